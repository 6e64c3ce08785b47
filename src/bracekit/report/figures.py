"""Figures 2–4 of the paper, the capacity figure and the animation of a run (matplotlib, Agg): every file of a run.

Fig. 2 and the animation draw the robot's link volumes (:mod:`bracekit.report.scene`) in an orthographic view,
every strategy of the run: Fig. 2 as a film strip (one row per strategy), the animation side by side. Fig. 3
draws the compliance ellipsoids in two orthographic views with metric axes; Fig. 4 and the capacity figure plot
the measures along the task with units on every axis and one legend for all panels.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from bracekit.report import forked
from bracekit.report.ellipsoid_figure import ellipsoid_figure, figure_ellipsoids
from bracekit.report.figure_common import COLORS, DPI, _label, _scene
from bracekit.report.film import RunAnimation, animate, figure_film_strip, film_strip
from bracekit.report.frozen_heap import frozen_heap
from bracekit.report.measure_figures import (
    capacity_figure,
    figure_capacity,
    figure_measures,
    has_capacity,
    measures_figure,
)

if TYPE_CHECKING:
    from bracekit.simulation.run import RunResult

__all__ = [
    "COLORS",
    "DPI",
    "RunAnimation",
    "_label",
    "_scene",
    "animate",
    "capacity_figure",
    "ellipsoid_figure",
    "figure_capacity",
    "figure_ellipsoids",
    "figure_files",
    "figure_film_strip",
    "figure_measures",
    "film_strip",
    "has_capacity",
    "measures_figure",
    "write_figures",
]


# --- every figure of a run ---------------------------------------------------------------------------
def figure_files(result: RunResult) -> list[str]:
    """The names of the figure files of a run, in the order :func:`write_figures` writes them."""
    names = ["fig2_film_strip.png", "fig3_ellipsoids.png", "fig4_measures.png", "animation.gif"]
    return [*names, "fig_capacity.png"] if has_capacity(result) else names


def write_figures(result: RunResult, folder: Path, progress: Callable[[str], None] | None = None) -> list[Path]:
    """Write every figure of the run and the animation into `folder`.

    The animation is drawn in a forked child process while the figures are drawn here, where that is
    available (:mod:`bracekit.report.forked`); else one after the other.

    Args:
        result: the run.
        folder: an existing folder.
        progress: called with each file name before it is written (the animation's when it is waited for).

    Returns:
        The paths written, in the order of :func:`figure_files`.

    Raises:
        OutputError: the animation could not be written (its child process failed writing).
        BracekitError: the animation could not be drawn.
    """
    names = figure_files(result)
    writers: dict[str, Callable[[], None]] = {
        "fig2_film_strip.png": lambda: figure_film_strip(result, folder / "fig2_film_strip.png"),
        "fig3_ellipsoids.png": lambda: figure_ellipsoids(result, folder / "fig3_ellipsoids.png"),
        "fig4_measures.png": lambda: figure_measures(result, folder / "fig4_measures.png"),
        "animation.gif": lambda: animate(result, folder / "animation.gif"),
        "fig_capacity.png": lambda: figure_capacity(result, folder / "fig_capacity.png"),
    }
    with frozen_heap():  # the run's objects stay out of the collector's passes while drawing (and the fork)
        _scene(result)  # made once, shared with the child
        job = forked.start(writers["animation.gif"], "animation.gif")
        try:
            for name in names:
                if progress is not None:
                    progress(name)
                if name == "animation.gif" and job is not None:
                    job.wait()
                else:
                    writers[name]()
        finally:
            if job is not None:
                job.stop()
    return [folder / name for name in names]
