"""Simulation: tracking with correction, contact kept to 1e-9 m, failures and region exits reported."""

from __future__ import annotations

import warnings

import numpy as np
import pinocchio as pin
import pytest

from bracekit import (
    BracedGradientProjection,
    BracedMinNorm,
    Circle,
    FreeSpaceMinNorm,
    InputError,
    load_scenario,
    simulate,
    solve_start,
)
from bracekit.errors import ConvergenceError, NoRedundancyWarning, RegionWarning
from bracekit.simulation.simulate import correct
from bracekit.simulation.start import START_CONDITIONING_FLOOR
from helpers import iiwa_like_urdf, iiwa_scenario_text


@pytest.fixture(scope="module")
def setup():
    sc = load_scenario("paper")
    start = solve_start(sc.braced, sc.task.position(0.0), sc.guess)
    # the paper's circle at the paper's speed, first tenth of the turn (20 steps of 0.1 s)
    task = Circle(sc.task.centre, sc.task.radius, sc.task.normal, sc.task.period, sc.task.start_direction, turns=0.1)
    return sc, start, task


def test_solved_start_has_the_tip_on_the_task_and_the_contact_closed(setup) -> None:
    sc, start, _ = setup
    brace = sc.braced.brace
    assert np.linalg.norm(start.e - sc.task.position(0.0)) < 1e-10
    assert abs(brace.surface.signed_distance(start.split.b)) < 1e-10
    assert np.linalg.norm(start.split.b - brace.surface.point) < brace.region_radius
    assert np.all(start.q >= sc.robot.lower) and np.all(start.q <= sc.robot.upper)


@pytest.mark.parametrize("name", ["braced_min_norm", "braced_gradient_projection"])
def test_braced_runs_keep_the_bracing_point_on_the_surface_and_the_tip_on_the_task(setup, name: str) -> None:
    sc, start, task = setup
    tr = simulate(sc.braced, sc.strategy(name), task, start.q, 0.1, sc.beta_x)
    assert tr.completed, tr.failure
    assert tr.steps == 20
    surface = sc.braced.brace.surface
    for q, t in zip(tr.q, tr.t, strict=True):
        st = sc.braced.state(q)
        assert abs(surface.signed_distance(st.split.b)) < 1e-9  # recomputed, not the recorded value
        assert np.linalg.norm(st.e - task.position(t)) < 1e-9
    assert tr.summary()["max_contact_violation_m"] < 1e-9
    # the largest joint motion between samples, recorded per sample and in the summary
    steps = np.max(np.abs(np.diff(tr.q, axis=0)), axis=1)
    assert np.array_equal(tr.measures["joint_step"], np.r_[0.0, steps])
    assert tr.summary()["max_joint_step_rad"] == np.max(steps)


def test_free_space_run_tracks_the_task_but_leaves_the_surface(setup) -> None:
    sc, start, task = setup
    tr = simulate(sc.braced, FreeSpaceMinNorm(), task, start.q, 0.1, sc.beta_x)
    s = tr.summary()
    assert tr.completed and s["max_task_error_m"] < 1e-9
    assert s["max_contact_violation_m"] > 1e-4


def test_gradient_projection_lowers_the_objective_compared_with_minimum_norm(setup) -> None:
    sc, start, task = setup
    obj = sc.objective()
    mean_g = {}
    for strategy in (BracedMinNorm(), BracedGradientProjection(obj)):
        tr = simulate(sc.braced, strategy, task, start.q, 0.1, sc.beta_x)
        mean_g[strategy.name] = np.mean([obj.value(sc.braced.state(q)) for q in tr.q[1:]])
    assert mean_g["braced_gradient_projection"] < mean_g["braced_min_norm"]


def test_an_unreachable_task_ends_the_run_with_a_reported_failure(setup) -> None:
    sc, start, _ = setup
    far = Circle([3.0, 0.0, 0.0], 0.1, [0, 1, 0], 2.0, [1, 0, 0])
    tr = simulate(sc.braced, BracedMinNorm(), far, start.q, 0.1, sc.beta_x)
    assert not tr.completed
    assert tr.failure and "step 1" in tr.failure
    assert tr.q.shape[0] == tr.t.shape[0] == 1
    assert not tr.summary()["completed"]


def test_leaving_the_bracing_region_warns_but_does_not_stop_minimum_norm(setup) -> None:
    sc, start, task = setup
    small = sc.braced.brace
    from bracekit import Brace, BracedRobot

    tiny = BracedRobot(sc.robot, Brace(small.frame, small.surface, region_radius=0.02))
    with pytest.warns(RegionWarning):
        tr = simulate(tiny, BracedMinNorm(), task, start.q, 0.1, sc.beta_x)
    assert tr.completed
    assert tr.summary()["max_region_radius_m"] > 0.02
    assert tr.warnings


def test_correction_raises_convergence_error_for_an_unreachable_pose(setup) -> None:
    sc, start, _ = setup
    with pytest.raises(ConvergenceError):
        correct(sc.braced, start.q, np.array([5.0, 0.0, 0.0]), start.R_e, None, max_iter=5)


def test_simulate_rejects_a_non_positive_time_step(setup) -> None:
    sc, start, task = setup
    with pytest.raises(InputError):
        simulate(sc.braced, BracedMinNorm(), task, start.q, 0.0, sc.beta_x)


def test_no_warnings_or_nan_in_a_gradient_projection_run(setup) -> None:
    sc, start, task = setup
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        tr = simulate(sc.braced, sc.strategy("braced_gradient_projection"), task, start.q, 0.1, sc.beta_x)
    for values in tr.measures.values():
        assert np.all(np.isfinite(values))


def test_a_step_that_jumps_over_the_region_barrier_is_split_and_the_run_stays_inside(setup, monkeypatch) -> None:
    import importlib

    from bracekit import Brace, BracedGradientProjection, BracedRobot, ComplianceIndex, Objective, RegionBarrier

    sc, start, _ = setup
    b = sc.braced.brace
    # the barrier, 0.05 m from a start solved for 0.15 m, drives the wrist at ~5× its URDF velocity limit: raise
    # the limits, since this test is about the splitting (the joint-speed bound has its own tests)
    fast = pin.Model(sc.robot.model)
    fast.velocityLimit = 10 * sc.robot.model.velocityLimit
    braced = BracedRobot(bk_robot(fast, sc), Brace(b.frame, b.surface, region_radius=0.05))
    obj = Objective([ComplianceIndex([1, 0, 0, 0, 0, 0]), RegionBarrier(0.05, b.surface.point)], [100.0, 0.01])
    task = Circle(sc.task.centre, sc.task.radius, sc.task.normal, 5.0, sc.task.start_direction, turns=0.25)
    tr = simulate(braced, BracedGradientProjection(obj), task, start.q, 0.1, sc.beta_x)
    assert tr.completed, tr.failure
    assert tr.substeps > 0 and any("split" in w for w in tr.warnings)
    assert tr.summary()["max_region_radius_m"] < 0.05
    # without splitting, the same run hits the barrier and says so
    monkeypatch.setattr(importlib.import_module("bracekit.simulation.loop"), "MAX_SUBSTEP_DEPTH", 0)
    tr0 = simulate(braced, BracedGradientProjection(obj), task, start.q, 0.1, sc.beta_x)
    assert not tr0.completed and "leaves the region" in tr0.failure


def test_runs_report_joint_limits_and_surface_penetration(setup) -> None:
    from bracekit import Brace, BracedRobot, Surface
    from bracekit.errors import JointLimitWarning

    sc, start, task = setup
    tr = simulate(sc.braced, FreeSpaceMinNorm(), task, start.q, 0.1, sc.beta_x)
    s = tr.summary()
    surface = sc.braced.brace.surface
    recomputed = min(surface.signed_distance(sc.braced.state(q).split.b) for q in tr.q)
    assert s["min_surface_distance_m"] == pytest.approx(recomputed)
    assert s["max_joint_limit_violation_rad"] == 0.0
    # a robot whose limits sit just around the start: the run stops at the first step and says where
    model = sc.robot.model
    tight = pin.Model(model)
    tight.lowerPositionLimit = start.q - 1e-3
    tight.upperPositionLimit = start.q + 1e-3
    robot = bk_robot(tight, sc)
    braced = BracedRobot(robot, Brace(sc.braced.brace.frame, Surface(surface.point, surface.normal)))
    tr2 = simulate(braced, BracedMinNorm(), task, start.q, 0.1, sc.beta_x)
    assert not tr2.completed and tr2.steps == 0
    assert "step 1 (t = 0.100 s): joint" in tr2.failure and "limit" in tr2.failure
    assert tr2.summary()["max_joint_limit_violation_rad"] == 0.0
    # a start beyond the limits is reported (the run's steps never go beyond them)
    tight.lowerPositionLimit = start.q + 1e-3
    tight.upperPositionLimit = start.q + 2e-3
    braced = BracedRobot(bk_robot(tight, sc), Brace(sc.braced.brace.frame, Surface(surface.point, surface.normal)))
    with pytest.warns(JointLimitWarning, match="the start exceeds the joint limits"):
        tr3 = simulate(braced, BracedMinNorm(), task, start.q, 0.1, sc.beta_x)
    assert not tr3.completed


def _with_limits(sc, start, joint: int, below: float, above: float):
    """The paper's braced robot with joint `joint` (0-based) limited to [q0 − below, q0 + above]."""
    from bracekit import BracedRobot

    model = pin.Model(sc.robot.model)
    lower, upper = model.lowerPositionLimit.copy(), model.upperPositionLimit.copy()
    lower[joint], upper[joint] = start.q[joint] - below, start.q[joint] + above
    model.lowerPositionLimit, model.upperPositionLimit = lower, upper
    return BracedRobot(bk_robot(model, sc), sc.braced.brace)


def test_gradient_projection_with_the_joint_limit_term_stays_inside_a_limit_it_would_cross(setup) -> None:
    from bracekit.objective import JointLimits, Objective

    sc, start, task = setup
    # joint 7's lower limit 0.15 rad below the start: braced minimum norm moves it 0.09 rad down, gradient
    # projection of the paper's g 0.18 rad (before joint limits were enforced it crossed and completed)
    braced = _with_limits(sc, start, 6, 0.15, 1.5)
    gp = sc.strategy("braced_gradient_projection")
    plain = simulate(braced, gp, task, start.q, 0.1, sc.beta_x)
    assert not plain.completed
    assert "joint 7 reaches its lower limit" in plain.failure and "null-space motion scaled to 0" in plain.failure
    assert np.all(plain.q >= braced.robot.lower) and np.all(plain.q <= braced.robot.upper)
    obj = gp.objective
    limited = Objective([*obj.terms, JointLimits(braced.robot.lower, braced.robot.upper)], [*obj.weights, 1.0])
    tr = simulate(braced, BracedGradientProjection(limited, alpha=gp.alpha), task, start.q, 0.1, sc.beta_x)
    assert tr.completed, tr.failure
    assert tr.steps == 20
    assert np.all(tr.q >= braced.robot.lower) and np.all(tr.q <= braced.robot.upper)
    assert tr.summary()["max_joint_limit_violation_rad"] == 0.0
    assert np.min(tr.q[:, 6] - braced.robot.lower[6]) > 0.01


def test_minimum_norm_stops_where_the_task_takes_a_joint_to_its_limit(setup) -> None:
    sc, start, task = setup
    # braced minimum norm moves joint 6 0.28 rad down along this task; its limit is 0.2 rad below the start
    braced = _with_limits(sc, start, 5, 0.2, 1.5)
    tr = simulate(braced, BracedMinNorm(), task, start.q, 0.1, sc.beta_x)
    assert not tr.completed
    lower = braced.robot.lower[5]
    assert f"joint 6 reaches its lower limit {lower:.4g} rad at t = {tr.t[-1] + 0.1:.2f} s" in tr.failure
    assert "no null-space motion" in tr.failure
    assert tr.summary()["max_joint_limit_violation_rad"] == 0.0
    assert np.all(tr.q[:, 5] >= lower)


def bk_robot(model, sc):
    from bracekit import Robot

    return Robot(model=model, tip=sc.robot.tip, stiffness=sc.robot.stiffness)


# ------------------------------------------------------------------------------------------ start solve
def test_the_paper_start_is_the_plain_solve_the_conditioning_barrier_inactive(setup) -> None:
    sc, start, _ = setup
    plain = solve_start(sc.braced, sc.task.position(0.0), sc.guess, conditioning_weight=0.0)
    np.testing.assert_array_equal(start.q, plain.q)
    assert min(start.motions.conditioning(None, ("A", "J_braced")).values()) >= START_CONDITIONING_FLOOR


def test_a_theta_weight_needs_a_pad_axis(tmp_path) -> None:
    (tmp_path / "iiwa.urdf").write_text(iiwa_like_urdf(), encoding="utf-8")
    (tmp_path / "s.toml").write_text(iiwa_scenario_text(pad_axis=False), encoding="utf-8")
    sc = load_scenario(tmp_path / "s.toml")
    with pytest.raises(InputError, match="pad axis"):
        solve_start(sc.braced, sc.task.position(0.0), sc.guess, theta_weight=0.3)


@pytest.mark.parametrize("weights", [{"conditioning_weight": -1.0}, {"conditioning_floor": 0.0}, {"theta_weight": "x"}])
def test_bad_start_weights_are_input_errors(setup, weights: dict) -> None:
    sc, _, _ = setup
    with pytest.raises(InputError):
        solve_start(sc.braced, sc.task.position(0.0), sc.guess, **weights)


@pytest.mark.parametrize("pad_axis", [False, True], ids=["link-point", "pad-axis"])
def test_an_iiwa_braced_at_its_forearm_starts_conditioned_and_completes_the_braced_runs(
    tmp_path, pad_axis: bool
) -> None:
    """Before: the start solve pulled link_4's z (or the pad axis) to the normal with weight 0.3 and nothing
    kept A conditioned: σ_min/σ_max of A 5e-4 (7e-4 with the pad axis), and the braced runs failed their
    correction after 16 (32) steps. Now A's ratio is above 0.01 and every run completes."""
    (tmp_path / "iiwa.urdf").write_text(iiwa_like_urdf(), encoding="utf-8")
    (tmp_path / "s.toml").write_text(iiwa_scenario_text(pad_axis), encoding="utf-8")
    sc = load_scenario(tmp_path / "s.toml")
    assert sc.braced.brace.pad_axis is pad_axis and sc.robot.n == 7
    assert sc.start_theta_weight == (0.3 if pad_axis else 0.0)
    position = sc.task.position(0.0)
    start = solve_start(sc.braced, position, sc.guess, rotation=sc.task.rotation, theta_weight=sc.start_theta_weight)
    ratios = start.motions.conditioning(None, ("A", "J_braced"))
    assert ratios["A"] > 0.01 and ratios["J_braced"] > 0.05
    assert np.linalg.norm(start.e - position) < 1e-10
    assert abs(sc.braced.brace.surface.signed_distance(start.split.b)) < 1e-10
    if pad_axis:  # the pad axis is pulled toward the normal
        assert np.degrees(np.arccos(start.split.z_b @ sc.braced.brace.surface.normal)) < 20.0
    unconditioned = solve_start(
        sc.braced,
        position,
        sc.guess,
        rotation=sc.task.rotation,
        theta_weight=0.3 if pad_axis else 0.0,
        conditioning_weight=0.0,
    )
    assert unconditioned.motions.conditioning(None, ("A",))["A"] < 0.01
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RegionWarning)
        for name in ("braced_min_norm", "braced_gradient_projection"):
            # a 7-joint arm, a point contact and a 6-D pose task: gradient projection has no room, and says so
            expected = NoRedundancyWarning if name == "braced_gradient_projection" else None
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always", NoRedundancyWarning)
                tr = simulate(sc.braced, sc.strategy(name), sc.task, start.q, sc.dt, sc.beta_x)
            assert [w.category for w in caught if w.category is NoRedundancyWarning] == ([expected] if expected else [])
            assert tr.completed, tr.failure
            assert tr.summary()["max_contact_violation_m"] < 1e-9


def test_an_arm_with_continuous_joints_solves_its_start_and_runs_with_unbounded_angles(tmp_path) -> None:
    text = iiwa_like_urdf()
    for j in ("joint_1", "joint_7"):
        head = f'<joint name="{j}" type="revolute">'
        start = text.index(head)
        end = text.index("</joint>", start)
        body = text[start:end].replace(head, f'<joint name="{j}" type="continuous">')
        text = text[:start] + body[: body.index("<limit")] + text[end:]
    (tmp_path / "iiwa.urdf").write_text(text, encoding="utf-8")
    (tmp_path / "s.toml").write_text(iiwa_scenario_text(pad_axis=True), encoding="utf-8")
    sc = load_scenario(tmp_path / "s.toml")
    assert np.isneginf(sc.robot.lower[[0, 6]]).all() and np.isposinf(sc.robot.upper[[0, 6]]).all()
    start = solve_start(sc.braced, sc.task.position(0.0), sc.guess, theta_weight=sc.start_theta_weight)
    assert start.q.shape == (7,)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RegionWarning)
        tr = simulate(sc.braced, sc.strategy("braced_min_norm"), sc.task, start.q, sc.dt, sc.beta_x)
    assert tr.completed, tr.failure
    assert tr.summary()["max_joint_limit_violation_rad"] == 0.0


def test_gradient_projection_scales_its_null_space_motion_at_a_limit_fused_and_reference_alike(setup) -> None:
    import dataclasses

    sc, start, task = setup
    # joint 9's upper limit 0.1 rad above the start: braced minimum norm leaves joint 9 where it is, the
    # paper's gradient projection moves it 0.13 rad up; scaled steps keep it inside and the run completes
    braced = _with_limits(sc, start, 8, 1.5, 0.1)
    gp = sc.strategy("braced_gradient_projection")
    tr = simulate(braced, gp, task, start.q, 0.1, sc.beta_x)
    assert tr.completed, tr.failure
    assert np.all(tr.q <= braced.robot.upper) and tr.summary()["max_joint_limit_violation_rad"] == 0.0
    assert np.max(tr.q[:, 8]) > braced.robot.upper[8] - 0.02  # it goes up to the limit, not further
    assert any("null-space motion scaled down" in w for w in tr.warnings)

    @dataclasses.dataclass(frozen=True)
    class Reference(BracedGradientProjection):  # not the exact type: simulate takes the reference path
        pass

    ref = simulate(braced, Reference(gp.objective, alpha=gp.alpha), task, start.q, 0.1, sc.beta_x)
    assert ref.completed and ref.warnings == tr.warnings
    assert np.max(np.abs(ref.q - tr.q)) < 1e-8


def test_runs_record_the_link_clearance_and_warn_when_a_link_passes_through_the_plane(setup) -> None:
    from bracekit.errors import ClearanceWarning
    from bracekit.kinematics.clearance import link_clearance

    sc, start, task = setup
    with pytest.warns(ClearanceWarning, match=r"into the body under the bracing disk \(radius 0\.15 m\)"):
        tr = simulate(sc.braced, FreeSpaceMinNorm(), task, start.q, 0.1, sc.beta_x)
    recomputed = [link_clearance(sc.braced.state(q))[0] for q in tr.q]
    np.testing.assert_allclose(tr.measures["link_clearance"], recomputed)
    assert tr.summary()["min_link_clearance_m"] == pytest.approx(min(recomputed)) and min(recomputed) < 0
    assert any("m into the body under the bracing disk (radius 0.15 m)" in w for w in tr.warnings)


@pytest.mark.parametrize("name", ["paper", "two-braces"])
def test_without_numba_the_run_takes_the_numpy_step_says_so_and_follows_the_same_path(name, monkeypatch) -> None:
    import importlib

    from bracekit.errors import InputError as Refused
    from bracekit.resolution import fused
    from bracekit.simulation.loop import STEP_BACKEND_NOTE

    if not fused.numba_available():
        pytest.skip("numba is not installed: every run takes the NumPy step")
    sc = load_scenario(name)
    start = solve_start(sc.braced, sc.task.position(0.0), sc.guess)
    c = sc.task  # the scenario's circle, its first twentieth
    task = Circle(c.centre, c.radius, c.normal, c.period, c.start_direction, turns=0.05)
    gp = sc.strategy("braced_gradient_projection")
    compiled = simulate(sc.braced, gp, task, start.q, sc.dt, sc.beta_x)
    assert fused.fused_step(sc.braced, gp, "auto").uses_kernel  # type: ignore[union-attr]

    def no_numba() -> None:
        raise Refused("numba cannot be imported here")

    real_import = importlib.import_module  # the patch below replaces importlib's own attribute

    def no_module(name: str, *args, **kwargs):  # type: ignore[no-untyped-def]
        if "_numba" in name:
            raise ImportError(f"no module named {name}")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(fused, "numba_kernels", no_numba)
    monkeypatch.setattr(fused.importlib, "import_module", no_module)
    assert fused.fused_step(sc.braced, gp, "auto").fallback_reason == "numba cannot be imported"  # type: ignore[union-attr]
    plain = simulate(sc.braced, gp, task, start.q, sc.dt, sc.beta_x)
    monkeypatch.undo()
    assert plain.completed and compiled.completed
    assert plain.warnings == [*compiled.warnings, f"braced_gradient_projection: {STEP_BACKEND_NOTE}"]
    # the compiled and the NumPy step give the reference's q̇ to ~1e-13: the paths differ by rounding only
    assert np.max(np.abs(plain.q - compiled.q)) < 1e-9
    mn = simulate(sc.braced, sc.strategy("braced_min_norm"), task, start.q, sc.dt, sc.beta_x)
    assert all(STEP_BACKEND_NOTE not in w for w in mn.warnings)  # no step of its own to fall back from
