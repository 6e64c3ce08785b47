"""Fig. 4 (the measures along the task) and the capacity figure (lift-off, slip and actuator margins)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import matplotlib

matplotlib.use("Agg")
import numpy as np
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from bracekit.compliance.directional import CI_LABEL, CT_LABEL
from bracekit.errors import NumericalError

if TYPE_CHECKING:
    from bracekit.simulation.run import RunResult


from bracekit.report.figure_common import _FONT, COLORS, DPI, Array, _label, _new_figure, _runs, _state, _tip_compliance


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
