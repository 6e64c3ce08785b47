"""Where `bracekit place` spends its time: per-phase timers around the command's own steps, medians over runs.

    python tools/place_phases.py SPEC [--runs 5] [--workers 2]

Each run is a new process (``python tools/place_phases.py --child ...``) that wraps the command's steps
(`bracekit.cli.place`'s worker imports and fork set-up, `prepare`, the cluster's start, `run_place`,
`write_outputs`, the cluster's close) with wall-clock marks and runs ``bracekit place SPEC --out TMP --workers W
--no-figures`` through `bracekit.cli.main.main`; the parent prints each mark's median time since the child's
start (s), with the load average and the commit.
"""

from __future__ import annotations

import argparse
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

T0 = time.perf_counter()


def _mark(text: str) -> None:
    print(f"[{time.perf_counter() - T0:7.3f}] {text}", file=sys.stderr, flush=True)


def _child(spec: str, workers: int, out: str) -> int:
    """Run the command with its steps timed (this process)."""
    _mark("start")
    import importlib

    cli = importlib.import_module("bracekit.cli.main")
    place_cli = importlib.import_module("bracekit.cli.place")
    import bracekit.studies.place.engine as engine
    import bracekit.studies.place.report as report
    import bracekit.studies.sweep.engine as sweep_engine

    _mark("bracekit and its CLI imported")

    def timed(module: Any, name: str) -> None:
        f: Callable[..., Any] = getattr(module, name)

        def wrapper(*a: Any, **k: Any) -> Any:
            _mark(f"{name} starts")
            try:
                return f(*a, **k)
            finally:
                _mark(f"{name} ends")

        setattr(module, name, wrapper)

    def timed_context(module: Any, name: str, inside: str) -> None:
        f = getattr(module, name)

        @contextmanager
        def wrapper(*a: Any, **k: Any) -> Iterator[Any]:
            _mark(f"{name} starts")
            with f(*a, **k) as value:
                _mark(inside)
                yield value
                _mark(f"{name} closing")
            _mark(f"{name} closed")

        setattr(module, name, wrapper)

    timed_context(place_cli, "_forked_workers", "the workers' modules imported")
    timed_context(sweep_engine, "dask_client", "the cluster up")
    for name in ("prepare", "run_place"):
        timed(engine, name)
    timed(report, "write_outputs")
    code = int(cli.main(["place", spec, "--out", out, "--workers", str(workers), "--no-figures"]))
    _mark("the command returned")
    return code


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("spec")
    p.add_argument("--runs", type=int, default=5)
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--child", metavar="OUT", default=None, help=argparse.SUPPRESS)
    a = p.parse_args()
    if a.child is not None:
        sys.exit(_child(a.spec, a.workers, a.child))
    marks: dict[str, list[float]] = {}
    load0 = os.getloadavg()[0]
    with tempfile.TemporaryDirectory(prefix="place-phases-") as tmp:
        for i in range(a.runs):
            cmd = [sys.executable, __file__, a.spec, "--workers", str(a.workers), "--child", str(Path(tmp) / str(i))]
            done = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, check=False)
            if done.returncode not in (0, 1):
                raise SystemExit(f"the timed command failed (exit {done.returncode}): {done.stderr[-400:]}")
            for line in done.stderr.splitlines():
                m = re.match(r"\[\s*([\d.]+)\] (.*)", line)
                if m:
                    marks.setdefault(m.group(2), []).append(float(m.group(1)))
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True, check=False)
    print(
        f"{a.spec}, {a.workers} workers, medians of {a.runs} runs (s since the process's start); load "
        f"{load0:.2f}–{os.getloadavg()[0]:.2f}; commit {commit.stdout.strip() or '?'}"
    )
    for name, times in marks.items():
        if len(times) == a.runs:
            print(f"{statistics.median(times):7.3f}  {name}")


if __name__ == "__main__":
    main()
