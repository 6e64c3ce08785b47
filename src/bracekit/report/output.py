"""A run's output files (summary, tables, trajectories, scene, figures), written whole into a checked folder.

The folder rules (checked and locked before any computation, replaced whole, user files never deleted) are in
:mod:`bracekit.report.folder`; this module re-exports its entry points. In short, for an output folder OUT:

* OUT is checked and locked before any computation; the new output is written beside it and swapped in
  whole (a kill at any point leaves the previous output or the new one; the next run recovers).
* Each file bracekit writes is listed in the manifest ``.bracekit-output.json`` with its SHA-256; only those
  are ever replaced, and a file bracekit did not write is never deleted or replaced.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Callable
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING, Any

import numpy as np

from bracekit.errors import MissingDependencyError
from bracekit.report.folder import OutputPlan, atomic_directory, prepare_output
from bracekit.report.frozen_heap import frozen_heap
from bracekit.report.swap import MANIFEST
from bracekit.report.table import table_csv, table_markdown
from bracekit.viewer.link_meshes import MESH_FILE, link_meshes, save_link_meshes
from bracekit.viewer.scene import scene_data

if TYPE_CHECKING:
    from bracekit.simulation.run import RunResult

#: Every file `write_run` may write (the first six without figures; meshes.npz too for a robot with meshes).
FILES = (
    "summary.json",
    "summary_all_models.json",
    "table.md",
    "table.csv",
    "trajectories.npz",
    "scene.json",
    "fig2_film_strip.png",
    "fig3_ellipsoids.png",
    "fig4_measures.png",
    "animation.gif",
    "fig_capacity.png",
)
__all__ = [
    "FILES",
    "MANIFEST",
    "OutputPlan",
    "atomic_directory",
    "prepare_output",
    "run_files",
    "save_trajectories",
    "to_json",
    "write_run",
]


def run_files(figures: bool = True, meshes: bool = False) -> tuple[str, ...]:
    """The names of the files `write_run` writes, with or without the figures and the robot's meshes.

    `meshes`: whether the robot has link meshes to carry (``bool(link_meshes(robot))``).
    """
    data = (*FILES[:6], MESH_FILE) if meshes else FILES[:6]
    return (*data, *FILES[6:]) if figures else data


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


# --- a run's files -------------------------------------------------------------------------------------
def save_trajectories(result: RunResult, path: Path) -> None:
    """All runs as one NPZ: keys '<model>/<strategy>/t', '.../q' and '.../<measure>' (SI units)."""
    arrays: dict[str, Any] = {"joint_names": np.array(result.scenario.robot.joint_names)}
    for model, runs in result.trajectories.items():
        for name, tr in runs.items():
            arrays[f"{model}/{name}/t"] = tr.t
            arrays[f"{model}/{name}/q"] = tr.q
            for key, values in tr.measures.items():
                arrays[f"{model}/{name}/{key}"] = values
    with open(path, "wb") as fh:
        np.savez_compressed(fh, **arrays)


def write_run(
    result: RunResult,
    out: OutputPlan | str | os.PathLike[str],
    *,
    figures: bool = True,
    overwrite: bool = False,
    progress: Callable[[str], None] | None = None,
) -> list[Path]:
    """Write summary.json, table.md/.csv, trajectories.npz, scene.json (meshes.npz) and Figures 2–4 and the GIF, whole.

    Args:
        result: The run to report.
        out: The output folder, or a plan of :func:`prepare_output` (the command line checks OUT before running).
        figures: Also write Figures 2–4 and the animation (needs matplotlib).
        overwrite: Replace bracekit's files in a folder that also holds other files; those are kept.
        progress: Called with each file name before it is written.

    Returns:
        The paths of the files written (the manifest `.bracekit-output.json` aside).

    Raises:
        OutputError: The folder is refused or cannot be written (see :func:`prepare_output`); nothing is changed.
    """
    steps: list[tuple[str, Callable[[Path], object]]] = [
        ("summary.json", lambda p: p.write_text(to_json(result.summary) + "\n", encoding="utf-8")),
        ("summary_all_models.json", lambda p: p.write_text(to_json(result.summaries) + "\n", encoding="utf-8")),
        ("table.md", lambda p: p.write_text(table_markdown(result.summaries, result.scenario.name), encoding="utf-8")),
        ("table.csv", lambda p: p.write_text(table_csv(result.summaries, result.scenario.name), encoding="utf-8")),
        ("trajectories.npz", lambda p: save_trajectories(result, p)),
    ]
    meshes = link_meshes(result.scenario.robot)
    if meshes:  # the robot's meshes travel with the run (scene.json names them)
        steps.append((MESH_FILE, lambda p: save_link_meshes(meshes, p)))
    scene = scene_data(result, meshes=bool(meshes))
    steps.append(("scene.json", lambda p: p.write_text(to_json(scene) + "\n", encoding="utf-8")))
    names = [name for name, _ in steps]
    drawing: ModuleType | None = None
    if figures:
        try:
            with frozen_heap():  # matplotlib's import, out of the way of the run's objects
                from bracekit.report import figures as fig  # matplotlib only when figures are asked for
        except ImportError as exc:
            raise MissingDependencyError(
                f"figures need matplotlib, which cannot be imported ({exc}): pip install 'bracekit[viz]', "
                "or write without figures"
            ) from exc
        names += fig.figure_files(result)
        drawing = fig
    with atomic_directory(out, overwrite=overwrite, files=names, command="bracekit.report.write_run") as tmp:
        for name, write in steps:
            if progress is not None:
                progress(name)
            write(tmp / name)
        if drawing is not None:
            drawing.write_figures(result, tmp, progress)
    shown = out.shown if isinstance(out, OutputPlan) else os.fspath(out)
    return [Path(shown) / name for name in names]
