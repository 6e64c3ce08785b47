"""The whole-run benchmarks and the baseline script: what they measure and record (no timing asserted)."""

from __future__ import annotations

import importlib.util
import json
import math
import subprocess
import sys
from pathlib import Path

import bench_runs
import pytest

ROOT = Path(__file__).resolve().parents[1]


def _load_tool() -> object:
    spec = importlib.util.spec_from_file_location("bench_baseline", ROOT / "tools" / "bench_baseline.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _git_head() -> str:
    return subprocess.run(["git", "-C", str(ROOT), "rev-parse", "HEAD"], capture_output=True, text=True).stdout.strip()


def test_the_machine_names_cores_load_cpu_date_and_the_commit_git_reports() -> None:
    m = bench_runs.machine()
    assert m["cores"] >= 1 and len(m["load_average"]) == 3 and m["cpu_model"]
    assert m["date_utc"].endswith("Z") and m["python"] == ".".join(map(str, sys.version_info[:3]))
    assert Path(m["bracekit_path"]) == ROOT / "src" / "bracekit"
    assert m["commit"].removesuffix("+dirty") == _git_head()


def test_the_steps_and_floors_are_timed_and_the_ratio_is_theirs() -> None:
    r = bench_runs.step_runs(calls=8, rounds=1)
    for key in ("pinocchio_floor_us", "pinocchio_floor_two_frames_us", "pinocchio_floor_two_braces_us", "step_gp_us"):
        assert isinstance(r[key], float) and math.isfinite(r[key]) and r[key] > 0, key
    assert r["step_gp_in_floors"] == pytest.approx(r["step_gp_us"] / r["pinocchio_floor_us"])
    assert r["step_gp_backend"] in ("numba", "numpy")
    if "control_step_us" in r:  # a version with a control-rate step times it against the same floor
        assert r["control_step_in_floors"] == pytest.approx(r["control_step_us"] / r["pinocchio_floor_us"])
    else:
        assert "ControlStep" in r["control_step_skipped"]


def test_rounds_of_one_checkout_merge_into_medians() -> None:
    tool = _load_tool()
    machine = {"load_average": [1.0, 1.0, 1.0], "load_average_after": [2.0, 1.0, 1.0], "commit": "c"}
    rounds = [
        {"run_paper_s": 3.0, "step_gp_backend": "numba", "machine": machine},
        {"run_paper_s": 1.0, "step_gp_backend": "numba", "machine": {**machine, "load_average_after": [5.0, 2, 1]}},
        {"run_paper_s": 2.0, "step_gp_backend": "numba", "machine": {**machine, "load_average_after": [7.0, 2, 1]}},
    ]
    merged = tool.merge(rounds)  # type: ignore[attr-defined]
    assert merged["run_paper_s"] == 2.0 and merged["step_gp_backend"] == "numba" and merged["rounds"] == 3
    assert merged["machine"]["load_average"] == [1.0, 1.0, 1.0]  # before the first round
    assert merged["machine"]["load_average_after"] == [7.0, 2, 1]  # after the last


def test_the_baseline_script_measures_a_checkout_in_a_new_process(tmp_path: Path) -> None:
    out = tmp_path / "this.json"
    cmd = [sys.executable, str(ROOT / "tools" / "bench_baseline.py"), str(ROOT), "--out", str(out), "--quick"]
    proc = subprocess.run([*cmd, "--no-sweep"], capture_output=True, text=True, check=False)
    assert proc.returncode == 0, proc.stderr[-2000:]
    r = json.loads(out.read_text(encoding="utf-8"))
    for key in ("run_paper_s", "run_two_braces_s", "run_panda_s", "run_paper_cpu_s", "step_gp_us"):
        assert r[key] > 0, key
    assert Path(r["machine"]["bracekit_path"]) == ROOT / "src" / "bracekit"  # this checkout's bracekit, not another
    assert r["machine"]["commit"].removesuffix("+dirty") == _git_head() and r["rounds"] == 1


def test_a_source_tree_without_bracekit_is_refused(tmp_path: Path) -> None:
    cmd = [sys.executable, str(ROOT / "tools" / "bench_baseline.py"), str(tmp_path), "--out", str(tmp_path / "x")]
    proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
    assert proc.returncode == 1 and "holds no src/bracekit" in proc.stderr and "Traceback" not in proc.stderr
    assert not (tmp_path / "x").exists()


def test_bench_with_runs_prints_the_ratios_and_goals_against_a_file(tmp_path: Path) -> None:
    from bench import run_benchmarks

    old = {"run_paper_s": 100.0, "run_two_braces_s": 1e-3, "machine": {"cores": 2, "commit": "0ld"}}
    path = tmp_path / "old.json"
    path.write_text(json.dumps(old), encoding="utf-8")
    r = run_benchmarks(quick=True, parts=("runs",), compare=path)
    assert "PASS: paper run ×5 faster (wall)" in r["table"]  # nobody's paper run takes 20 s
    assert "FAIL: two-braces run ×5 faster (wall)" in r["table"]  # nor 0.2 ms
    ratios = {row["key"]: row["ratio"] for row in r["comparison"]["ratios"]}
    assert ratios["run_paper_s"] == pytest.approx(r["run_paper_s"] / 100.0)
    assert r["machine"]["cores"] >= 1 and "Against old.json" in r["table"]
    # a step of a two-brace run against a step of a one-brace run: the ratio of the two times, and its goal
    assert r["run_step_one_brace_us"] > 0 and r["run_step_two_braces_us"] > 0
    assert r["run_step_braces_ratio"] == pytest.approx(r["run_step_two_braces_us"] / r["run_step_one_brace_us"])
    assert "run_step_braces_ratio" in r["table"]
    goal = "two-braces run step ≤ 2× a one-brace run step"
    (row,) = [g for g in r["comparison"]["goals"] if g["name"] == goal]
    assert row["passed"] == (r["run_step_braces_ratio"] <= 2.0)
    json.dumps(r)


def test_the_sweep_is_timed_on_one_and_two_workers() -> None:
    pytest.importorskip("distributed")
    r = bench_runs.sweep_runs(candidates=2)
    assert r["sweep_candidates"] == 2
    assert r["sweep_candidates_per_s_1"] > 0 and r["sweep_candidates_per_s_2"] > 0
    assert r["sweep_scaling_1_to_2"] == pytest.approx(r["sweep_candidates_per_s_2"] / r["sweep_candidates_per_s_1"])
    for n in (1, 2):  # the command's time: its candidates' share of the workers and the rest
        elapsed = 2 / r[f"sweep_candidates_per_s_{n}"]
        assert 0 < r[f"sweep_candidate_s_{n}"] < elapsed * n
        assert r[f"sweep_fixed_s_{n}"] == pytest.approx(elapsed - 2 * r[f"sweep_candidate_s_{n}"] / n)


def test_the_table_shows_the_control_step_against_its_floor_and_says_why_a_step_is_missing() -> None:
    from bench_table import extra_table

    r = {
        "step_gp_us": 20.0,
        "step_gp_backend": "numba",
        "step_gp_in_floors": 5.0,
        "pinocchio_floor_us": 4.0,
        "pinocchio_floor_two_braces_us": 6.0,
        "control_step_us": 30.0,
        "control_step_in_floors": 7.5,
        "control_step_two_braces_failed": "TypeError: no two braces",
        "machine": {"cores": 2, "load_average": [1.25, 1, 1], "load_average_after": [2.5, 1, 1], "commit": "abc"},
    }
    lines = extra_table(r).splitlines()
    assert "2 cores" in lines[0] and "load 1.25 → 2.50" in lines[0] and "commit abc" in lines[0]
    (step,) = [line for line in lines if line.startswith("Control step, paper")]
    assert "30.0 µs" in step and "7.5× its floor (goal ≤ 10)" in step
    (failed,) = [line for line in lines if line.startswith("control step two braces failed")]
    assert "TypeError: no two braces" in failed
