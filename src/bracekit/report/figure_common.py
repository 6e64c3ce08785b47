"""What the figures of a run share: labels, the run's scene (made once), legends, the scale bar and sizes."""

from __future__ import annotations

import weakref
from typing import TYPE_CHECKING, Any

import matplotlib

matplotlib.use("Agg")
import numpy as np
from matplotlib.artist import Artist
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch
from numpy.typing import NDArray

from bracekit.compliance.preloaded import run_compliance
from bracekit.report.scene import (
    BASE_COLOR,
    BRACE_COLOR,
    REGION_COLOR,
    STRATEGY_COLORS,
    SURFACE_COLOR,
    TASK_COLOR,
    RunScene,
)
from bracekit.report.table import STRATEGY_LABELS

if TYPE_CHECKING:
    from bracekit.kinematics import BracedState
    from bracekit.simulation.run import RunResult
    from bracekit.simulation.simulate import Trajectory

Array = NDArray[np.float64]
#: Colour of each strategy (tip traces, ellipsoids, curves).
COLORS = STRATEGY_COLORS
#: Resolution of the PNG figures, dots per inch.
DPI = 100
_FONT = 9.0
_GIF_DPI = 90
_MIN_VIEW_M = 0.04  # the least extent of a view of Fig. 3, m


def _label(name: str) -> str:
    return STRATEGY_LABELS.get(name, name)


def _runs(result: RunResult) -> dict[str, Trajectory]:
    return result.trajectories[result.compliance_model]


def _main_run(result: RunResult) -> Trajectory:
    runs = _runs(result)
    return runs.get("braced_gradient_projection") or next(iter(runs.values()))


def _model_of(result: RunResult, tr: Trajectory) -> str:
    return result.compliance_model if tr.braced else "free-space"


def _new_figure(width: float, height: float) -> Figure:
    """A figure (inches) on an Agg canvas, outside pyplot (nothing to close, no global state)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    fig = Figure(figsize=(width, height), dpi=DPI)
    FigureCanvasAgg(fig)
    return fig


def _title(fig: Figure, text: str, size: float, inset: float, height: float) -> None:
    """The figure's title, centred, its top `inset` inches below the top of a figure `height` inches tall."""
    fig.suptitle(text, fontsize=size, y=1.0 - inset / height, va="top")


def _wrapped(text: str, inches: float, size: float = _FONT + 1) -> str:
    """`text` on two lines (at its middle space) when it is longer than `inches` at font size `size` (pt)."""
    if len(text) * 0.55 * size / 72.0 <= inches or " " not in text:
        return text
    mid = len(text) // 2
    cut = min((i for i, ch in enumerate(text) if ch == " "), key=lambda i: abs(i - mid))
    return text[:cut] + "\n" + text[cut + 1 :]


_SCENES: list[tuple[weakref.ref[RunResult], RunScene]] = []


def _scene(result: RunResult) -> RunScene:
    """The scene of the run model's runs; the last one is kept while its run lives (Fig. 2 and the animation)."""
    if _SCENES and _SCENES[0][0]() is result:
        return _SCENES[0][1]
    scene = RunScene(result, _runs(result))
    _SCENES[:] = [(weakref.ref(result), scene)]
    return scene


def _sample(tr: Trajectory, t: float) -> int:
    """Index of the sample of `tr` nearest to time t (the last one after a run stopped early)."""
    return int(np.argmin(np.abs(tr.t - t)))


# --- Fig. 2 and the animation: the robot's link volumes -------------------------------------------------
def _scene_legend(scene: RunScene) -> tuple[list[Artist], list[str]]:
    handles: list[Artist] = [Patch(fc=p.colors[0], ec=p.colors[1]) for p in scene.parts]
    labels = [p.label for p in scene.parts]
    handles += [
        Patch(fc=BASE_COLOR),
        Patch(fc=SURFACE_COLOR, ec="#8a7a50"),
        Line2D([], [], color=REGION_COLOR, ls="--"),
        Line2D([], [], color=TASK_COLOR, ls=(0, (4, 2))),
        Line2D([], [], color="0.4", lw=1.6),
        Line2D([], [], color=BRACE_COLOR, marker="o", mfc=BRACE_COLOR, mec="k", lw=1.0),
        Line2D([], [], ls="none", marker="o", mfc="white", mec="k"),
    ]
    obstacle = "brace surface" if len(scene.braces) == 1 else "brace surfaces"
    labels += [
        "base",
        f"{obstacle} (top and body below)",
        "bracing region",
        "task path",
        "tip trace (colour of the strategy)",
        "brace point b and its path",
        "b of the unbraced run",
    ]
    return handles, labels


def _scale_bar(ax: Axes, scene: RunScene) -> None:
    """A bar of a round length (m) and the world axes, each in an empty corner of the panel."""
    x0, x1, y0, y1 = scene.limits
    width, height = x1 - x0, y1 - y0
    length = _nice(0.18 * width)
    corners = scene.free_corners()

    def anchor(corner: str, w: float, h: float) -> tuple[float, float]:
        x = x0 + (0.03 * width if "left" in corner else width - 0.03 * width - w)
        y = y0 + (0.05 * height if "lower" in corner else height - 0.05 * height - h)
        return x, y

    px, py = anchor(corners[0], length, 0.06 * height)
    ax.plot([px, px + length], [py, py], color="k", lw=2.0, solid_capstyle="butt", zorder=20)
    ax.text(px + length / 2, py + 0.012 * width, f"{length:g} m", ha="center", va="bottom", fontsize=7, zorder=20)
    cam = scene.camera
    arm = 0.06 * width
    ox, oy = anchor(corners[1], 2 * arm, 2 * arm)
    ox, oy = ox + arm, oy + arm
    for axis, name in zip(np.eye(3), "xyz", strict=True):
        dx, dy = cam.project(axis) * arm
        if abs(dx) + abs(dy) < 0.05 * arm:  # seen end on
            ax.plot([ox], [oy], "o", color="0.3", ms=2.0, zorder=20)
            ax.text(ox + 0.2 * arm, oy + 0.2 * arm, name, fontsize=7, color="0.3", zorder=20)
            continue
        ax.annotate(
            "", (ox + dx, oy + dy), (ox, oy), arrowprops={"arrowstyle": "-|>", "color": "0.3", "lw": 0.8}, zorder=20
        )
        ax.text(ox + 1.3 * dx, oy + 1.3 * dy, name, fontsize=7, color="0.3", ha="center", va="center", zorder=20)


def _view_text(scene: RunScene) -> str:
    cam = scene.camera
    return f"orthographic view from azimuth {cam.azimuth:.0f}°, elevation {cam.elevation:.0f}°"


def _tip_compliance(result: RunResult, st: Any, braced: bool) -> Array:
    """The tip compliance (6×6) of the run's model at a state (free space for the unbraced run)."""
    h = result.scenario.holding
    return run_compliance(st, result.compliance_model, braced, preload=h.preload, gravity=h.gravity)


def _state(result: RunResult, q: Array) -> BracedState | Any:
    """The braced state at q: the one-brace BracedState, or the stacked state of several braces."""
    braced = result.scenario.braced
    return braced.state(q)


def _nice(value: float) -> float:
    """The largest 1-2-5 number ≤ value (> 0)."""
    e = np.floor(np.log10(value))
    for m in (5.0, 2.0, 1.0):
        if m * 10**e <= value:
            return float(m * 10**e)
    return float(10**e)
