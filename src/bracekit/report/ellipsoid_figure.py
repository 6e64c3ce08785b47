"""Fig. 3: the tip's compliance ellipsoids along the task in two orthographic views with metric axes."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import matplotlib

matplotlib.use("Agg")
import numpy as np
from matplotlib.figure import Figure
from matplotlib.patches import Polygon
from matplotlib.ticker import MaxNLocator

from bracekit.compliance.first_order import compliance_ellipsoids
from bracekit.report.projection import OrthoCamera, ellipsoid_outline
from bracekit.report.scene import (
    TASK_COLOR,
)

if TYPE_CHECKING:
    from bracekit.simulation.run import RunResult


from bracekit.report.figure_common import (
    _FONT,
    _MIN_VIEW_M,
    COLORS,
    DPI,
    Array,
    _label,
    _new_figure,
    _nice,
    _runs,
    _state,
    _tip_compliance,
    _title,
)

# --- Fig. 3: compliance ellipsoids -----------------------------------------------------------------------


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
            for (e, _), outline in zip(items, outlines[v][c], strict=True):  # add_artist: the limits are set below
                ax.add_artist(Polygon(outline, closed=True, fc=color, ec=color, alpha=0.35, lw=1.0))
                ax.add_artist(Polygon(outline, closed=True, fc="none", ec=color, lw=1.0))
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
    title = (
        f"Fig. 3: translational compliance ellipsoids at {points} points of the task ({result.compliance_model} "
        f"model for the braced runs)\nsemi-axes: eigenvalues of the force block of the tip compliance, drawn at "
        f"{scale:.2f} m per m/N; dashed: the task path"
    )
    _title(fig, title, _FONT + 1, 0.08, height)
    return fig
