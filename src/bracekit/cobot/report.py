"""What a cobot run reports per strategy: the numbers (summary.json, table.md) and the figure (cobot.png).

Per strategy: the tool's deflection under the process wrench (max and steady, mm) against its first-order
prediction C w (mm, relative error), the tool's distance to the hole before the work (path error, mm), the
worker's effort (mean and peak force over the guiding, N; the work the hand did on the handle ∫ F_h·ė dt, J),
the brace (normal force min/mean/max, ticks lifted off, the first lift-off, the least slip margin
μ f_n − ‖f_t‖ while clamped, the pad's slip while the clamp engages and under the work, held or not), the peak
servo torque against the URDF's effort limits and the control step's cost (µs). The brace is held when no tick
lifts it off after the start (:data:`~bracekit.cobot.loop.LIFT_TOL`) and the pad slips less than SLIP_TOL
under the work.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from bracekit._text_table import text_rows
from bracekit.cobot.config import CobotScenario
from bracekit.cobot.loop import CobotRun

__all__ = ["SLIP_TOL", "figure_cobot", "summary", "table_markdown"]

#: The clamped pad's tangential motion (m) that counts as a slip.
SLIP_TOL = 1e-4
_START = 0.3  # s: the start's settling, not part of the guiding


def summary(sc: CobotScenario, run: CobotRun, seconds: float) -> dict[str, Any]:
    """The numbers of one strategy's run (module docstring); lengths in mm, forces in N."""
    dt = sc.dt
    guided = (~run.dwell) & (run.t >= _START)
    fmag = np.linalg.norm(run.force, axis=1)
    edot = np.gradient(run.e, dt, axis=0)
    work = float(np.sum(np.einsum("ij,ij->i", run.force, edot)) * dt)
    dw = run.dwells
    out: dict[str, Any] = {
        "strategy": run.strategy,
        "braced": run.braced,
        "deflection_max_mm": 1e3 * max(d.max_deflection for d in dw) if dw else None,
        "deflection_mm": 1e3 * float(np.mean([np.linalg.norm(d.deflection) for d in dw])) if dw else None,
        "predicted_mm": 1e3 * float(np.mean([np.linalg.norm(d.predicted) for d in dw])) if dw else None,
        "prediction_rel_err_max": max(d.rel_err for d in dw) if dw else None,
        "path_error_mm_mean": 1e3 * float(np.mean([d.path_error for d in dw])) if dw else None,
        "path_error_mm_max": 1e3 * max(d.path_error for d in dw) if dw else None,
        "worker_force_mean_N": float(np.mean(fmag[guided])),
        "worker_force_peak_N": float(np.max(fmag[guided])),
        "worker_work_J": work,
        "torque_peak_Nm": float(np.max(np.abs(run.torque[run.t >= _START]))),
        "torque_over_effort_max": float(np.max(np.abs(run.torque[run.t >= _START]) / run.effort)),
        "tick_us_median": float(np.median(run.tick_us[run.tick_us > 0])),
        "tick_us_p99": float(np.percentile(run.tick_us[run.tick_us > 0], 99)),
        "runtime_s": seconds,
        "servo_damping_time_s": run.damping_time,
        "dwells": [
            {
                "target": d.target,
                "t_s": d.t_on,
                "deflection_mm": (1e3 * d.deflection).tolist(),
                "predicted_mm": (1e3 * d.predicted).tolist(),
                "max_deflection_mm": 1e3 * d.max_deflection,
                "rel_err": d.rel_err,
                "path_error_mm": 1e3 * d.path_error,
            }
            for d in dw
        ],
    }
    if run.braced:
        after = run.t >= _START
        clamped = run.dwell & after
        margin = sc.friction * run.normal[clamped] - run.tangential[clamped]
        slip = max((d.slip for d in dw), default=0.0)
        clamp_slip = max((d.clamp_slip for d in dw), default=0.0)
        out.update(
            {
                "normal_force_min_N": float(np.min(run.normal[after])),
                "normal_force_mean_N": float(np.mean(run.normal[after])),
                "normal_force_max_N": float(np.max(run.normal[after])),
                "open_ticks": run.open_ticks,
                "first_lift_off": run.contact_lost,
                "slip_margin_min_N": float(np.min(margin)) if margin.size else None,
                "slip_mm": 1e3 * slip,
                "clamp_slip_mm": 1e3 * clamp_slip,
                "brace_held": run.open_ticks == 0 and slip < SLIP_TOL,
            }
        )
    return out


def _fmt(v: Any, digits: int = 2) -> str:
    if v is None:
        return "—"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, int):
        return str(v)
    return f"{v:.{digits}f}"


#: The table's rows: label | summary keys (several: shown a / b) | digits.
_ROWS_TABLE = """
tool deflection under the work, steady (mm) | deflection_mm                                             | 3
first-order prediction ‖C w‖ (mm)           | predicted_mm                                              | 3
prediction error, worst hole (%)            | prediction_rel_err_max                                    | 1
tool deflection, peak (mm)                  | deflection_max_mm                                         | 3
path error to the holes, mean / max (mm)    | path_error_mm_mean path_error_mm_max                      | 2
worker force, mean / peak (N)               | worker_force_mean_N worker_force_peak_N                   | 2
worker's work on the handle (J)             | worker_work_J                                             | 3
brace normal force, min / mean / max (N)    | normal_force_min_N normal_force_mean_N normal_force_max_N | 1
ticks with the brace open                   | open_ticks                                                | 0
least slip margin μf_n − ‖f_t‖ clamped (N)  | slip_margin_min_N                                         | 2
pad slip under the work (mm)                | slip_mm                                                   | 3
pad slip while the clamp engages (mm)       | clamp_slip_mm                                             | 3
brace held                                  | brace_held                                                | 0
peak servo torque (N·m) / over effort limit | torque_peak_Nm torque_over_effort_max                     | 2
control step, median / p99 (µs)             | tick_us_median tick_us_p99                                | 0
"""
_ROWS = [(label, keys.split(), int(digits)) for label, keys, digits in text_rows(_ROWS_TABLE, 3)]


def table_markdown(sc: CobotScenario, rows: list[dict[str, Any]]) -> str:
    """The strategies side by side (Markdown)."""
    head = "| | " + " | ".join(r["strategy"] for r in rows) + " |"
    lines = [f"# {sc.name}: a worker guides the braced cobot", "", head, "|---" * (len(rows) + 1) + "|"]
    for label, keys, digits in _ROWS:
        cells = []
        for r in rows:
            vals = [r.get(k) for k in keys]
            if keys == ["prediction_rel_err_max"]:
                vals = [None if v is None else 100.0 * v for v in vals]
            cells.append(" / ".join(_fmt(v, digits) for v in vals))
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def figure_cobot(sc: CobotScenario, runs: list[CobotRun], path: Path) -> None:
    """Worker force, tool error to the hole, brace normal force and deflection over time, dwells shaded."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(4, 1, figsize=(9, 9), sharex=True)
    period = sc.operator.travel + sc.operator.approach + sc.operator.dwell
    targets = sc.operator.targets
    direction = sc.process.wrench[:3] / max(float(np.linalg.norm(sc.process.wrench[:3])), 1e-300)
    for c, run in enumerate(runs):
        colour = f"C{c}"
        idx = np.clip(((run.t - _START) // period).astype(int), 0, len(targets) - 1)
        axes[0].plot(run.t, np.linalg.norm(run.force, axis=1), lw=0.8, color=colour, label=run.strategy)
        axes[1].plot(run.t, 1e3 * np.linalg.norm(run.e - targets[idx], axis=1), lw=0.8, color=colour)
        if run.braced:
            axes[2].plot(run.t, run.normal, lw=0.8, color=colour)
        axes[3].plot(run.t, 1e3 * ((run.e - run.e_cmd) @ direction), lw=0.8, color=colour)
    for ax, label in zip(
        axes,
        ("worker force (N)", "tool to hole (mm)", "brace normal force (N)", "tool − command along the load (mm)"),
        strict=True,
    ):
        ax.set_ylabel(label, fontsize=8)
        on = runs[0].dwell
        edges = np.flatnonzero(np.diff(on.astype(int)))
        starts = [runs[0].t[i + 1] for i in edges if not on[i]]
        ends = [runs[0].t[i + 1] for i in edges if on[i]] + [runs[0].t[-1]]
        for a, b in zip(starts, ends, strict=False):
            ax.axvspan(a, b, color="0.9", zorder=0)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=7, loc="upper right")
    axes[-1].set_xlabel("time (s); shaded: the work (hand off, process wrench on)")
    fig.suptitle(f"{sc.name}: {sc.description}", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
