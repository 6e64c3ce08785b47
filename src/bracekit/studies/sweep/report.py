"""The outputs of a sweep: results.parquet/.csv, a ranked table.md, summary.json, a heatmap and a Pareto plot.

Ranking: feasible candidates first, by the mean C_i of gradient projection (lowest first), ties by candidate
order; then the others in candidate order. Units: C_i in m/N in the data files, mm/N in table.md.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from bracekit.report.output import to_json
from bracekit.studies.sweep.engine import SweepRun
from bracekit.studies.sweep.evaluate import finite
from bracekit.studies.sweep.store import write_csv, write_parquet

#: Every file a sweep writes into its output folder.
FILES = ("results.parquet", "results.csv", "table.md", "summary.json", "heatmap.png", "pareto.png", "refined.csv")
#: The note on a figure with no completed run.
EMPTY_NOTE = "no completed run: every candidate was screened out or failed"
#: Rows listed in table.md.
TABLE_ROWS = 20


def ranked(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Feasible rows by mean C_i of gradient projection (then candidate order), then the others in order."""
    good = sorted(
        (r for r in rows if r["feasible"]),
        key=lambda r: (r["Ci_mean_gp"] if finite(r["Ci_mean_gp"]) else math.inf, r["index"]),
    )
    return good + [r for r in rows if not r["feasible"]]


def _mm(x: float | None) -> str:
    return "—" if x is None else f"{1e3 * x:.3f}"


def _f(x: float | None, fmt: str = ".2f") -> str:
    return "—" if x is None else format(x, fmt)


def _where(r: dict[str, Any]) -> str:
    if "fraction" in r:
        return f"{r['fraction']:.3f}"
    if "offset_x" in r:
        return f"[{r['offset_x']:.3f}, {r['offset_y']:.3f}, {r['offset_z']:.3f}]"
    return "0.500"


def _reason(r: dict[str, Any]) -> str:
    text = r["failure"] or ""
    if r["screened_out"]:
        return "screened out"
    names = {"surface": "link clearance", "did not complete": "run failed", "does not hold": "brace does not hold"}
    keys = ("did not complete", "k_mean", "joint limits", "surface", "does not hold", "unstable", "margin", "C_i")
    for key in (*keys, "task context"):
        if key in text:
            return names.get(key, key)
    return text.split(":")[0] or "not feasible"


def summary(run: SweepRun) -> dict[str, Any]:
    """The sweep's summary: counts, screening savings, timings and the refinement (SI units)."""
    rows = run.rows
    simulated = [r for r in rows if not r["screened_out"] and r["wall_s"] is not None]
    mean_wall = float(np.mean([r["wall_s"] for r in simulated])) if simulated else None
    reasons: dict[str, int] = {}
    for r in rows:
        if not r["feasible"]:
            reasons[_reason(r)] = reasons.get(_reason(r), 0) + 1
    saved = None if mean_wall is None else run.screened_out * mean_wall
    best = ranked(rows)[0] if rows and rows and ranked(rows)[0]["feasible"] else None
    return {
        "spec": run.spec.name,
        "base_scenario": run.spec.base_name,
        "candidates": len(rows),
        "simulated": len(simulated),
        "simulated_now": run.evaluated,
        "reused_from_earlier_runs": run.reused,
        "rerun_invalid_rows": run.rerun,
        "screened_out": run.screened_out,
        "feasible": sum(1 for r in rows if r["feasible"]),
        "not_feasible_by_reason": reasons,
        "best": None if best is None else {k: best[k] for k in best if k != "wall_s"},
        "screening": {
            "enabled": any(r["screen_Ci_mean"] is not None for r in rows),
            "k_max": run.spec.screening.k_max,
            "keep_fraction": run.spec.screening.keep_fraction,
            "mean_simulation_wall_s": mean_wall,
            "estimated_simulation_time_saved_s": saved,
            "estimated_share_saved": None if saved is None or not rows else run.screened_out / len(rows),
        },
        "refined": run.refined,
        "workers": run.workers,
        "timings_s": run.timings,
        "units": "C_i in m/N, lengths in m, angles in rad (the axis 'angle' in degrees, as [brace] surface), "
        "times in s",
    }


def table_markdown(run: SweepRun) -> str:
    """The ranked table (best TABLE_ROWS feasible candidates) and the counts of the others."""
    s = summary(run)
    lines = [
        f"# Sweep {run.spec.name} (base scenario {run.spec.base_name})",
        "",
        f"{s['candidates']} candidates: {s['feasible']} feasible, {s['simulated']} simulated, "
        f"{s['screened_out']} screened out. C_i: mean over the task (mm/N); k: mean condition number of J̃; "
        "clearance: least link distance from the surface (m).",
        "",
        "| rank | candidate | link | fraction / offset | point at start [m] | C_i GP | C_i MN | C_i free | less | k GP "
        "| clearance |",
        "|---:|---|---|---:|---|---:|---:|---:|---:|---:|---:|",
    ]
    good = [r for r in ranked(run.rows) if r["feasible"]][:TABLE_ROWS]
    for i, r in enumerate(good, start=1):
        point = f"[{r['point_x']:.3f}, {r['point_y']:.3f}, {r['point_z']:.3f}]"
        red = r["Ci_reduction_gp"]
        lines.append(
            f"| {i} | {r['candidate']} | {r['link']} | {_where(r)} | {point} | {_mm(r['Ci_mean_gp'])} | "
            f"{_mm(r['Ci_mean_min_norm'])} | {_mm(r['Ci_mean_free_space'])} | "
            f"{'—' if red is None else f'{100 * red:.0f} %'} | {_f(r['k_mean_gp'])} | "
            f"{_f(r['min_link_clearance_m'], '.3f')} |"
        )
    if not good:
        lines.append("| — | no feasible candidate | | | | | | | | | |")
    lines += ["", "Not feasible: " + (", ".join(f"{n} {k}" for k, n in s["not_feasible_by_reason"].items()) or "none")]
    if run.refined:
        lines += [
            "",
            "Refined (bounded search of the fraction along the link):",
            "",
            "| candidate | link | grid fraction | C_i GP grid | refined fraction | C_i GP refined | evaluations |",
            "|---|---|---:|---:|---:|---:|---:|",
        ]
        for f in run.refined:
            rf = f["refined_fraction"]
            lines.append(
                f"| {f['candidate']} | {f['link']} | {f['fraction']:.3f} | {_mm(f['grid_Ci_mean_gp'])} | "
                f"{'—' if rf is None else f'{rf:.3f}'} | {_mm(f['refined_Ci_mean_gp'])} | {f['evaluations']} |"
            )
    scr = s["screening"]
    if scr["enabled"] and scr["estimated_simulation_time_saved_s"] is not None:
        lines += [
            "",
            f"Screening skipped {s['screened_out']} of {s['candidates']} simulations (about "
            f"{scr['estimated_simulation_time_saved_s']:.0f} s of worker time at "
            f"{scr['mean_simulation_wall_s']:.2f} s each).",
        ]
    return "\n".join(lines) + "\n"


def heatmap(run: SweepRun, path: Path) -> None:
    """Mean C_i of gradient projection (mm/N) over link × fraction (the least over other axes), completed runs.

    Marks: ✓ feasible, x completed but not feasible, f run failed, · screened out.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = run.rows
    links = list(dict.fromkeys(r["link"] for r in rows))
    fig, ax = plt.subplots(figsize=(9, 0.45 * len(links) + 2.0), dpi=110)
    mesh: Any
    if "fraction" in (rows[0] if rows else {}):
        fracs = sorted({r["fraction"] for r in rows})
        grid = np.full((len(links), len(fracs)), np.nan)
        mark = np.full(grid.shape, "·", dtype=object)  # screened out, unless a row says more
        for r in rows:
            i, j = links.index(r["link"]), fracs.index(r["fraction"])
            if r["completed"] and finite(r["Ci_mean_gp"]):
                grid[i, j] = np.nanmin([grid[i, j], 1e3 * r["Ci_mean_gp"]])
            if r["feasible"]:
                mark[i, j] = "✓"
            elif not r["screened_out"] and mark[i, j] != "✓":
                mark[i, j] = "x" if r["completed"] else "f"
        edges = np.concatenate([[fracs[0]], 0.5 * (np.array(fracs[1:]) + np.array(fracs[:-1])), [fracs[-1]]])
        if len(fracs) == 1:
            edges = np.array([fracs[0] - 0.5, fracs[0] + 0.5])
        mesh = ax.pcolormesh(edges, np.arange(len(links) + 1) - 0.5, np.ma.masked_invalid(grid), cmap="viridis_r")
        for i in range(len(links)):
            for j in range(len(fracs)):
                bold = mark[i, j] == "✓"
                shade = "0.1" if bold else "0.35"
                if np.isfinite(grid[i, j]):  # white on the dark end of the colour map
                    r, g, b, _ = mesh.cmap(mesh.norm(grid[i, j]))
                    shade = "white" if 0.299 * r + 0.587 * g + 0.114 * b < 0.5 else "black"
                ax.text(
                    fracs[j],
                    i,
                    mark[i, j],
                    ha="center",
                    va="center",
                    color=shade,
                    fontsize=10 if bold else 8,
                    fontweight="bold" if bold else "normal",
                )
        ax.set_xlabel("fraction along the link (0: its joint, 1: the next joint)")
    else:
        ok = [r for r in rows if r["feasible"] and finite(r["Ci_mean_gp"])]
        mesh = ax.scatter([links.index(r["link"]) for r in ok], [1e3 * r["Ci_mean_gp"] for r in ok])
        ax.set_xlabel("link")
    ax.set_yticks(range(len(links)), links)
    fig.colorbar(mesh, ax=ax, label="mean C_i, gradient projection (mm/N)")
    if not any(r["completed"] and finite(r["Ci_mean_gp"]) for r in rows):
        ax.text(0.5, 1.0, EMPTY_NOTE, ha="center", va="bottom", transform=ax.transAxes, color="0.3", fontsize=8)
    ax.set_title(
        f"{run.spec.name}: mean C_i of completed runs; ✓: feasible, x: not feasible, f: run failed, ·: screened out",
        fontsize=9,
    )
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def pareto_front(points: list[tuple[float, float]]) -> list[int]:
    """Indices of the points no other point beats in both coordinates (both minimised), by the first coordinate."""
    order = sorted(range(len(points)), key=lambda i: points[i])
    front, best = [], np.inf
    for i in order:
        if points[i][1] < best:
            front.append(i)
            best = points[i][1]
    return front


def pareto(run: SweepRun, path: Path) -> None:
    """Mean C_i against mean k of gradient projection for every completed run; the feasible Pareto front."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    sim = [r for r in run.rows if r["completed"] and finite(r["Ci_mean_gp"]) and finite(r["k_mean_gp"])]
    good = [r for r in sim if r["feasible"]]
    bad = [r for r in sim if not r["feasible"]]
    fig, ax = plt.subplots(figsize=(7, 5), dpi=110)
    ax.scatter(
        [r["k_mean_gp"] for r in bad],
        [1e3 * r["Ci_mean_gp"] for r in bad],
        c="0.75",
        s=12,
        label="completed, not feasible",
    )
    ax.scatter([r["k_mean_gp"] for r in good], [1e3 * r["Ci_mean_gp"] for r in good], s=14, label="feasible")
    pts = [(r["k_mean_gp"], r["Ci_mean_gp"]) for r in good]
    front = [good[i] for i in pareto_front(pts)]
    if front:
        ax.plot([r["k_mean_gp"] for r in front], [1e3 * r["Ci_mean_gp"] for r in front], "r.-", label="Pareto front")
    if sim:
        ax.set_xscale("log")
        ax.legend()
    else:  # nothing to place on a log axis
        ax.text(0.5, 0.5, EMPTY_NOTE, ha="center", va="center", transform=ax.transAxes, color="0.3")
    ax.set_xlabel("mean k of J̃ (gradient projection, log scale)")
    ax.set_ylabel("mean C_i (mm/N, gradient projection)")
    ax.set_title(f"{run.spec.name}: compliance against conditioning")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def write_outputs(run: SweepRun, folder: Path, figures: bool = True) -> list[str]:
    """Write every output file into `folder` (a temporary folder of :func:`atomic_directory`); their names."""
    rows = run.rows
    write_parquet(rows, folder / "results.parquet")
    write_csv(rows, folder / "results.csv")
    (folder / "table.md").write_text(table_markdown(run), encoding="utf-8")
    (folder / "summary.json").write_text(to_json(summary(run)) + "\n", encoding="utf-8")
    names = ["results.parquet", "results.csv", "table.md", "summary.json"]
    if run.refined:
        write_csv(run.refined, folder / "refined.csv")
        names.append("refined.csv")
    if figures and rows:
        heatmap(run, folder / "heatmap.png")
        pareto(run, folder / "pareto.png")
        names += ["heatmap.png", "pareto.png"]
    return names
