"""Table I of the paper beside ours, as Markdown and CSV (SI units)."""

from __future__ import annotations

import csv
import io
from typing import Any

STRATEGY_LABELS = {
    "free_space_min_norm": "Free space min. norm",
    "braced_min_norm": "Braced min. norm",
    "braced_gradient_projection": "Braced grad. projection",
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


def table_rows(summaries: dict[str, dict[str, Any]]) -> list[dict[str, Any]]:
    """Rows of the table: the paper's, then ours under each compliance model."""
    rows: list[dict[str, Any]] = []
    for name, values in PAPER_TABLE_I.items():
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
            red = None if free is None or name == "free_space_min_norm" else 1.0 - values["Ci_mean"] / free["Ci_mean"]
            rows.append(
                {
                    "source": "bracekit",
                    "model": model,
                    "strategy": name,
                    **{c: values[c] for c in COLUMNS},
                    "Ci_mean_reduction": red,
                    "completed": values["completed"],
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


def table_markdown(summaries: dict[str, dict[str, Any]], scenario: str = "paper") -> str:
    """Table I (paper beside bracekit) as Markdown, SI units."""
    lines = [
        f"# Table I: scenario `{scenario}`",
        "",
        "SI units: C_i in m/N (the paper prints 10⁻³ m/N, i.e. mm/N; its values are converted here).",
        "Πσ, σ_min and k are those of the braced Jacobian J̃ (eq:J_wave) along each strategy's own path;",
        "the free-space run's C_i uses the free-space compliance J K⁻¹ Jᵀ, the braced runs C_e of the model.",
        "",
        "| source | compliance model | strategy | " + " | ".join(HEADERS) + " | mean C_i reduction vs free space |",
        "|" + "---|" * (len(HEADERS) + 4),
    ]
    for row in table_rows(summaries):
        cells = [row["source"], row["model"], STRATEGY_LABELS.get(row["strategy"], row["strategy"])]
        cells += [_fmt(row[c], c) for c in COLUMNS] + [_fmt(row["Ci_mean_reduction"], "Ci_mean_reduction")]
        if row.get("completed") is False:
            cells[2] += " (did not complete)"
        lines.append("| " + " | ".join(cells) + " |")
    lines.append("")
    return "\n".join(lines)


def table_csv(summaries: dict[str, dict[str, Any]]) -> str:
    """Table I as CSV (SI units, reductions as fractions)."""
    buf = io.StringIO()
    fields = ["source", "model", "strategy", *COLUMNS, "Ci_mean_reduction"]
    writer = csv.DictWriter(buf, fieldnames=fields, extrasaction="ignore", lineterminator="\n")
    writer.writeheader()
    for row in table_rows(summaries):
        writer.writerow({k: ("" if row.get(k) is None else row.get(k)) for k in fields})
    return buf.getvalue()
