"""Ratios between two benchmark results and the speed goals, against numbers worked out by hand."""

from __future__ import annotations

import json
from pathlib import Path

import bench_compare
import pytest

from bracekit.errors import InputError

OLD = {
    "run_paper_s": 3.0,
    "run_two_braces_s": 4.0,
    "sweep_candidates_per_s_1": 1.0,
    "sweep_candidates_per_s_2": 2.0,
    "pinocchio_floor_us": 5.0,
    "only_old_s": 1.0,
    "quick": False,
    "sweep_candidates": 16,
    "machine": {"cores": 2, "load_average": [1.5, 1.0, 0.5], "commit": "e6bc01a" + "0" * 33, "cpu_model": "X"},
}
NEW = {
    "run_paper_s": 0.5,  # 6× faster
    "run_two_braces_s": 1.0,  # 4× faster
    "sweep_candidates_per_s_1": 6.0,
    "sweep_candidates_per_s_2": 11.0,  # 5.5× faster; 11/6 = 1.83× one worker
    "pinocchio_floor_us": 4.0,
    "control_step_us": 44.0,  # 11× the new floor
    "only_new_s": 2.0,
    "quick": True,
    "sweep_candidates": 4,
    "machine": {"cores": 2, "load_average": [0.2, 0.1, 0.1], "commit": "abc"},
}


def test_ratios_are_new_over_old_for_the_measurements_both_hold() -> None:
    c = bench_compare.compare(NEW, OLD)
    ratios = {r.key: r.ratio for r in c.rows}
    assert ratios == {
        "run_paper_s": 0.5 / 3.0,
        "run_two_braces_s": 0.25,
        "sweep_candidates_per_s_1": 6.0,
        "sweep_candidates_per_s_2": 5.5,
        "pinocchio_floor_us": 0.8,
    }  # settings (quick, sweep_candidates), one-sided keys and the machine are not compared
    assert c.old_machine["commit"].startswith("e6bc01a") and c.new_machine["commit"] == "abc"


def test_goals_pass_or_fail_by_their_bounds() -> None:
    goals = {g.name: g for g in bench_compare.compare(NEW, OLD).goals}
    paper, two = goals["paper run ×5 faster (wall)"], goals["two-braces run ×5 faster (wall)"]
    assert paper.value == pytest.approx(6.0) and paper.passed and paper.at_least
    assert two.value == pytest.approx(4.0) and not two.passed
    sweep = goals["sweep on 2 workers ×5 faster"]
    assert sweep.value == pytest.approx(5.5) and sweep.passed
    scaling = goals["sweep scaling 1 → 2 workers ≥ 1.8"]
    assert scaling.value == pytest.approx(11.0 / 6.0) and scaling.passed
    step = goals["control step ≤ 10× Pinocchio floor"]
    assert step.value == pytest.approx(11.0) and not step.passed and not step.at_least
    # the two-brace control step was not measured: its goal is left out, not failed
    assert "control step, two braces ≤ 10× floor" not in goals


def test_table_names_both_machines_and_every_goal() -> None:
    text = bench_compare.table(bench_compare.compare(NEW, OLD))
    assert "commit e6bc01a00000" in text and "load 1.50" in text and "load 0.20" in text
    assert "PASS: paper run ×5 faster (wall): 6.00 (goal ≥ 5)" in text
    assert "FAIL: two-braces run ×5 faster (wall): 4.00 (goal ≥ 5)" in text
    assert "FAIL: control step ≤ 10× Pinocchio floor: 11.00 (goal ≤ 10)" in text
    assert "| run_paper_s" in text and "0.167" in text
    json.dumps(bench_compare.as_dict(bench_compare.compare(NEW, OLD)))


def test_the_committed_baseline_holds_the_goals_keys_and_its_machine() -> None:
    base = bench_compare.load(Path(__file__).parents[1] / "benchmarks" / "baseline-e6bc01a.json")
    for key in ("run_paper_s", "run_two_braces_s", "sweep_candidates_per_s_2", "pinocchio_floor_us", "step_gp_us"):
        assert base[key] > 0, key
    m = base["machine"]
    assert m["commit"].startswith("e6bc01a") and m["cores"] >= 1 and len(m["load_average"]) == 3 and m["cpu_model"]


def test_a_bad_file_is_refused_in_one_line(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="cannot read"):
        bench_compare.load(tmp_path / "missing.json")
    bad = tmp_path / "bad.json"
    bad.write_text("{not json", encoding="utf-8")
    with pytest.raises(InputError, match=r"is not JSON .* bracekit bench --json"):
        bench_compare.load(bad)
    bad.write_text("[1, 2]", encoding="utf-8")
    with pytest.raises(InputError, match="holds no benchmark object"):
        bench_compare.load(bad)


def test_bench_refuses_a_bad_compare_file_in_one_line_before_measuring(tmp_path: Path, capsys) -> None:
    from bracekit.cli import main

    bad = tmp_path / "old.json"
    bad.write_text("{", encoding="utf-8")
    assert main(["bench", "--only", "runs", "--compare", str(bad)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "is not JSON" in err[0] and "Traceback" not in err[0]
