"""Figures 2–4 of the paper, the capacity figure and the animation of a run (matplotlib, Agg).

Fig. 2 and the animation draw the robot's link volumes (:mod:`bracekit.report.scene`) in an orthographic view,
every strategy of the run: Fig. 2 as a film strip (one row per strategy), the animation side by side. Fig. 3
draws the compliance ellipsoids in two orthographic views with metric axes; Fig. 4 and the capacity figure plot
the measures along the task with units on every axis and one legend for all panels.
"""

from __future__ import annotations

import weakref
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import matplotlib

matplotlib.use("Agg")
import numpy as np
from matplotlib.artist import Artist
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch, Polygon
from matplotlib.ticker import MaxNLocator
from numpy.typing import NDArray
from PIL import Image

from bracekit.compliance.directional import CI_LABEL, CT_LABEL
from bracekit.compliance.first_order import compliance_ellipsoids
from bracekit.compliance.preloaded import run_compliance
from bracekit.errors import NumericalError
from bracekit.report import forked
from bracekit.report.gif import quantize, render_frames, save_gif
from bracekit.report.projection import OrthoCamera, ellipsoid_outline
from bracekit.report.scene import (
    BASE_COLOR,
    BRACE_COLOR,
    REGION_COLOR,
    STRATEGY_COLORS,
    SURFACE_COLOR,
    TASK_COLOR,
    RunScene,
    SceneView,
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


def figure_film_strip(result: RunResult, path: Path, frames: int = 5) -> None:
    """Write Fig. 2 (:func:`film_strip`) as a PNG."""
    film_strip(result, frames).savefig(path, dpi=DPI)


def film_strip(result: RunResult, frames: int = 5) -> Figure:
    """Fig. 2: every strategy's run at `frames` instants (rows: strategies), link volumes in an orthographic view.

    The panels are the figure's axes, row by row (strategies in the run's order), `frames` per row.
    """
    runs = _runs(result)
    scene = _scene(result)
    names = list(runs)
    t_end = max(float(tr.t[-1]) for tr in runs.values())
    times = np.linspace(0.0, t_end, frames)
    pw = 2.9  # panel width, in
    ph = pw / float(np.clip(scene.aspect, 0.5, 4.0))
    left, top, bottom, gap = 0.45, 0.62, 0.62, 0.06
    width = left + frames * pw + (frames - 1) * gap + 0.1
    height = top + len(names) * ph + (len(names) - 1) * gap + bottom
    fig = _new_figure(width, height)
    for r, name in enumerate(names):
        tr = runs[name]
        for c, t in enumerate(times):
            x = (left + c * (pw + gap)) / width
            y = (bottom + (len(names) - 1 - r) * (ph + gap)) / height
            ax = fig.add_axes((x, y, pw / width, ph / height))
            view = SceneView(ax, scene, name)
            k = _sample(tr, float(t))
            view.show(k)
            ax.add_artist(
                Polygon(
                    [[0, 0], [1, 0], [1, 1], [0, 1]], closed=True, transform=ax.transAxes, fc="none", ec="0.8", lw=0.6
                )
            )
            if abs(float(tr.t[k]) - t) > 0.5 * (tr.t[1] - tr.t[0] if tr.t.size > 1 else 1.0):
                ax.text(
                    0.5,
                    0.04,
                    f"run stopped at t = {tr.t[-1]:.1f} s",
                    transform=ax.transAxes,
                    ha="center",
                    fontsize=7,
                    color="tab:red",
                )
            if r == 0:
                ax.set_title(f"t = {t:.1f} s", fontsize=_FONT + 1, pad=3)
            if c == 0:
                fig.text(
                    (left - 0.06) / width,
                    y + 0.5 * ph / height,
                    _wrapped(_label(name), ph),
                    rotation=90,
                    ha="right",
                    va="center",
                    fontsize=_FONT + 1,
                    color=COLORS.get(name, "k"),
                    fontweight="bold",
                )
                if r == 0:
                    _scale_bar(ax, scene)
    handles, labels = _scene_legend(scene)
    fig.legend(
        handles, labels, loc="lower center", ncol=5, fontsize=_FONT - 1, frameon=False, bbox_to_anchor=(0.5, 0.0)
    )
    fig.suptitle(
        f"Fig. 2: the runs of scenario {result.scenario.name} ({result.compliance_model} compliance for the braced "
        f"runs); {_view_text(scene)}",
        fontsize=_FONT + 2,
        y=1.0 - 0.1 / height,
        va="top",
    )
    return fig


def animate(result: RunResult, path: Path, frames: int = 60, fps: int = 12) -> None:
    """Write every strategy's run side by side as a looping GIF (:class:`RunAnimation`)."""
    anim = RunAnimation(result, frames)
    save_gif(quantize(anim.images(), keep=anim.colors), path, fps)


class RunAnimation:
    """Every strategy's run side by side (link volumes, orthographic view, tip traces), frame by frame.

    Args:
        result: the run.
        frames: number of frames (at most the longest run's samples), evenly spaced in time.

    Attributes:
        figure: the figure; its axes are the panels, one per strategy in the run's order.
        views: the panels' scene views.
        times: the time of each frame (s).
    """

    def __init__(self, result: RunResult, frames: int = 60) -> None:
        runs = _runs(result)
        scene = _scene(result)
        self.names = list(runs)
        self.runs = runs
        self.t_end = max(float(tr.t[-1]) for tr in runs.values())
        longest = max(tr.t.size for tr in runs.values())
        self.times = np.linspace(0.0, self.t_end, max(1, min(frames, longest)))
        pw = 3.4
        ph = pw / float(np.clip(scene.aspect, 0.6, 3.0))
        top, bottom, gap = 0.5, 0.5, 0.05
        width = len(self.names) * pw + (len(self.names) + 1) * gap
        height = top + ph + bottom
        fig = _new_figure(width, height)
        fig.set_dpi(_GIF_DPI)
        self.views = []
        for c, name in enumerate(self.names):
            ax = fig.add_axes(((gap + c * (pw + gap)) / width, bottom / height, pw / width, ph / height))
            ax.set_title(_label(name), fontsize=_FONT + 1, color=COLORS.get(name, "k"), fontweight="bold", pad=2)
            self.views.append(SceneView(ax, scene, name, animated=True))
        handles, labels = _scene_legend(scene)
        keep = [i for i, lab in enumerate(labels) if not lab.startswith(("base", "b of"))]
        fig.legend(
            [handles[i] for i in keep],
            [labels[i] for i in keep],
            loc="lower center",
            ncol=(len(keep) + 1) // 2,
            fontsize=7,
            frameon=False,
            handlelength=1.6,
            columnspacing=1.2,
            borderaxespad=0.2,
        )
        self.clock = fig.text(0.5, 1.0 - 0.06 / height, "", ha="center", va="top", fontsize=_FONT + 1, animated=True)
        fig.text(
            0.99,
            1.0 - 0.06 / height,
            f"scenario {result.scenario.name}, {self.t_end:g} s",
            ha="right",
            va="top",
            fontsize=_FONT - 1,
            color="0.35",
        )
        self.figure = fig
        scene_colors = [c for p in scene.parts for c in p.colors]
        #: the flat colours of the frames (kept exact in a GIF's palette)
        self.colors = [
            "white",
            "black",
            BRACE_COLOR,
            SURFACE_COLOR,
            REGION_COLOR,
            BASE_COLOR,
            *scene_colors,
            *(COLORS.get(n, "C0") for n in self.names),
        ]

    def samples(self, i: int) -> list[int]:
        """The sample of each run shown in frame i."""
        t = float(self.times[i])
        return [_sample(self.runs[name], t) for name in self.names]

    def draw(self, i: int) -> list[Artist]:
        """Set the artists to frame i; return the changing ones in drawing order."""
        self.clock.set_text(f"t = {float(self.times[i]):4.1f} s")
        arts: list[Artist] = [self.clock]
        for view, k in zip(self.views, self.samples(i), strict=True):
            arts += view.show(k)
        return arts

    def images(self) -> list[Image.Image]:
        """The RGB image of every frame."""
        return render_frames(self.figure, len(self.times), self.draw)


# --- Fig. 3: compliance ellipsoids -----------------------------------------------------------------------
def _tip_compliance(result: RunResult, st: Any, braced: bool) -> Array:
    """The tip compliance (6×6) of the run's model at a state (free space for the unbraced run)."""
    h = result.scenario.holding
    return run_compliance(st, result.compliance_model, braced, preload=h.preload, gravity=h.gravity)


def _state(result: RunResult, q: Array) -> BracedState | Any:
    """The braced state at q: the one-brace BracedState, or the stacked state of several braces."""
    braced = result.scenario.braced
    return braced.state(q)


#: Axis-aligned orthographic views: (name, camera, world axis index on the screen's right and up).
_VIEWS = {
    "y": ("front view (along +y)", OrthoCamera(-90.0, 0.0), (0, 2)),
    "z": ("top view (along −z)", OrthoCamera(-90.0, 90.0), (0, 1)),
    "x": ("side view (along −x)", OrthoCamera(0.0, 0.0), (1, 2)),
}


def _ellipsoid_views(path_pts: Array) -> list[str]:
    """Two world axes to look along: the one nearest the task path's normal first, then z (or y)."""
    centred = path_pts - path_pts.mean(axis=0)
    _, _, vt = np.linalg.svd(centred, full_matrices=False)
    first = "xyz"[int(np.argmax(np.abs(vt[-1])))]
    second = "z" if first != "z" else "y"
    return [first, second]


def _nice(value: float) -> float:
    """The largest 1-2-5 number ≤ value (> 0)."""
    e = np.floor(np.log10(value))
    for m in (5.0, 2.0, 1.0):
        if m * 10**e <= value:
            return float(m * 10**e)
    return float(10**e)


def figure_ellipsoids(result: RunResult, path: Path, points: int = 6) -> None:
    """Write Fig. 3 (:func:`ellipsoid_figure`) as a PNG."""
    ellipsoid_figure(result, points).savefig(path, dpi=DPI)


def ellipsoid_figure(result: RunResult, points: int = 6) -> Figure:
    """Fig. 3: translational compliance ellipsoids along the task, one column per strategy, two views per run.

    The axes are the panels, row by row: the first view for each strategy, then the second.
    """
    runs = _runs(result)
    cases = []
    semis = []
    for name, tr in runs.items():
        idx = np.linspace(0, tr.q.shape[0] - 1, points + 1).astype(int)[:-1]
        items = []
        for k in idx:
            st = _state(result, tr.q[k])
            ell = compliance_ellipsoids(_tip_compliance(result, st, tr.braced)).translational
            items.append((np.asarray(st.e), ell.axes * ell.semi_axes))
            semis.append(float(ell.semi_axes.max()))
        cases.append((name, items))
    task = result.scenario.task
    path_pts = np.array([task.position(t) for t in np.linspace(0.0, task.duration, 240)])
    extent = float(np.max(np.ptp(path_pts, axis=0)))
    scale = 0.25 * max(extent, 0.02) / max(semis)  # the largest semi-axis a quarter of the path's size
    views = _ellipsoid_views(path_pts)
    outlines = {
        v: [[ellipsoid_outline(_VIEWS[v][1], e, scale * shape) for e, shape in items] for _, items in cases]
        for v in views
    }
    boxes = {}
    for v in views:
        cam = _VIEWS[v][1]
        pts = np.vstack([cam.project(path_pts)] + [o for case in outlines[v] for o in case])
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        centre = 0.5 * (lo + hi)
        half = 0.5 * np.maximum(hi - lo, _MIN_VIEW_M)
        half[1] = max(half[1], 0.35 * half[0])  # a flat view gets room for its ticks
        half *= 1.06
        boxes[v] = (centre - half, centre + half)
    pw = 3.3  # panel width, in
    heights = {v: pw * float((boxes[v][1][1] - boxes[v][0][1]) / (boxes[v][1][0] - boxes[v][0][0])) for v in views}
    left, right, top, bottom, hgap, vgap = 0.75, 0.15, 0.95, 0.55, 0.8, 0.7
    ncol = len(cases)
    width = left + ncol * pw + (ncol - 1) * hgap + right
    height = top + sum(heights.values()) + vgap * (len(views) - 1) + bottom
    fig = _new_figure(width, height)
    ref = _nice(max(semis))
    y = height - top
    for r, v in enumerate(views):
        title, cam, (ix, iy) = _VIEWS[v]
        y -= heights[v]
        for c, (name, items) in enumerate(cases):
            ax = fig.add_axes(((left + c * (pw + hgap)) / width, y / height, pw / width, heights[v] / height))
            color = COLORS.get(name, "C0")
            flat = cam.project(path_pts)
            ax.plot(*np.vstack([flat, flat[:1]]).T, color=TASK_COLOR, lw=0.8, ls=(0, (4, 2)))
            for (e, _), outline in zip(items, outlines[v][c], strict=True):
                ax.add_patch(Polygon(outline, closed=True, fc=color, ec=color, alpha=0.35, lw=1.0))
                ax.add_patch(Polygon(outline, closed=True, fc="none", ec=color, lw=1.0))
                ax.plot(*cam.project(e), "o", color="k", ms=2.0)
            (lo, hi) = boxes[v]
            ax.set_xlim(lo[0], hi[0])
            ax.set_ylim(lo[1], hi[1])
            ax.set_aspect("equal", adjustable="box")
            ax.tick_params(labelsize=_FONT - 1)
            ax.xaxis.set_major_locator(MaxNLocator(5, steps=[1, 2, 2.5, 5, 10]))
            ax.yaxis.set_major_locator(MaxNLocator(5, steps=[1, 2, 2.5, 5, 10]))
            ax.set_xlabel(f"{'xyz'[ix]} [m]", fontsize=_FONT, labelpad=2)
            ax.set_ylabel(f"{'xyz'[iy]} [m]", fontsize=_FONT, labelpad=2)
            ax.grid(alpha=0.25)
            heading = f"({'abcdef'[c]}) {_label(name)}" if r == 0 else ""
            ax.set_title(
                f"{heading}\n{title}" if heading else title,
                fontsize=_FONT,
                pad=3,
                color=COLORS.get(name, "k") if r == 0 else "k",
            )
            if r == 0 and c == 0:
                bx, by = lo[0] + 0.04 * (hi[0] - lo[0]), lo[1] + 0.05 * (hi[1] - lo[1])
                ax.plot([bx, bx + scale * ref], [by, by], color="k", lw=2.0, solid_capstyle="butt")
                ax.text(
                    bx + 0.5 * scale * ref,
                    by + 0.02 * (hi[1] - lo[1]),
                    f"{ref:g} m/N",
                    ha="center",
                    va="bottom",
                    fontsize=_FONT - 2,
                )
        y -= vgap
    fig.suptitle(
        f"Fig. 3: translational compliance ellipsoids at {points} points of the task ({result.compliance_model} "
        f"model for the braced runs)\nsemi-axes: eigenvalues of the force block of the tip compliance, drawn at "
        f"{scale:.2f} m per m/N; dashed: the task path",
        fontsize=_FONT + 1,
        y=1.0 - 0.08 / height,
        va="top",
    )
    return fig


# --- Fig. 4 and the capacity figure: measures along the task ---------------------------------------------
def _ct_series(result: RunResult, tr: Any) -> Array | None:
    """c_t = β_xᵀC_ttβ_x (m/N) along a run, with the run's own compliance as C_i's; None if β_x rotates.

    A sample where the compliance cannot be computed is NaN (a visible gap in the curve).
    """
    sc = result.scenario
    out = np.full(tr.t.size, np.nan)
    for i, (t, q) in enumerate(zip(tr.t, tr.q, strict=True)):
        beta = sc.beta_x(float(t))
        if np.linalg.norm(beta[3:]) > 1e-12 * np.linalg.norm(beta):
            return None
        try:
            c = _tip_compliance(result, _state(result, q), tr.braced)
        except NumericalError:
            continue
        b = beta[:3] / np.linalg.norm(beta[:3])
        out[i] = b @ c[:3, :3] @ b
    return out


def _curves(result: RunResult, panels: list[tuple[str, str, str]], title: str, margins: bool = False) -> Figure:
    """A 2×2 figure of measures over time: (key, panel title, y label with unit) per panel, one shared legend."""
    runs = _runs(result)
    fig = _new_figure(11.0, 7.4)
    axes = fig.subplots(2, 2, sharex=True)
    fig.subplots_adjust(left=0.08, right=0.985, top=0.9, bottom=0.15, hspace=0.28, wspace=0.22)
    for ax, (key, heading, ylabel) in zip(axes.flat, panels, strict=True):
        margin = margins and key != "torque_ratio"
        for name, tr in runs.items():
            if key == "Ci":
                y = tr.measures[tr.ci_key(result.compliance_model)]
            elif key in tr.measures:
                y = tr.measures[key]
            else:
                continue
            if margin:
                y = np.clip(y, 1e-2, 1e2)
            ax.plot(tr.t, y, color=COLORS.get(name), label=_label(name), lw=1.4)
            ct = _ct_series(result, tr) if key == "Ci" else None
            if ct is not None:
                ax.plot(tr.t, ct, color=COLORS.get(name), lw=1.1, linestyle="--")
        if margins:
            ax.axhline(1.0, color="0.3", linestyle="--", linewidth=0.8)
            if margin:
                ax.set_yscale("log")
                ax.set_ylim(1e-2, 1.2e2)
            else:
                ax.set_ylim(
                    0.0,
                    max(1.2, *(float(np.max(tr.measures[key])) * 1.1 for tr in runs.values() if key in tr.measures)),
                )
        ax.set_title(heading, fontsize=_FONT + 1)
        ax.set_ylabel(ylabel, fontsize=_FONT)
        ax.tick_params(labelsize=_FONT - 0.5)
        ax.grid(alpha=0.3)
    for ax in axes[1]:
        ax.set_xlabel("time along the task [s]", fontsize=_FONT)
    handles = [Line2D([], [], color=COLORS.get(n), lw=2.0) for n in runs]
    fig.legend(
        handles,
        [_label(n) for n in runs],
        loc="lower center",
        ncol=len(handles),
        fontsize=_FONT + 1,
        frameon=False,
        bbox_to_anchor=(0.5, 0.0),
    )
    fig.suptitle(title, fontsize=_FONT + 2)
    return fig


def figure_measures(result: RunResult, path: Path) -> None:
    """Write Fig. 4 (:func:`measures_figure`) as a PNG."""
    measures_figure(result).savefig(path, dpi=DPI)


def measures_figure(result: RunResult) -> Figure:
    """Fig. 4: C_i, Πσ_t, Πσ_o and k of J̃ along the task for every strategy (2×2 axes, one legend).

    Panel (a) draws the paper's index C_i (solid) and, for a translational β_x, the translational compliance
    c_t along β_x (dashed, m/N) of the same compliance model.
    """
    return _curves(
        result,
        [
            ("Ci", f"(a) solid: {CI_LABEL};\ndashed: {CT_LABEL}", "C_i (mixed) and c_t [m/N]"),
            ("prod_sigma_t", "(b) Πσ_t of J̃ (rows 1–3, translational)", "Πσ_t [m³/rad³]"),
            ("prod_sigma_o", "(c) Πσ_o of J̃ (rows 4–6, rotational)", "Πσ_o [1] (rad/rad)"),
            ("k", "(d) Frobenius condition number k of J̃", "k [1]"),
        ],
        f"Fig. 4: measures along the task ({result.compliance_model} compliance model for the braced runs)",
    )


def has_capacity(result: RunResult) -> bool:
    """Whether the run computed statics (gravity, a preload or tool loads): then it has a capacity figure."""
    return any("torque_ratio" in tr.measures for runs in result.trajectories.values() for tr in runs.values())


def figure_capacity(result: RunResult, path: Path) -> None:
    """Write the capacity figure (:func:`capacity_figure`) as a PNG."""
    capacity_figure(result).savefig(path, dpi=DPI)


def capacity_figure(result: RunResult) -> Figure:
    """Capacity along the task: the load margins of each braced run and the peak |τ_i|/effort_i of every run.

    Margins are scales of the listed tool wrenches (> 1: the brace holds the listed load), on a log axis clipped
    to [0.01, 100]; the dashed line is 1. Margins beyond 100 (or infinite: nothing limits the load) are drawn at
    the top of the axis.
    """
    h = result.scenario.holding
    mu = "frictionless" if h.friction is None else f"μ = {h.friction:g}"
    return _curves(
        result,
        [
            ("liftoff_margin", "(a) lift-off margin", "scale of the listed load [1]"),
            ("slip_margin", "(b) slip margin", "scale of the listed load [1]"),
            ("torque_margin", "(c) actuator margin", "scale of the listed load [1]"),
            ("torque_ratio", "(d) peak joint torque over its effort limit, no tool load", "max |τ_i| / effort_i [1]"),
        ],
        f"Brace capacity along the task: gravity {'on' if h.gravity else 'off'}, preload {h.preload:g} N, {mu}, "
        f"{0 if h.wrenches is None else len(h.wrenches)} listed tool wrench(es)",
        margins=True,
    )


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
