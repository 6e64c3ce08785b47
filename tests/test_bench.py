"""Smoke test of the benchmark entry point: it runs and returns the promised keys (no timing asserted)."""

from __future__ import annotations

import copy
import importlib.util
import json
import math

import pytest
from bench import run_benchmarks
from bench_table import core_table, extra_table

KEYS = (
    "gp_step_analytic_us",
    "gp_step_analytic_numpy_us",
    "gp_step_fd_ratio_numpy",
    "gp_step_fd_us",
    "gp_step_fd_ratio",
    "gp_step_fd_reference_us",
    "gp_step_analytic_reference_us",
    "pinocchio_floor_us",
    "batch_configs_per_s",
    "scenario_wall_s",
)


@pytest.fixture(scope="module")
def results() -> dict:
    return run_benchmarks(quick=True, parts=("core",))  # sweep and figures: whole processes, run by bench


def test_run_benchmarks_returns_positive_finite_numbers_and_a_table(results: dict) -> None:
    for key in KEYS:
        value = results[key]
        assert isinstance(value, float) and math.isfinite(value) and value > 0, (key, value)
    assert results["scenario_exit_code"] == 0
    assert isinstance(results["table"], str) and "GP step" in results["table"]
    assert results["gp_step_max_rel_diff"] < 1e-10  # the fused step equals the reference path
    assert results["batch"]["max_rel_diff"] < 1e-12
    json.dumps(results)  # what `bracekit bench --json` prints


def test_robotics_toolbox_is_optional(results: dict) -> None:
    rtb = results["rtb"]
    if rtb["available"]:
        assert rtb["max_abs_diff_vs_pinocchio"] < 1e-12  # the same chain
        assert rtb["jacob0_us"] > 0 and rtb["hessian0_us"] > 0
    else:
        assert rtb["reason"]


def test_both_backends_side_by_side(results: dict) -> None:
    numpy_us, numba_us = results["gp_step_analytic_numpy_us"], results["gp_step_analytic_numba_us"]
    assert results["gp_step_analytic_us"] == min(numpy_us, numba_us if numba_us is not None else math.inf)
    assert results["gp_step_max_rel_diff_numpy"] < 1e-10
    if importlib.util.find_spec("numba") is None:
        assert numba_us is None and results["gp_step_fd_ratio_numba"] is None
        assert not results["numba"]["available"] and "pip install bracekit[fast]" in results["numba"]["reason"]
        assert "skipped" in results["table"]
        return
    assert isinstance(numba_us, float) and math.isfinite(numba_us) and numba_us > 0
    assert results["gp_step_max_rel_diff_numba"] < 1e-10  # the numba kernel equals the reference path
    assert results["numba"]["kernel_used"]
    assert results["gp_step_fd_ratio_numba"] == pytest.approx(results["gp_step_fd_us"] / numba_us)
    # a fresh process imports numba and loads the kernel from the disk cache this process filled
    warm = results["numba"]["warm"]
    assert warm["ok"] and warm["cache_hits"] == 1 and warm["cache_misses"] == 0, warm
    assert results["numba_import_and_cache_load_s"] == pytest.approx(
        results["numba_import_s"] + results["numba_cache_load_s"]
    )
    assert results["numba"]["empty_cache"] is None  # the compilation from scratch is measured in full runs only
    assert "numba backend" in results["table"] and "cache load" in results["table"]


def test_table_without_numba(results: dict) -> None:
    r = copy.deepcopy(results)
    r["numba"] = {"available": False, "reason": "numba missing", "version": None}
    r["environment"]["numba"] = None
    for key in ("gp_step_analytic_numba_us", "gp_step_fd_ratio_numba", "gp_step_max_rel_diff_numba"):
        r[key] = None
    for key in ("numba_compile_s", "numba_import_s", "numba_cache_load_s", "numba_import_and_cache_load_s"):
        r[key] = None
    table = core_table(r)
    numba_rows = [line for line in table.splitlines() if line.startswith("|") and "numba backend" in line]
    assert len(numba_rows) == 1 and "skipped" in numba_rows[0] and "bracekit[fast]" in numba_rows[0]
    assert "NumPy backend" in table and "cache load" not in table


def test_sweep_and_figures_rows_read_their_keys() -> None:
    table = extra_table(
        {
            "sweep_candidates_per_s_1": 0.8,
            "sweep_candidates_per_s_2": 1.5,
            "sweep_candidates": 8.0,
            "run_figures_s": 3.0,
            "run_no_figures_s": 2.0,
            "figures_overhead_ratio": 1.5,
            "run_figures_cpu_s": 3.5,
            "run_no_figures_cpu_s": 2.1,
        }
    )
    assert "1.88× one worker" in table and "figures_overhead_ratio" in table and "1.50" in table


def test_an_unknown_part_is_refused() -> None:
    from bracekit.errors import InputError

    with pytest.raises(InputError, match="unknown benchmark part"):
        run_benchmarks(quick=True, parts=("everything",))
