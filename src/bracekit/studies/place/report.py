"""The placement's outputs, written whole into a temporary folder (:func:`bracekit.report.output.atomic_directory`).

table.md / table.csv: the whole-task evaluations ranked (feasible first, by mean C_i of gradient projection);
evaluations.parquet: every evaluation, inner (stage ``start``) and whole-task (``task``, ``refine``);
summary.json: the settings, timings, counts and the best place; best.toml: the best place's scenario, ready for
``bracekit run``; surface.png: the start objective over the best link's surface (fraction × angle) at the best
start posture, with the optimum marked.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from bracekit.report.output import to_json
from bracekit.studies.place.engine import PlaceRun, best_place
from bracekit.studies.place.scenario import place_data
from bracekit.studies.place.surface import link_surface
from bracekit.studies.place.toml_text import toml_text
from bracekit.studies.sweep.refine import usable
from bracekit.studies.sweep.store import write_csv, write_parquet

#: Every file a placement may write.
FILES = ("table.md", "table.csv", "evaluations.parquet", "summary.json", "best.toml", "surface.png")


def ranked(run: PlaceRun) -> list[dict[str, Any]]:
    """The whole-task rows: feasible first by mean C_i of gradient projection, then the rest in order.

    Among the feasible ones, those MuJoCo's static check did not settle on come last.
    """
    good = sorted(
        (r for r in run.evaluations if usable(r)),
        key=lambda r: (r.get("mujoco_settles") is False, r["Ci_mean_gp"], r["place"]),
    )
    return good + [r for r in run.evaluations if not usable(r)]


def all_rows(run: PlaceRun) -> list[dict[str, Any]]:
    """Every evaluation as one table: the inner rows, then the whole-task rows (the union of their columns)."""
    rows = [r.row() | {"place": r.seed, "evaluation": -1} for r in run.inner] + run.evaluations
    names: dict[str, None] = {}
    for r in rows:
        names |= dict.fromkeys(r)
    return [{n: r.get(n) for n in names} for r in rows]


def summary(run: PlaceRun) -> dict[str, Any]:
    """summary.json: spec, settings, counts, timings (s), the best place (SI units, angle in degrees)."""
    s = run.settings
    best = run.best
    found = best_place(run)
    return {
        "spec": run.spec.name,
        "objective": {"inner": s.inner.measure, "outer": "Ci_mean_gp"},
        "settings": {
            "seeds_per_link": s.seeds,
            "top": s.top,
            "refine_rounds": s.refine_rounds,
            "first_step": {"fraction": s.step[0], "angle_deg": math.degrees(s.step[1])},
            "max_tilt_deg": s.inner.max_tilt_deg,
            "clearance_margin_m": s.inner.clearance_margin,
            "limit_margin_rad": s.inner.limit_margin,
            "posture_radius_rad": s.inner.posture_radius,
            "surface": s.inner.surface,
        },
        "inner_runs": len(run.inner),
        "inner_successful": sum(r.success for r in run.inner),
        "whole_task_runs": len(run.evaluations),
        "feasible_runs": sum(usable(r) for r in run.evaluations),
        "mujoco_checks": {
            "settled": sum(r.get("mujoco_settles") is True for r in run.evaluations),
            "not_settled": sum(r.get("mujoco_settles") is False for r in run.evaluations),
        },
        "workers": run.workers,
        "trials_run_ahead_unused": run.unused,
        "early_runs_unused": run.unused_early,
        "timings": run.timings,
        "best": None
        if best is None or found is None
        else {
            "link": best["link"],
            "fraction": best["fraction"],
            "angle_deg": best["angle_deg"],
            "Ci_mean_gp": best["Ci_mean_gp"],
            "k_mean_gp": best["k_mean_gp"],
            "Ci_mean_free_space": best["Ci_mean_free_space"],
            "min_link_clearance_m": best["min_link_clearance_m"],
            "point": [best["point_x"], best["point_y"], best["point_z"]],
            "start_posture": [float(x) for x in found[1]],
        },
    }


def _mm(x: Any) -> str:
    return "—" if x is None or not math.isfinite(x) else f"{1e3 * x:.3f}"


def table_markdown(run: PlaceRun) -> str:
    """The ranked whole-task table in Markdown (C_i in mm/N)."""
    lines = [
        f"# Placement on {run.spec.name}",
        "",
        f"{len(run.inner)} inner optimisations ({sum(r.success for r in run.inner)} converged), "
        f"{len(run.evaluations)} whole-task runs ({sum(usable(r) for r in run.evaluations)} feasible), "
        f"{run.timings.get('total_s', 0.0):.1f} s on {run.workers} workers. C_i: mean over the task (mm/N).",
        "",
        "| rank | link | fraction | angle (°) | stage | C_i GP | C_i MN | C_i free | k GP | clearance (m) | feasible |",
        "|---:|---|---:|---:|---|---:|---:|---:|---:|---:|---|",
    ]
    for i, r in enumerate(ranked(run), 1):
        clear = r.get("min_link_clearance_m")
        why = "yes" if usable(r) else f"no: {r.get('failure') or ''}"[:90]
        if usable(r) and r.get("mujoco_settles") is False:
            why = "yes, but MuJoCo's static check does not settle"
        k = r.get("k_mean_gp")
        lines.append(
            f"| {i} | {r['link']} | {r['fraction']:.4f} | {r['angle_deg']:.1f} | {r['stage']} | "
            f"{_mm(r.get('Ci_mean_gp'))} | {_mm(r.get('Ci_mean_min_norm'))} | {_mm(r.get('Ci_mean_free_space'))} | "
            f"{'—' if k is None else f'{k:.2f}'} | {'—' if clear is None else f'{clear:.3f}'} | {why} |"
        )
    return "\n".join(lines) + "\n"


def surface_figure(run: PlaceRun, path: Path, count: tuple[int, int] = (30, 36)) -> None:
    """The start objective over the best link's surface at the best start posture (fraction × angle)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from bracekit.studies.place.inner import StartProblem

    found = best_place(run)
    assert found is not None
    place, q = found
    problem = StartProblem(run.spec, place.link, q, run.settings.inner)
    lo, hi = run.settings.inner.fraction_bounds
    fractions = np.linspace(lo, hi, count[0])
    angles = np.linspace(-math.pi, math.pi, count[1])
    values = np.array([[problem.value_at(q, s, a) for s in fractions] for a in angles])
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    mesh = ax.pcolormesh(fractions, np.degrees(angles), 1e3 * values, shading="auto", cmap="viridis")
    fig.colorbar(mesh, ax=ax, label=f"{run.settings.inner.measure} at the start (mm/N)")
    ax.plot([place.fraction], [place.angle_deg], "r*", markersize=12, label="best place")
    ax.set_xlabel(f"fraction along {place.link}")
    ax.set_ylabel("angle about the link axis (°)")
    ax.set_title(f"{run.spec.name}: start objective over {place.link}'s surface")
    ax.legend(loc="upper right")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def write_outputs(run: PlaceRun, folder: Path, figures: bool = True) -> list[str]:
    """Write the outputs into `folder`; their names (best.toml and the figure only when a place is feasible)."""
    rows = ranked(run)
    names = ["table.md", "summary.json", "evaluations.parquet"]
    (folder / "table.md").write_text(table_markdown(run), encoding="utf-8")
    (folder / "summary.json").write_text(to_json(summary(run)) + "\n", encoding="utf-8")
    write_parquet(all_rows(run), folder / "evaluations.parquet")
    if rows:
        write_csv(rows, folder / "table.csv")
        names.append("table.csv")
    found = best_place(run)
    if found is not None:
        place, q = found
        surface = link_surface(run.spec.base_scenario().robot, place.link, run.settings.inner.surface)
        (folder / "best.toml").write_text(toml_text(place_data(run.spec, surface, place, q)), encoding="utf-8")
        names.append("best.toml")
        if figures:
            surface_figure(run, folder / "surface.png")
            names.append("surface.png")
    return names
