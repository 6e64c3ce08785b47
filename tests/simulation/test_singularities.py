"""Runs never pass a singularity silently: a joint jump or a singular Jacobian ends the run with its reason.

The user cases are variants of the paper scenario (dt = 0.05 s) whose runs, before these checks, jumped
between two samples (joints 4 and 6 of the PUMA's wrist by 11.3, 75 and 14.6 rad) and reported success.
"""

from __future__ import annotations

import importlib
import re
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin
import pytest

from bracekit import (
    Brace,
    BracedMinNorm,
    BracedRobot,
    Circle,
    InputError,
    Robot,
    Surface,
    load_scenario,
    simulate,
    solve_start,
)
from bracekit.errors import BracekitWarning, ConvergenceError
from bracekit.simulation.scenario import Scenario
from bracekit.simulation.simulate import (
    Trajectory,
    contact_jacobian,
    contact_residual,
    correct,
    joint_step_bound,
    reach,
)
from bracekit.tolerances import DEFAULT_JOINT_SPEED, JOINT_STEP_SAFETY, MAX_JOINT_STEP
from helpers import random_chain_urdf, scenario_text

GUARDS = importlib.import_module("bracekit.simulation.guards")
START = importlib.import_module("bracekit.simulation.start")


def _scenario(tmp_path: Path, name: str, **keys: Any) -> Scenario:
    path = tmp_path / f"{name}.toml"
    path.write_text(scenario_text(**keys), encoding="utf-8")
    return load_scenario(path)


def _run(sc: Scenario, name: str) -> Trajectory:
    """The scenario's run from its solved start, with the joint ranges widened to ±1000 rad.

    These runs reach singularities past the PUMA's joint limits (they used to go beyond them): the wide
    ranges keep the singularity, not the limit, what stops them.
    """
    start = solve_start(sc.braced, sc.task.position(0.0), sc.guess, rotation=sc.task.rotation)
    model = pin.Model(sc.robot.model)
    model.lowerPositionLimit = np.full(model.nq, -1e3)
    model.upperPositionLimit = np.full(model.nq, 1e3)
    robot = Robot(model=model, tip=sc.robot.tip, stiffness=sc.robot.stiffness)
    wide = BracedRobot(robot, sc.braced.brace)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", BracekitWarning)  # region exits: not under test here
        return simulate(wide, sc.strategy(name), sc.task, start.q, sc.dt, sc.beta_x)


def _assert_no_recorded_jump(sc: Scenario, tr: Trajectory) -> None:
    bound = joint_step_bound(sc.robot, sc.dt)
    steps = np.abs(np.diff(tr.q, axis=0))
    assert np.all(steps <= bound)
    assert tr.summary()["max_joint_step_rad"] == pytest.approx(np.max(steps), abs=0.0)


@pytest.mark.parametrize(
    ("case", "keys", "strategy", "when"),
    [
        # a 0.25 m circle: braced minimum norm drives q5 through 0 (J1 singular), q4 and q6 jump 11.3 rad
        ("circle", {"centre": "[1.0, -0.3, -0.15]", "radius": 0.25}, "braced_min_norm", "t = 10.550 s"),
        # sticking point contact: gradient projection meets the same wrist singularity, jumps 6.3 then 75 rad
        # (from the start solve's conditioned start, σ_min/σ_max of A 0.025 rather than 0.0066: at 12.85 s)
        ("friction", {"contact": '"point_with_friction"'}, "braced_gradient_projection", "t = 12.850 s"),
    ],
)
def test_a_run_through_the_wrist_singularity_stops_and_names_the_joints_and_J1(
    tmp_path: Path, case: str, keys: dict, strategy: str, when: str
) -> None:
    sc = _scenario(tmp_path, case, **keys)
    tr = _run(sc, strategy)
    assert not tr.completed and tr.failure is not None
    assert not tr.summary()["completed"]
    assert when in tr.failure
    assert "joints 4, 6 moved" in tr.failure and "bound 0.5 rad" in tr.failure  # 2 × 5 rad/s × 0.05 s
    assert "singularity of J1" in tr.failure
    _assert_no_recorded_jump(sc, tr)


def test_a_gradient_projection_step_too_long_for_a_wall_brace_stops_and_says_to_reduce_dt(tmp_path: Path) -> None:
    # a wall (normal +x) through (0.75, 0, 0): at dt = 0.05 s the run later jumps 14.6 rad; at 0.025 s it is smooth
    sc = _scenario(tmp_path, "wall", normal="[1.0, 0.0, 0.0]", point="[0.75, 0.0, 0.0]")
    tr = _run(sc, "braced_gradient_projection")
    assert not tr.completed and tr.failure is not None
    assert "t = 13.450 s" in tr.failure and "joints 4, 6 moved" in tr.failure
    assert "no singularity between the samples" in tr.failure and "reduce dt" in tr.failure
    _assert_no_recorded_jump(sc, tr)


def test_soft_finger_runs_keep_the_contact_past_where_the_correction_used_to_stall(tmp_path: Path) -> None:
    # the anchor's allowed rotations reach ~0.9 rad by t = 1.9 s: with plain Xᵀ J_b rows the correction
    # converged linearly and stopped at a residual of 1e-12 rad after 20 iterations
    sc = _scenario(tmp_path, "soft", contact='"soft_finger"', turns=0.15)
    for name in ("braced_min_norm", "braced_gradient_projection"):
        tr = _run(sc, name)
        assert tr.completed, tr.failure
        assert tr.summary()["max_contact_violation_m"] < 1e-9
        assert tr.summary()["max_task_error_m"] < 1e-9


def test_the_contact_jacobian_is_the_derivative_of_the_contact_residual(tmp_path: Path) -> None:
    sc = _scenario(tmp_path, "soft", contact='"soft_finger"')
    q = sc.guess + 0.05
    st = sc.braced.state(sc.guess)
    anchor = (st.split.b, pin.exp3(np.array([0.7, -0.6, 0.1])) @ st.split.R_b)  # 0.9 rad from {b}
    jac = contact_jacobian(sc.braced.state(q), [anchor])
    h = 1e-6
    fd = np.column_stack(
        [
            (
                contact_residual(sc.braced.state(q + h * e), [anchor])
                - contact_residual(sc.braced.state(q - h * e), [anchor])
            )
            / (2 * h)
            for e in np.eye(q.size)
        ]
    )
    assert np.max(np.abs(jac - fd)) < 1e-8
    assert np.max(np.abs(sc.braced.split.X.T @ sc.braced.state(q).split.J_b - fd)) > 1e-2  # the plain rows are not


def test_the_correction_tolerance_is_relative_to_the_robots_reach() -> None:
    # the same chain in metres and scaled ×1000 (as if read in millimetres): both converge relative to the reach
    urdf = random_chain_urdf(8, seed=5, brace_link=4)
    up = np.array([0.0, 0.0, 1.0])
    metres = reach(Robot.from_urdf(urdf, tip="tip"))
    for scale in (1.0, 1e3):

        def scaled(m: re.Match[str], k: float = scale) -> str:
            return '<origin xyz="' + " ".join(str(float(v) * k) for v in m.group(1).split()) + '"'

        robot = Robot.from_urdf(re.sub(r'<origin xyz="([^"]+)"', scaled, urdf), tip="tip")
        q0 = np.full(8, 0.3)
        b0 = BracedRobot(robot, Brace("brace", Surface(np.zeros(3), up))).state(q0).split.b
        braced = BracedRobot(robot, Brace("brace", Surface(b0, up)))
        st = braced.state(q0)
        length = reach(robot)
        assert length == pytest.approx(scale * metres, rel=1e-12)
        out = correct(braced, q0 + 0.01 * np.arange(8), st.e, st.R_e, [(st.split.b, st.split.R_b)])
        assert np.max(np.abs(out.e - st.e)) < 1e-10 * length
        assert abs(braced.brace.surface.signed_distance(out.split.b)) < 1e-10 * length


def test_the_joint_step_bound_comes_from_the_velocity_limits_with_a_default_and_a_cap() -> None:
    sc = load_scenario("paper")
    v = sc.robot.model.velocityLimit
    assert np.allclose(joint_step_bound(sc.robot, 0.05), JOINT_STEP_SAFETY * v * 0.05)
    assert np.all(joint_step_bound(sc.robot, 10.0) == MAX_JOINT_STEP)
    model = pin.Model(sc.robot.model)
    limits = model.velocityLimit.copy()
    limits[0], limits[1] = 0.0, np.inf
    model.velocityLimit = limits
    robot = Robot(model=model, tip=sc.robot.tip, stiffness=sc.robot.stiffness)
    bound = joint_step_bound(robot, 0.05)
    assert bound[0] == bound[1] == pytest.approx(JOINT_STEP_SAFETY * DEFAULT_JOINT_SPEED * 0.05)
    assert np.allclose(bound[2:], JOINT_STEP_SAFETY * v[2:] * 0.05)


def test_a_sample_below_the_singular_ratio_stops_the_run_and_names_the_matrix(monkeypatch) -> None:
    sc = load_scenario("paper")
    start = solve_start(sc.braced, sc.task.position(0.0), sc.guess)
    c = sc.task
    assert isinstance(c, Circle)
    task = Circle(c.centre, c.radius, c.normal, c.period, c.start_direction, turns=0.01)
    tr = simulate(sc.braced, BracedMinNorm(), task, start.q, 0.1, sc.beta_x)
    assert tr.completed
    for key in ("joint_step", "sigma_ratio_J1", "sigma_ratio_A", "sigma_ratio_J", "sigma_ratio_J_braced"):
        assert tr.measures[key].shape == tr.t.shape
    assert tr.measures["joint_step"][0] == 0.0
    # a threshold above J̃'s σ_min/σ_max at the start (0.02–0.05): the run stops there, before any step
    monkeypatch.setattr(GUARDS, "PATH_SINGULAR_RATIO", 0.9)
    tr = simulate(sc.braced, BracedMinNorm(), task, start.q, 0.1, sc.beta_x)
    assert not tr.completed and tr.steps == 0 and tr.failure is not None
    assert tr.failure.startswith("start (t = 0.000 s)") and "singular on the path" in tr.failure


@pytest.mark.parametrize(
    ("position", "guess", "rotation"),
    [
        ([np.nan, 0.0, 0.0], None, None),
        ([np.inf, 0.0, 0.0], None, None),
        ([1.0, 0.0], None, None),
        (None, np.nan, None),
        (None, None, np.full((3, 3), np.nan)),
        (None, None, 2 * np.eye(3)),
    ],
)
def test_solve_start_rejects_a_non_finite_or_malformed_target_or_guess_with_input_error(
    position, guess, rotation
) -> None:
    sc = load_scenario("paper")
    target = sc.task.position(0.0) if position is None else position
    q = sc.guess.copy()
    if guess is not None:
        q[3] = guess
    with pytest.raises(InputError):
        solve_start(sc.braced, target, q, rotation=rotation)


def test_solve_start_that_fails_never_warns_that_the_start_meets_the_task(monkeypatch) -> None:
    sc = load_scenario("paper")
    monkeypatch.setattr(START, "START_MAX_NFEV", 2)  # the solve stops early: the old code warned here
    with warnings.catch_warnings():
        warnings.simplefilter("error", BracekitWarning)
        with pytest.raises(ConvergenceError, match="no start configuration"):
            solve_start(sc.braced, [3.0, 0.0, 0.0], sc.guess)
