"""Strategies in a task space: the reference formulas (S J)⁺ S ẋ and (S A)⁺ S ẋ + (I − (S A)⁺ S A) α∇g.

The reference here is built from NumPy's pinv with a perpendicular basis of the tool axis rotated
arbitrarily in its plane (the result must not depend on the basis), and from the state's J_e and A.
"""

from __future__ import annotations

import numpy as np
import pytest

from bracekit import (
    Brace,
    BracedGradientProjection,
    BracedMinNorm,
    BracedRobot,
    ComplianceIndex,
    ConditionNumber,
    FreeSpaceMinNorm,
    InputError,
    Objective,
    Robot,
    Surface,
    TaskSpace,
)
from bracekit.contact import contact_type
from bracekit.objective import braced_gradient
from bracekit.resolution.fused import GradientProjectionStep, numba_available
from helpers import pin_frame_placement, random_chain_urdf

Q0 = np.array([0.4, -0.7, 0.9, 1.1, -0.5, 0.8, 0.3])


@pytest.fixture(scope="module")
def braced() -> BracedRobot:
    robot = Robot.from_urdf(random_chain_urdf(7, seed=4, brace_link=3), tip="tip")
    b = pin_frame_placement(robot.model, "brace", Q0).translation
    surface = Surface(b, [0.2, -0.1, 1.0])
    return BracedRobot(robot, Brace(frame="brace", surface=surface, contact=contact_type("frictionless_point")))


def _selection(kind: str, rotation: np.ndarray, axis: np.ndarray, turn: float) -> np.ndarray:
    """S with the perpendicular basis of the world axis rotated by `turn` rad in its plane."""
    if kind == "position":
        return np.eye(6)[:3]
    a = rotation @ axis / np.linalg.norm(axis)
    _, _, vt = np.linalg.svd(a[None, :])
    u1, u2 = vt[1], vt[2]
    s = np.zeros((5, 6))
    s[:3, :3] = np.eye(3)
    s[3] = np.r_[0, 0, 0, np.cos(turn) * u1 + np.sin(turn) * u2]
    s[4] = np.r_[0, 0, 0, -np.sin(turn) * u1 + np.cos(turn) * u2]
    return s


@pytest.mark.parametrize(("kind", "axis"), [("position", None), ("position+axis", [0.3, -1.0, 0.5])])
def test_strategies_resolve_the_selected_rows_whatever_the_perpendicular_basis(braced, kind, axis) -> None:
    space = TaskSpace(kind, axis)  # type: ignore[arg-type]
    beta = np.array([0.0, 0.0, 1.0, 0.0, 0.0, 0.0])
    objective = Objective([ConditionNumber(), ComplianceIndex(beta, "constrained")], [0.5, 100.0])
    rng = np.random.default_rng(2)
    for turn in (0.0, 0.7, 2.9):
        q = Q0 + rng.uniform(-0.2, 0.2, 7)
        xdot = rng.normal(size=6)
        st = braced.state(q, hessians=True)
        s = _selection(kind, st.R_e, np.asarray(axis if axis is not None else [0, 0, 1.0]), turn)
        free = np.linalg.pinv(s @ st.J_e) @ (s @ xdot)
        assert np.allclose(FreeSpaceMinNorm(space=space).velocity(st, xdot), free, atol=1e-12)
        sa = s @ st.split.A
        sa_pinv = np.linalg.pinv(sa)
        l_ = st.split.chain1_map.shape[1]

        def joint(y: np.ndarray, st=st, l_=l_) -> np.ndarray:
            return np.r_[st.split.chain1_map @ y[:l_], y[l_:]]

        assert np.allclose(BracedMinNorm(space=space).velocity(st, xdot), joint(sa_pinv @ (s @ xdot)), atol=1e-12)
        grad = braced_gradient(st, objective.gradient(st))
        y = sa_pinv @ (s @ xdot) - (grad - sa_pinv @ sa @ grad)
        gp = BracedGradientProjection(objective, space=space)
        assert np.allclose(gp.velocity(st, xdot), joint(y), atol=1e-10)


def test_a_strategy_space_must_be_a_task_space() -> None:
    with pytest.raises(InputError, match="TaskSpace"):
        BracedGradientProjection(Objective([ConditionNumber()], [1.0]), space="position")  # type: ignore[arg-type]


@pytest.mark.skipif(not numba_available(), reason="numba is not installed")
def test_the_numba_kernel_runs_the_pose_only_and_the_numpy_code_the_other_spaces() -> None:
    from bracekit import load_scenario

    sc = load_scenario("paper")  # n1 = 6: the kernel applies to the pose
    objective = sc.objective()
    for kind, kernel in (("pose", True), ("position", False), ("position+axis", False)):
        strategy = BracedGradientProjection(objective, space=TaskSpace(kind))  # type: ignore[arg-type]
        step = GradientProjectionStep(sc.braced, strategy, backend="numba")
        assert step.uses_kernel is kernel
        q = sc.guess
        ref = strategy.velocity(sc.braced.state(q, hessians=True), np.r_[0.01, 0.0, -0.02, 0.0, 0.05, 0.0])
        got = step(q, np.r_[0.01, 0.0, -0.02, 0.0, 0.05, 0.0])
        assert np.allclose(got, ref, rtol=1e-9, atol=1e-12 * np.max(np.abs(ref)))
