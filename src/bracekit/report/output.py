"""Write a run's outputs whole or not at all: everything goes to a temporary sibling folder first."""

from __future__ import annotations

import json
import math
import os
import shutil
import tempfile
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from bracekit.errors import InputError
from bracekit.report.table import table_csv, table_markdown

if TYPE_CHECKING:
    from bracekit.simulation.run import RunResult

#: Every file `write_run` may write; a re-run into the same folder removes the ones it does not rewrite.
FILES = (
    "summary.json",
    "summary_all_models.json",
    "table.md",
    "table.csv",
    "trajectories.npz",
    "fig2_film_strip.png",
    "fig3_ellipsoids.png",
    "fig4_measures.png",
    "animation.gif",
)


def _clean(value: Any) -> Any:
    """JSON-safe copy: numpy scalars → Python, non-finite floats refused (never silently written)."""
    if isinstance(value, dict):
        return {str(k): _clean(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_clean(v) for v in value]
    if isinstance(value, np.ndarray):
        return _clean(value.tolist())
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        raise ValueError(f"refusing to write a non-finite number ({value}) to JSON")
    return value


def to_json(data: Any) -> str:
    """Indented JSON of SI results; raises ValueError on NaN or inf."""
    return json.dumps(_clean(data), indent=2, allow_nan=False)


@contextmanager
def atomic_directory(out: Path, owned: tuple[str, ...] = ()) -> Iterator[Path]:
    """Yield a temporary folder; on success its files replace those in `out`, on error nothing is left.

    Files named in `owned` that the new run did not write are removed from `out`, so a folder never mixes
    two runs' outputs.
    """
    if str(out).strip() in ("", "."):
        raise InputError("the output folder must be a named folder (e.g. --out bracekit-out), not '' or '.'")
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise InputError(f"output path {out} exists and is not a folder; give a folder path with --out")
    parent = out.parent if str(out.parent) else Path(".")
    try:
        parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.tmp-", dir=parent))
    except OSError as exc:
        raise InputError(f"cannot write to {parent}: {exc.strerror}; choose another --out folder") from exc
    try:
        yield tmp
        if not out.exists():
            os.replace(tmp, out)
            return
        new = {item.name for item in tmp.iterdir()}
        for name in owned:
            if name not in new and (out / name).is_file():
                (out / name).unlink()
        for item in tmp.iterdir():
            os.replace(item, out / item.name)
        tmp.rmdir()
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)


def save_trajectories(result: RunResult, path: Path) -> None:
    """All runs as one NPZ: keys '<model>/<strategy>/t', '.../q' and '.../<measure>' (SI units)."""
    arrays: dict[str, np.ndarray] = {"joint_names": np.array(result.scenario.robot.joint_names)}
    for model, runs in result.trajectories.items():
        for name, tr in runs.items():
            arrays[f"{model}/{name}/t"] = tr.t
            arrays[f"{model}/{name}/q"] = tr.q
            for key, values in tr.measures.items():
                arrays[f"{model}/{name}/{key}"] = values
    with open(path, "wb") as fh:
        np.savez_compressed(fh, **arrays)


def write_run(
    result: RunResult, out: Path, *, figures: bool = True, progress: Callable[[str], None] | None = None
) -> list[Path]:
    """Write summary.json, table.md/.csv, trajectories.npz and (optionally) Figures 2–4 and the GIF."""
    steps: list[tuple[str, Callable[[Path], None]]] = [
        ("summary.json", lambda p: p.write_text(to_json(result.summary) + "\n", encoding="utf-8")),
        ("summary_all_models.json", lambda p: p.write_text(to_json(result.summaries) + "\n", encoding="utf-8")),
        ("table.md", lambda p: p.write_text(table_markdown(result.summaries, result.scenario.name), encoding="utf-8")),
        ("table.csv", lambda p: p.write_text(table_csv(result.summaries), encoding="utf-8")),
        ("trajectories.npz", lambda p: save_trajectories(result, p)),
    ]
    if figures:
        from bracekit.report import figures as fig  # matplotlib only when figures are asked for

        steps += [
            ("fig2_film_strip.png", lambda p: fig.figure_film_strip(result, p)),
            ("fig3_ellipsoids.png", lambda p: fig.figure_ellipsoids(result, p)),
            ("fig4_measures.png", lambda p: fig.figure_measures(result, p)),
            ("animation.gif", lambda p: fig.animate(result, p)),
        ]
    with atomic_directory(out, owned=FILES) as tmp:
        for name, write in steps:
            if progress is not None:
                progress(name)
            write(tmp / name)
    return [Path(out) / name for name, _ in steps]
