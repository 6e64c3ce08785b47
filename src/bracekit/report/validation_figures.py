"""Figures of the validation: predicted vs MuJoCo deflections, and the error against the contact preload."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from bracekit.validate.compliance_check import ValidationReport
from bracekit.validate.table import fmt_rel

_COLORS = {"constrained": "tab:blue", "projection": "tab:orange", "free_space": "tab:red"}
_MARKERS = {"constrained": "o", "projection": "s", "free_space": "^"}


def figure_validation(report: ValidationReport, path: str | Path) -> Path:
    """PNG: predicted vs MuJoCo tip-deflection components (Δp in mm, Δθ in mrad) for the three models.

    One point per component of each closed-contact case; on the y = x line the model is exact. The legend
    gives each model's median relative error vs MuJoCo. Returns the path written.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(path)
    ok = [c for c in report.cases if c["status"] == "ok" and c["deflection"]["mujoco"] is not None]
    fig, axes = plt.subplots(1, 2, figsize=(10.0, 4.8))
    parts = ((slice(0, 3), 1e3, "translation Δp [mm]"), (slice(3, 6), 1e3, "rotation Δθ [mrad]"))
    for ax, (sl, unit, name) in zip(axes, parts, strict=True):
        ref = np.array([np.asarray(c["deflection"]["mujoco"])[sl] for c in ok]).reshape(-1) * unit
        lim = [0.0, 0.0]
        for m in report.models:  # the models defined for the robot's braces
            pred = np.array([np.asarray(c["deflection"][m])[sl] for c in ok]).reshape(-1) * unit
            med = report.model_stats(m)["median_rel_err_mujoco"]
            ax.scatter(
                ref,
                pred,
                s=16,
                marker=_MARKERS[m],
                facecolors="none" if m != "constrained" else _COLORS[m],
                edgecolors=_COLORS[m],
                linewidths=0.9,
                label=f"{m} (median error {fmt_rel(med)})",
                zorder=3 if m == "constrained" else 2,
            )
            if ref.size:
                lim = [min(lim[0], ref.min(), pred.min()), max(lim[1], ref.max(), pred.max())]
        pad = 0.05 * (lim[1] - lim[0] or 1.0)
        lo, hi = lim[0] - pad, lim[1] + pad
        ax.plot([lo, hi], [lo, hi], "k-", lw=0.8, label="y = x (exact)", zorder=1)
        ax.set_xlim(lo, hi)
        ax.set_ylim(lo, hi)
        ax.set_aspect("equal")
        ax.grid(alpha=0.3)
        ax.set_xlabel(f"MuJoCo {name}")
        ax.set_ylabel(f"first-order prediction C·w, {name}")
        ax.set_title(f"tip {name.split(' [')[0]}, components x, y, z")
    axes[0].legend(fontsize=8, loc="upper left")
    cnt = report.counts()
    s = report.settings
    fig.suptitle(
        f"Predicted vs simulated tip deflection, scenario '{report.scenario}': {cnt['ok']} cases "
        f"(|f| = {s['force_N']:g} N, |m| = {s['moment_Nm']:g} N·m, preload {s['preload_N']:g} N; "
        f"{cnt['contact_opened']} opened, {cnt['failed']} failed, not shown)",
        fontsize=10,
    )
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=100)
    plt.close(fig)
    return out


def figure_preload(study: dict[str, Any], path: str | Path) -> Path:
    """PNG: median relative error of the constrained model vs preload (log–log), one line per load.

    Solid: the first-order ``constrained`` model; dashed: the same with the preload's geometric stiffness
    (``corrected``). Returns the path written.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(path)
    ps = np.asarray(study["preloads_N"], dtype=float)
    fig, ax = plt.subplots(figsize=(6.4, 5.0))
    colors = plt.get_cmap("viridis")(np.linspace(0.0, 0.85, len(study["loads_N"])))
    for j, f in enumerate(study["loads_N"]):
        lines = (("median_rel_err", "-o", "first-order"), ("median_rel_err_corrected", "--x", "with K_g"))
        for key, style, what in lines:
            vals = [row[j] for row in study[key]]
            keep = [(p, 100.0 * v) for p, v in zip(ps, vals, strict=True) if v is not None and v > 0]
            if keep:
                x, y = zip(*keep, strict=True)
                ax.plot(x, y, style, color=colors[j], ms=4, lw=1.2, label=f"|f| = {f:g} N, {what}")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("contact preload P [N]")
    ax.set_ylabel("median relative tip-deflection error [%]")
    ref = "nonlinear static solve" if study["reference"] == "static" else "MuJoCo"
    ax.set_title(
        f"First-order constrained model vs {ref} ({study['contact']}), scenario '{study['scenario']}'\n"
        "solid: C_e from K alone; dashed: with the preload's geometric stiffness K_g = −P ∂(J_b,vᵀn̂)/∂q",
        fontsize=8,
    )
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=7, ncol=3, loc="upper center", bbox_to_anchor=(0.5, -0.16))
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=100)
    plt.close(fig)
    return out
