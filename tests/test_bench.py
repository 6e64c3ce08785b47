"""Smoke test of the benchmark entry point: it runs and returns the promised keys (no timing asserted)."""

from __future__ import annotations

import json
import math

import pytest

from bracekit.bench import run_benchmarks

KEYS = (
    "gp_step_analytic_us",
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
    return run_benchmarks(quick=True)


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
