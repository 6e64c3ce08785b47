"""Fig. 2 (the film strip: one row per strategy) and the animation of a run (side by side, blitted GIF).

Both draw the robot's link volumes (:mod:`bracekit.report.scene`) in an orthographic view.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import matplotlib

matplotlib.use("Agg")
import numpy as np
from matplotlib.artist import Artist
from matplotlib.figure import Figure
from matplotlib.patches import Polygon
from PIL import Image

from bracekit.report.gif import quantize, render_frames, save_gif
from bracekit.report.scene import (
    BASE_COLOR,
    BRACE_COLOR,
    REGION_COLOR,
    SURFACE_COLOR,
    SceneView,
)

if TYPE_CHECKING:
    from bracekit.simulation.run import RunResult


from bracekit.report.figure_common import (
    _FONT,
    _GIF_DPI,
    COLORS,
    DPI,
    _label,
    _new_figure,
    _runs,
    _sample,
    _scale_bar,
    _scene,
    _scene_legend,
    _title,
    _view_text,
    _wrapped,
)


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
            k = _sample(tr, float(t))
            view = SceneView(ax, scene, name, samples=[k])
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
    title = (
        f"Fig. 2: the runs of scenario {result.scenario.name} ({result.compliance_model} compliance for the braced "
        f"runs); {_view_text(scene)}"
    )
    _title(fig, title, _FONT + 2, 0.1, height)
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
