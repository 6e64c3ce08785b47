"""Table I of the paper beside ours, as Markdown and CSV (SI units)."""

from __future__ import annotations

import csv
import io
from typing import Any

from bracekit._text_table import text_rows

STRATEGY_LABELS = {
    "free_space_min_norm": "Free space min. norm",
    "braced_min_norm": "Braced min. norm",
    "braced_gradient_projection": "Braced grad. projection",
    "braced_qp": "Braced QP",
}
COLUMNS = ("Ci_mean", "Ci_min", "prod_sigma_t_mean", "prod_sigma_o_mean", "sigma_t_min", "sigma_o_min", "k_mean")
HEADERS = ("mean C_i [m/N]", "min C_i [m/N]", "mean Πσ_t", "mean Πσ_o", "σ_t,min", "σ_o,min", "mean k")

#: The paper's Table I; its compliances are printed in 10⁻³ units (mm/N, docs/model.md), here in m/N.
PAPER_TABLE_I: dict[str, dict[str, float]] = {
    "free_space_min_norm": dict(zip(COLUMNS, (24.90e-3, 17.16e-3, 1.22, 5.50, 0.29, 1.08, 5.84), strict=True)),
    "braced_min_norm": dict(zip(COLUMNS, (12.52e-3, 6.86e-3, 0.81, 5.30, 0.29, 1.01, 4.87), strict=True)),
    "braced_gradient_projection": dict(zip(COLUMNS, (10.16e-3, 4.30e-3, 0.66, 5.88, 0.29, 1.15, 4.33), strict=True)),
}
PAPER_REDUCTIONS = {"braced_min_norm": 0.497, "braced_gradient_projection": 0.592}

#: The run checks beside Table I: summary key | header | format.
_ALWAYS_TABLE = """
task_space                    | task space                | s
redundancy                    | redundancy                | d
max_joint_limit_violation_rad | max limit violation [rad] | .2g
min_link_clearance_m          | min link clearance [m]    | .4f
max_region_radius_m           | max r [m]                 | .4f
"""
_ALWAYS_CHECKS: dict[str, tuple[str, str]] = {key: (header, spec) for key, header, spec in text_rows(_ALWAYS_TABLE, 3)}
#: Checks shown only when some strategy has a value (the statics of a run with gravity, preload or loads).
_OPTIONAL_TABLE = """
holds                         | holds                     | s
unstable_samples              | unstable samples          | d
Ci_preloaded_mean             | mean C_i preloaded [m/N]  | .5f
max_torque_ratio              | max τ/effort              | .3f
max_contact_force_N           | max contact force [N]     | .2f
min_liftoff_margin            | min lift-off margin       | .3g
min_slip_margin               | min slip margin           | .3g
min_torque_margin             | min torque margin         | .3g
"""
_OPTIONAL_CHECKS: dict[str, tuple[str, str]] = {
    key: (header, spec) for key, header, spec in text_rows(_OPTIONAL_TABLE, 3)
}
#: Every run check, in column order.
CHECKS: dict[str, tuple[str, str]] = {**_ALWAYS_CHECKS, **_OPTIONAL_CHECKS}
OPTIONAL_CHECKS = tuple(_OPTIONAL_CHECKS)


def table_rows(summaries: dict[str, dict[str, Any]], paper: bool = True) -> list[dict[str, Any]]:
    """Rows of the table: the paper's (if `paper`), then ours under each compliance model."""
    rows: list[dict[str, Any]] = []
    for name, values in PAPER_TABLE_I.items() if paper else ():
        rows.append(
            {
                "source": "paper",
                "model": "projection (printed)",
                "strategy": name,
                **values,
                "Ci_mean_reduction": PAPER_REDUCTIONS.get(name),
            }
        )
    for model, summary in summaries.items():
        strategies = summary["strategies"]
        free = strategies.get("free_space_min_norm")
        for name, values in strategies.items():
            red = (
                None
                if free is None or name == "free_space_min_norm" or None in (values["Ci_mean"], free["Ci_mean"])
                else 1.0 - values["Ci_mean"] / free["Ci_mean"]
            )
            rows.append(
                {
                    "source": "bracekit",
                    "model": model,
                    "strategy": name,
                    **{c: values[c] for c in COLUMNS},
                    "Ci_mean_reduction": red,
                    "completed": values["completed"],
                    "valid": values.get("valid"),
                    **{c: values.get(c) for c in CHECKS},
                }
            )
    return rows


def _fmt(v: Any, col: str) -> str:
    if v is None:
        return "–"
    if col == "Ci_mean_reduction":
        return f"{100 * v:.1f} %"
    if col.startswith("Ci"):
        return f"{v:.5f}"
    return f"{v:.3f}"


PRINTED = " (the paper prints 10⁻³ m/N, i.e. mm/N; its values are converted here)."


def _check(v: Any, spec: str) -> str:
    if v is None:
        return "–"
    if isinstance(v, bool):
        return "yes" if v else "no"
    return str(v) if spec == "s" else format(v, spec)


def checks_markdown(summaries: dict[str, dict[str, Any]]) -> list[str]:
    """The run checks of every strategy (task space, redundancy, limits, clearance, region; statics if any)."""
    rows = [
        (model, name, values) for model, summary in summaries.items() for name, values in summary["strategies"].items()
    ]
    keys = [k for k in CHECKS if k not in OPTIONAL_CHECKS or any(v.get(k) is not None for _, _, v in rows)]
    lines = [
        "## Run checks",
        "",
        "Limits, clearance of the links from the surface, the brace's region; with gravity, a preload or tool loads",
        "also the peak joint torque over its effort limit and the load margins (a scale of the listed loads: > 1",
        "holds; – where nothing limits it or it does not apply).",
        "",
        "| compliance model | strategy | completed | valid | " + " | ".join(CHECKS[k][0] for k in keys) + " |",
        "|" + "---|" * (len(keys) + 4),
    ]
    reasons = []
    for model, name, values in rows:
        label = STRATEGY_LABELS.get(name, name)
        cells = [model, label, "yes" if values.get("completed") else "no", _check(values.get("valid"), "s")]
        cells += [_check(values.get(k), CHECKS[k][1]) for k in keys]
        lines.append("| " + " | ".join(cells) + " |")
        reasons += [f"- {model}, {label}: {why}" for why in values.get("invalid_reasons") or ()]
    lines.append("")
    if reasons:
        lines += [
            "Not valid (a run is valid when no link is in an obstacle, every brace stays in its region, the",
            "braces hold where the statics are on and the joints stay inside their limits):",
            "",
            *reasons,
            "",
        ]
    return lines


def table_markdown(summaries: dict[str, dict[str, Any]], scenario: str = "paper") -> str:
    """Table I as Markdown, SI units (the paper's printed rows beside ours for the paper scenario), and run checks."""
    paper = scenario == "paper"
    lines = [
        f"# Table I: scenario `{scenario}`",
        "",
        "SI units: C_i in m/N" + (PRINTED if paper else "."),
        "C_i = ‖β_xᵀC_e‖, mixed units, the paper's index: the norm of the row β_xᵀC_e adds its force columns (m/N)",
        "and its moment columns (1/N). The translational compliance along β_x, c_t = β_xᵀC_ttβ_x (m/N, the",
        "displacement along β_x per newton along β_x), is drawn dashed in Fig. 4(a).",
        "Πσ, σ_min and k are those of the braced Jacobian J̃ (eq:J_wave) along each strategy's own path;",
        "the free-space run's C_i uses the free-space compliance J K⁻¹ Jᵀ, the braced runs C_e of the model.",
        "",
        "| source | compliance model | strategy | " + " | ".join(HEADERS) + " | mean C_i reduction vs free space |",
        "|" + "---|" * (len(HEADERS) + 4),
    ]
    for row in table_rows(summaries, paper):
        cells = [row["source"], row["model"], STRATEGY_LABELS.get(row["strategy"], row["strategy"])]
        cells += [_fmt(row[c], c) for c in COLUMNS] + [_fmt(row["Ci_mean_reduction"], "Ci_mean_reduction")]
        if row.get("completed") is False:
            cells[2] += " (did not complete)"
        lines.append("| " + " | ".join(cells) + " |")
    lines.append("")
    lines += checks_markdown(summaries)
    return "\n".join(lines)


def table_csv(summaries: dict[str, dict[str, Any]], scenario: str = "paper") -> str:
    """Table I and the run checks as CSV (SI units, reductions as fractions; paper rows for the paper scenario)."""
    buf = io.StringIO()
    fields = ["source", "model", "strategy", *COLUMNS, "Ci_mean_reduction", "completed", "valid", *CHECKS]
    writer = csv.DictWriter(buf, fieldnames=fields, extrasaction="ignore", lineterminator="\n")
    writer.writeheader()
    for row in table_rows(summaries, scenario == "paper"):
        writer.writerow({k: ("" if row.get(k) is None else row.get(k)) for k in fields})
    return buf.getvalue()
