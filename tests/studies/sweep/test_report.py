from __future__ import annotations

import csv
import itertools
import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from bracekit.studies.sweep.engine import SweepRun
from bracekit.studies.sweep.evaluate import RESULT_COLUMNS
from bracekit.studies.sweep.report import pareto_front, ranked, summary, table_markdown, write_outputs
from bracekit.studies.sweep.spec import load_spec


def test_pareto_front_is_the_set_no_point_dominates() -> None:
    rng = np.random.default_rng(3)
    pts = [(float(a), float(b)) for a, b in rng.uniform(0, 1, size=(40, 2))]
    front = set(pareto_front(pts))
    brute = {
        i
        for i, p in enumerate(pts)
        if not any(q[0] <= p[0] and q[1] <= p[1] and q != p for j, q in enumerate(pts) if j != i)
    }
    assert front == brute


def rows(n: int = 6) -> list[dict[str, Any]]:
    out = []
    for i, (link, frac) in enumerate(itertools.product(["link2", "link4"], [0.2, 0.5, 0.8])):
        row: dict[str, Any] = {"candidate": f"c{i}", "index": i, "link": link, "fraction": frac}
        row |= dict.fromkeys(RESULT_COLUMNS)
        feasible = i % 3 != 2
        row |= {
            "point_x": 0.1 * i,
            "point_y": 0.0,
            "point_z": 0.0,
            "screened_out": i == 5,
            "completed": i != 5,
            "feasible": feasible and i != 5,
            "Ci_mean_gp": None if i == 5 else 1e-3 * (7 - i),
            "k_mean_gp": None if i == 5 else 2.0 + i,
            "Ci_mean_free_space": 0.016,
            "Ci_mean_min_norm": 0.009,
            "Ci_reduction_gp": 0.5,
            "min_link_clearance_m": 0.01,
            "wall_s": 1.0,
            "failure": None if feasible else "a link comes -0.1 m from the surface (< 0 m)",
        }
        if i == 5:
            row["failure"] = "screened out: ..."
        out.append(row)
    return out[:n]


def test_ranking_puts_feasible_rows_first_by_ci() -> None:
    order = [r["candidate"] for r in ranked(rows())]
    assert order == ["c4", "c3", "c1", "c0", "c2", "c5"]


def test_outputs_are_written_and_read_back(tmp_path: Path) -> None:
    import pyarrow.parquet as pq

    spec = load_spec("paper-links")
    run = SweepRun(spec, rows(), screened_out=1, evaluated=5)
    names = write_outputs(run, tmp_path)
    assert set(names) == {"results.parquet", "results.csv", "table.md", "summary.json", "heatmap.png", "pareto.png"}
    assert pq.read_table(tmp_path / "results.parquet").to_pylist() == run.rows
    with open(tmp_path / "results.csv", encoding="utf-8") as fh:
        table = list(csv.DictReader(fh))
    assert [r["candidate"] for r in table] == [r["candidate"] for r in run.rows]
    assert float(table[4]["Ci_mean_gp"]) == run.rows[4]["Ci_mean_gp"]
    s = json.loads((tmp_path / "summary.json").read_text())
    assert s["feasible"] == 4 and s["screened_out"] == 1 and s["best"]["candidate"] == "c4"
    assert s["screening"]["estimated_simulation_time_saved_s"] == pytest.approx(1.0)
    md = table_markdown(run)
    assert md.index("| 1 | c4 |") < md.index("| 2 | c3 |")
    assert summary(run)["not_feasible_by_reason"] == {"link clearance": 1, "screened out": 1}


def test_outputs_with_no_completed_run_are_written(tmp_path: Path) -> None:
    import pyarrow.parquet as pq

    spec = load_spec("paper-links")
    none: list[dict[str, Any]] = []
    for r in rows():
        r |= {"screened_out": True, "completed": False, "feasible": False, "failure": "screened out: k along the path"}
        r |= {"Ci_mean_gp": None, "k_mean_gp": None, "wall_s": None}
        none.append(r)
    run = SweepRun(spec, none, screened_out=len(none))
    names = write_outputs(run, tmp_path)
    assert set(names) == {"results.parquet", "results.csv", "table.md", "summary.json", "heatmap.png", "pareto.png"}
    assert (tmp_path / "pareto.png").stat().st_size > 0 and (tmp_path / "heatmap.png").stat().st_size > 0
    assert pq.read_table(tmp_path / "results.parquet").to_pylist() == none
    s = json.loads((tmp_path / "summary.json").read_text())
    assert s["feasible"] == 0 and s["best"] is None and s["not_feasible_by_reason"] == {"screened out": 6}
    assert "no feasible candidate" in table_markdown(run)


def test_a_brace_that_does_not_hold_is_counted_as_such_not_as_a_margin() -> None:
    from bracekit.studies.sweep.report import _reason

    row = {
        "screened_out": False,
        "failure": "the brace does not hold (holds = false: a margin below 1 or a torque beyond the effort limit)",
    }
    assert _reason(row) == "brace does not hold"
    assert _reason({"screened_out": False, "failure": "min_slip_margin 0.5 < 1"}) == "margin"
