"""Redundancy resolution: the task twist is realised exactly, the contact is kept, the null space descends g."""

from __future__ import annotations

import numpy as np
import pytest

from bracekit import (
    Brace,
    BracedGradientProjection,
    BracedMinNorm,
    BracedRobot,
    FreeSpaceMinNorm,
    InputError,
    SingularityError,
    Surface,
    load_model,
    load_scenario,
)
from bracekit.objective import braced_gradient

Q0 = np.array([0.0, 0.194, -2.598, 0.0, -0.737, -2.498, -1.898, 3.142, 2.106, 2.438, 0.867])


@pytest.fixture(scope="module")
def paper():
    sc = load_scenario("paper")
    rng = np.random.default_rng(7)
    return sc, [Q0 + rng.normal(scale=0.15, size=11) for _ in range(4)]


def _braced_at(sc, q):
    """The scenario's brace moved so that the surface passes through b at q (the contact is closed)."""
    b = sc.braced.state(q).b
    brace = sc.braced.brace
    return BracedRobot(sc.robot, Brace(brace.frame, Surface(b, brace.surface.normal), region_radius=0.5))


def test_free_space_min_norm_is_the_pseudo_inverse_solution(paper) -> None:
    sc, qs = paper
    xdot = np.array([0.05, -0.02, 0.03, 0.1, 0.0, -0.1])
    for q in qs:
        st = sc.braced.state(q)
        assert np.allclose(FreeSpaceMinNorm().velocity(st, xdot), np.linalg.pinv(st.J_e) @ xdot, atol=1e-12)


def test_braced_strategies_realise_the_commanded_tip_twist_and_keep_the_contact(paper) -> None:
    sc, qs = paper
    rng = np.random.default_rng(1)
    for q in qs:
        braced = _braced_at(sc, q)
        obj = load_scenario("paper").objective()
        strategies = [
            BracedMinNorm(),
            BracedGradientProjection(obj),
            BracedGradientProjection(obj, gradient="finite-difference"),
        ]
        st = braced.state(q, hessians=True)
        n_hat = braced.brace.surface.normal
        for strategy in strategies:
            xdot = rng.normal(size=6) * 0.05
            qdot = strategy.velocity(st, xdot)
            # independent check with Pinocchio's full Jacobian: J_e q̇ = ẋ
            assert np.allclose(st.J_e @ qdot, xdot, atol=1e-10), strategy.name
            # normal velocity of the bracing point is zero
            assert abs(n_hat @ (st.J_b[:3] @ qdot)) < 1e-10


def test_null_space_term_never_changes_the_tip_twist(paper) -> None:
    sc, qs = paper
    obj = sc.objective()
    for q in qs:
        st = _braced_at(sc, q).state(q, hessians=True)
        xdot = np.array([0.01, 0.02, -0.03, 0.0, 0.05, 0.0])
        with_null = BracedGradientProjection(obj, alpha=-5.0).velocity(st, xdot)
        without = BracedMinNorm().velocity(st, xdot)
        assert np.linalg.norm(with_null - without) > 1e-6  # the null-space term does something
        assert np.allclose(st.J_e @ with_null, st.J_e @ without, atol=1e-10)


def test_gradient_projection_with_zero_task_twist_descends_the_objective(paper) -> None:
    sc, qs = paper
    obj = sc.objective()
    for q in qs:
        braced = _braced_at(sc, q)
        st = braced.state(q, hessians=True)
        qdot = BracedGradientProjection(obj).velocity(st, np.zeros(6))
        g0 = obj.value(st)
        g1 = obj.value(braced.state(q + 1e-4 * qdot))
        assert g1 < g0


def test_analytic_and_finite_difference_gradient_projection_agree(paper) -> None:
    sc, qs = paper
    obj = sc.objective()
    for q in qs:
        st = _braced_at(sc, q).state(q, hessians=True)
        a = BracedGradientProjection(obj).dg_dq(st)
        f = BracedGradientProjection(obj, gradient="finite-difference").dg_dq(st)
        assert np.linalg.norm(a - f) <= 1e-6 * np.linalg.norm(f)
        ga, gf = braced_gradient(st, a), braced_gradient(st, f)
        assert np.linalg.norm(ga - gf) <= 1e-6 * np.linalg.norm(gf)


def test_gradient_projection_rejects_a_non_negative_gain_and_unknown_gradient_mode() -> None:
    obj = load_scenario("paper").objective()
    with pytest.raises(InputError):
        BracedGradientProjection(obj, alpha=0.5)
    with pytest.raises(InputError):
        BracedGradientProjection(obj, gradient="symbolic")  # type: ignore[arg-type]


def test_a_singular_jacobian_is_reported_not_inverted() -> None:
    robot = load_model("puma560")
    braced = BracedRobot(
        robot.with_point_frame("pad", "link3", [0.0, 0.0, 0.0]), Brace("pad", Surface([0, 0, 0], [0, 0, 1]))
    )
    q_singular = np.zeros(6)  # qz: the PUMA's wrist is singular (q5 = 0)
    st = braced.state(q_singular)
    with pytest.raises(SingularityError):
        FreeSpaceMinNorm().velocity(st, np.ones(6))
