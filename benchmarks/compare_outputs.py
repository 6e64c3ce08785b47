"""Compare two output folders of `bracekit run` number by number: the largest relative difference.

    python benchmarks/compare_outputs.py OLD NEW paper two-braces panda panda-holding

OLD/NAME and NEW/NAME are `bracekit run NAME --out …` folders (e.g. two versions' outputs); summary.json,
summary_all_models.json and trajectories.npz are compared: keys, strings and non-finite entries exactly, numbers
by their relative difference (over the largest magnitude of an array). Prints each difference that is not a
rounding one and the largest relative difference with where it is.
"""

from __future__ import annotations

import json
import sys
from typing import Any

import numpy as np

worst: list[Any] = [0.0, ""]


def _numbers(a: Any, b: Any, where: str) -> None:
    a, b = np.asarray(a, float), np.asarray(b, float)
    if a.shape != b.shape:
        print("shape", where, a.shape, b.shape)
        return
    fin = np.isfinite(a) & np.isfinite(b)
    if not np.array_equal(np.isfinite(a), np.isfinite(b)) or not np.array_equal(a[~fin], b[~fin]):
        print("non-finite entries differ", where)
        return
    if fin.any():
        scale = max(float(np.max(np.abs(b[fin]))), 1e-300)
        d = float(np.max(np.abs(a[fin] - b[fin]))) / scale
        if d > worst[0]:
            worst[:] = [d, where]


def _walk(a: Any, b: Any, where: str) -> None:
    if isinstance(b, dict):
        if set(a) != set(b):
            print("keys", where, sorted(set(a) ^ set(b)))
        for k in b:
            if k in a:
                _walk(a[k], b[k], f"{where}.{k}")
    elif isinstance(b, list) and (not b or not all(isinstance(x, int | float) for x in b)):
        if len(a) != len(b):
            print("length", where, len(a), len(b))
            return
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            _walk(x, y, f"{where}[{i}]")
    elif isinstance(b, int | float | list) and not isinstance(b, bool) and not isinstance(a, str | None):
        _numbers(a, b, where)
    elif a != b:
        print("differs", where, repr(a)[:160], "|", repr(b)[:160])


def main(old: str, new: str, names: list[str]) -> None:
    for name in names:
        for f in ("summary.json", "summary_all_models.json"):
            with open(f"{new}/{name}/{f}") as fa, open(f"{old}/{name}/{f}") as fb:
                _walk(json.load(fa), json.load(fb), f"{name}/{f}")
        a, b = np.load(f"{new}/{name}/trajectories.npz"), np.load(f"{old}/{name}/trajectories.npz")
        if set(a.files) != set(b.files):
            print("npz keys", name, sorted(set(a.files) ^ set(b.files)))
        for k in b.files:
            if k not in a.files:
                continue
            if b[k].dtype.kind in "USO":
                if not np.array_equal(a[k], b[k]):
                    print("npz differs", name, k)
            else:
                _numbers(a[k], b[k], f"{name}/trajectories.npz/{k}")
    print(f"largest relative difference {worst[0]:.3g} at {worst[1]}")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], sys.argv[3:])
