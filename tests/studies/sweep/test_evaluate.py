from __future__ import annotations

import dataclasses
import re
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin
import pytest

from bracekit.errors import InputError
from bracekit.resolution.strategies import FreeSpaceMinNorm
from bracekit.simulation.run import run_scenario
from bracekit.simulation.scenario import load_scenario
from bracekit.simulation.simulate import simulate
from bracekit.studies.sweep.candidates import expand
from bracekit.studies.sweep.context import free_space_context, reference_context, task_context
from bracekit.studies.sweep.evaluate import RESULT_COLUMNS, evaluate_candidate, with_free_space
from bracekit.studies.sweep.spec import load_spec


def _by_hand(
    base: str, link_joint: int, fraction: float, q_ref: np.ndarray, robot_model: pin.Model
) -> tuple[str, np.ndarray]:
    """The candidate scenario written by hand: a point on the link, the plane through it at q_ref, guess q_ref."""
    data = robot_model.createData()
    pin.forwardKinematics(robot_model, data, q_ref)
    local = fraction * np.asarray(robot_model.jointPlacements[link_joint + 1].translation)
    point = data.oMi[link_joint].act(local)
    brace = (
        "[brace]\n"
        f'link = "link{link_joint}"\nframe = "p"\noffset = {local.tolist()}\n'
        f"point = {point.tolist()}\nnormal = [0.0, 0.0, 1.0]\nregion_radius = 0.15\n\n"
    )
    text = re.sub(r"(?ms)^\[brace\].*?(?=^\[task\])", brace, base)
    text = re.sub(r"(?m)^guess = .*$", f"guess = {q_ref.tolist()}", text)
    text = re.sub(r"theta_z = 0\.6", "theta_z = 0.0", text)
    text = re.sub(r"(?m)^strategies = .*$", 'strategies = ["braced_min_norm", "braced_gradient_projection"]', text)
    return text, point


def test_a_row_equals_an_independent_run_of_its_scenario(tiny_spec: Path, tmp_path: Path) -> None:
    spec = load_spec(tiny_spec)
    cand = expand(spec)[3]  # link8 at 0.7
    ctx = task_context(spec, {}, cand.context_key)
    assert ctx.q_ref is not None
    row = evaluate_candidate(spec, cand, ctx)
    assert set(RESULT_COLUMNS) <= set(row)
    base = (tiny_spec.parent / "short.toml").read_text()
    sc0 = load_scenario(tiny_spec.parent / "short.toml")
    model = sc0.robot.model
    # the reference start: the tip at the task's start, with the guess's tip orientation
    data = model.createData()
    pin.framesForwardKinematics(model, data, ctx.q_ref)
    tip = data.oMf[sc0.robot.tip_id]
    np.testing.assert_allclose(tip.translation, sc0.task.position(0.0), atol=1e-9)
    pin.framesForwardKinematics(model, data, sc0.guess)
    np.testing.assert_allclose(tip.rotation, data.oMf[sc0.robot.tip_id].rotation, atol=1e-9)
    text, point = _by_hand(base, 8, 0.7, ctx.q_ref, model)
    path = tmp_path / "cand.toml"
    path.write_text(text, encoding="utf-8")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ref = run_scenario(load_scenario(path), both_models=False).summary["strategies"]
    np.testing.assert_allclose([row["point_x"], row["point_y"], row["point_z"]], point, atol=1e-12)
    gp, mn = ref["braced_gradient_projection"], ref["braced_min_norm"]
    assert row["completed"] == gp["completed"] and row["completed_min_norm"] == mn["completed"]
    for key, value in (
        ("Ci_mean_gp", gp["Ci_mean"]),
        ("Ci_mean_min_norm", mn["Ci_mean"]),
        ("k_mean_gp", gp["k_mean"]),
        ("k_mean_min_norm", mn["k_mean"]),
        ("min_link_clearance_m", gp["min_link_clearance_m"]),
        ("max_region_radius_m", gp["max_region_radius_m"]),
    ):
        assert row[key] == pytest.approx(value, rel=1e-9, abs=1e-12), key
    # the free-space run of the task context: minimum norm from the reference start
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        free = simulate(sc0.braced, FreeSpaceMinNorm(), sc0.task, ctx.q_ref, sc0.dt, sc0.beta_x)
    assert row["Ci_mean_free_space"] == pytest.approx(float(np.mean(free.measures["Ci_free"])), rel=1e-12)
    assert row["Ci_reduction_gp"] == pytest.approx(1 - gp["Ci_mean"] / row["Ci_mean_free_space"], rel=1e-12)
    assert row["feasible"] == (gp["completed"] and gp["k_mean"] <= 50 and gp["min_link_clearance_m"] >= 0)


def test_a_candidate_whose_run_fails_gets_a_row_with_the_reason(tiny_spec: Path) -> None:
    spec = load_spec(tiny_spec)
    cand = expand(spec)[0]
    ctx = task_context(spec, {}, cand.context_key)
    bad = dataclasses.replace(spec, region_radius=1e-4)  # the point leaves so small a region at once
    row = evaluate_candidate(bad, cand, ctx)
    assert row["completed"] is False and row["feasible"] is False
    assert row["failure"] and "\n" not in row["failure"]


def _no_time(row: dict[str, Any]) -> dict[str, Any]:
    return {k: v for k, v in row.items() if k != "wall_s"}


def test_a_row_from_the_reference_start_completed_by_the_free_space_run_is_the_whole_contexts_row(
    tiny_spec: Path,
) -> None:
    """A candidate run while the free-space run is under way gets, once it ends, the row of the whole context."""
    spec = load_spec(tiny_spec)
    cand = expand(spec)[3]
    ref = reference_context(spec, {}, cand.context_key)
    whole = free_space_context(spec, ref)
    assert ref.free == {} and ref.q_ref is not None and whole.q_ref is not None
    np.testing.assert_array_equal(whole.q_ref, task_context(spec, {}, cand.context_key).q_ref)
    early = evaluate_candidate(spec, cand, ref)
    assert early["Ci_mean_free_space"] is None and early["Ci_reduction_gp"] is None
    row = with_free_space(spec, cand, early, whole)
    assert _no_time(row) == _no_time(evaluate_candidate(spec, cand, whole))
    assert row["Ci_reduction_gp"] == pytest.approx(1.0 - row["Ci_mean_gp"] / row["Ci_mean_free_space"], rel=1e-15)


def test_a_failed_free_space_run_gives_the_row_of_a_failed_context(tiny_spec: Path) -> None:
    """A free-space run that fails after the candidate ran: the row says the context failed, as when it fails first."""
    spec = load_spec(tiny_spec)
    cand = expand(spec)[0]
    ref = reference_context(spec, {}, cand.context_key)
    failed = dataclasses.replace(ref, q_ref=None, failure="task context: the free-space run left the joint limits")
    row = with_free_space(spec, cand, evaluate_candidate(spec, cand, ref), failed)
    assert _no_time(row) == _no_time(evaluate_candidate(spec, cand, failed))
    assert row["failure"] == failed.failure and row["completed"] is False and row["Ci_mean_gp"] is None


def test_a_search_evaluation_is_the_rows_gradient_projection_without_minimum_norm(tiny_spec: Path) -> None:
    """A refinement's evaluation runs gradient projection only: its columns are the full row's, min norm's None."""
    from bracekit.studies.sweep.evaluate import SEARCH_STRATEGIES

    spec = load_spec(tiny_spec)
    cands = expand(spec)
    ctx = task_context(spec, {}, cands[0].context_key)
    minimum_norm = ("Ci_mean_min_norm", "k_mean_min_norm", "completed_min_norm", "failure_min_norm")
    for c in cands:
        full = evaluate_candidate(spec, c, ctx)
        search = evaluate_candidate(spec, c, ctx, SEARCH_STRATEGIES)
        assert full["completed_min_norm"] is not None
        assert all(search[key] is None for key in minimum_norm)
        assert search["warnings"] <= full["warnings"]
        skip = {*minimum_norm, "warnings", "wall_s"}
        assert {k: v for k, v in search.items() if k not in skip} == {k: v for k, v in full.items() if k not in skip}
    with pytest.raises(InputError, match="strategies"):
        evaluate_candidate(spec, cands[0], ctx, ("braced_min_norm",))
