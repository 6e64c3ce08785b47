"""The fused gradient-projection step (bracekit.resolution.fused) and the hot-path helpers equal their reference paths.

Reference: ``BracedGradientProjection.velocity(braced.state(q, hessians=True), ẋ)`` (and
``Objective.gradient`` / ``Objective.value``), on the paper's robot, on random chains whose brace is not
after joint 6, with every contact type, a compliant environment, a user-defined term, the joint-limit term, and at
the configurations where the reference raises or warns; the NumPy backend (the numba backend:
test_fused_numba.py). No timing is asserted.
"""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest

from bracekit import (
    Brace,
    BracedGradientProjection,
    BracedRobot,
    ComplianceIndex,
    ConditionNumber,
    InputError,
    NumericalError,
    Objective,
    RegionBarrier,
    Robot,
    Surface,
    load_model,
)
from bracekit._linalg import cross3, inverse
from bracekit.compliance.measures import theta_z
from bracekit.contact import contact_type
from bracekit.errors import BarrierError, SingularityError, UnloadedContactWarning
from bracekit.objective import BraceAngle
from bracekit.resolution.fused import GradientProjectionStep, numba_available
from helpers import random_chain_urdf

RTOL = 1e-10  # observed ≈ 1e-13 on the paper's robot


def _objective(braced: BracedRobot, model: str, beta: np.ndarray, r_max: float = 5.0) -> Objective:
    surface = braced.brace.surface
    terms = [ConditionNumber(), ComplianceIndex(beta, model), BraceAngle(), RegionBarrier(r_max, surface.point)]
    return Objective(terms, [0.5, 100.0, 0.6, 0.01])


def _outcome(fn):
    try:
        return fn()
    except Exception as exc:  # compare errors by type and message
        return (type(exc).__name__, str(exc))


def _assert_same(ref, got, rtol: float = RTOL) -> None:
    if isinstance(ref, tuple) or isinstance(got, tuple):
        assert ref == got
        return
    scale = max(float(np.max(np.abs(ref))), 1e-300)
    assert np.max(np.abs(np.asarray(got) - ref)) <= rtol * scale


@pytest.mark.parametrize("model", ["constrained", "projection"])
def test_fused_step_equals_the_reference_on_the_paper_robot(paper, model: str) -> None:
    sc, qs = paper
    braced = sc.braced
    rng = np.random.default_rng(3)
    strategy = BracedGradientProjection(_objective(braced, model, np.r_[1.0, 0, 0, 0, 0, 0]), alpha=-0.7)
    step = GradientProjectionStep(braced, strategy)
    for q in qs:
        xdot = rng.normal(scale=0.05, size=6)
        ref = strategy.velocity(braced.state(q, hessians=True), xdot)
        got = step(q, xdot)
        _assert_same(ref, got)
        st = braced.state(q, hessians=True)
        _assert_same(strategy.objective.gradient(st), step.gradient(q))
        assert step.value(q) == pytest.approx(strategy.objective.value(st), rel=1e-13)


def test_fused_step_replaces_beta_x_like_a_new_compliance_index_term(paper) -> None:
    sc, qs = paper
    braced = sc.braced
    base = BracedGradientProjection(_objective(braced, "constrained", np.r_[1.0, 0, 0, 0, 0, 0]))
    step = GradientProjectionStep(braced, base)
    beta = np.array([0.0, 2.0, 1.0, 0.0, 0.0, 0.0])  # not unit: normalised like ComplianceIndex does
    terms = [dataclasses.replace(t, beta_x=beta) if isinstance(t, ComplianceIndex) else t for t in base.objective.terms]
    ref = dataclasses.replace(base, objective=Objective(terms, base.objective.weights))
    xdot = np.array([0.01, 0.0, -0.02, 0.0, 0.01, 0.0])
    for q in qs[:4]:
        _assert_same(ref.velocity(braced.state(q, hessians=True), xdot), step(q, xdot, beta))
    with pytest.raises(InputError):
        step(qs[0], xdot, np.zeros(6))


def test_fused_step_with_a_repeated_or_changed_beta_x_gives_a_fresh_step_result(paper) -> None:
    """Reference: a new step for each β_x (the step keeps the terms of the last β_x while it stays the same)."""
    sc, qs = paper
    braced = sc.braced
    base = BracedGradientProjection(_objective(braced, "constrained", np.r_[1.0, 0, 0, 0, 0, 0]))
    step = GradientProjectionStep(braced, base)
    xdot = np.array([0.01, 0.0, -0.02, 0.0, 0.01, 0.0])
    fixed = np.array([0.0, 2.0, 1.0, 0.0, 0.0, 0.0])
    for beta in (fixed, fixed.copy(), np.array([1.0, 0.0, 1.0, 0.0, 0.0, 0.0]), fixed):
        assert np.array_equal(step(qs[0], xdot, beta), GradientProjectionStep(braced, base)(qs[0], xdot, beta))
    fixed[:] = [0.0, 0.0, 1.0, 0.0, 0.0, 0.0]  # the same array with another direction
    assert np.array_equal(step(qs[0], xdot, fixed), GradientProjectionStep(braced, base)(qs[0], xdot, fixed))
    with pytest.raises(InputError):
        step(qs[0], xdot, np.zeros(6))


@pytest.mark.parametrize("model", ["constrained", "projection"])
def test_fused_finite_difference_step_equals_the_reference_finite_differences(paper, model: str) -> None:
    sc, qs = paper
    braced = sc.braced
    strategy = BracedGradientProjection(
        _objective(braced, model, np.r_[0.0, 0.6, 0.8, 0, 0, 0]), gradient="finite-difference"
    )
    step = GradientProjectionStep(braced, strategy)
    xdot = np.array([0.0, 0.01, 0.02, 0.0, 0.0, 0.01])
    for q in qs[:3]:
        # central differences amplify rounding by 1/(2 δq) = 5e4: equal to ~1e-10, not 1e-13
        _assert_same(strategy.velocity(braced.state(q), xdot), step(q, xdot), rtol=1e-7)
        _assert_same(strategy.dg_dq(braced.state(q)), step.gradient(q), rtol=1e-7)


@pytest.mark.parametrize("contact", ["frictionless_point", "point_with_friction", "soft_finger"])
@pytest.mark.parametrize("seed", [1, 2])
def test_fused_step_equals_the_reference_on_random_chains_and_contacts(contact: str, seed: int) -> None:
    # n1 = 5 and n1 = 7: the chain-1 map is the null space of Xᵀ J1, not J1⁻¹ H
    n, brace_link = (9, 5) if seed == 1 else (11, 7)
    robot = Robot.from_urdf(random_chain_urdf(n, seed=seed, brace_link=brace_link), tip="tip", stiffness=150.0)
    rng = np.random.default_rng(seed)
    braced0 = BracedRobot(robot, Brace("brace", Surface(np.zeros(3), rng.normal(size=3)), contact_type(contact)))
    for model in ("constrained", "projection"):
        beta = rng.normal(size=6)
        strategy = BracedGradientProjection(_objective(braced0, model, beta, r_max=50.0), alpha=-0.5)
        step = GradientProjectionStep(braced0, strategy)
        for _ in range(4):
            q = rng.uniform(-2.5, 2.5, n)
            xdot = rng.normal(scale=0.1, size=6)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", UnloadedContactWarning)
                ref = _outcome(lambda q=q, x=xdot, s=strategy: s.velocity(braced0.state(q, hessians=True), x))
                got = _outcome(lambda q=q, x=xdot, f=step: f(q, x))
            _assert_same(ref, got, rtol=1e-9)


def test_fused_step_with_a_compliant_environment_and_a_user_term_uses_the_reference(paper) -> None:
    sc, qs = paper
    brace = dataclasses.replace(sc.braced.brace, environment_stiffness=2e4)
    braced = BracedRobot(sc.robot, brace)

    @dataclasses.dataclass(frozen=True)
    class Height:  # a user-defined term: height of the tip, exact gradient from J_e
        name: str = "height"

        def value(self, state) -> float:
            return float(state.e[2])

        def gradient(self, state) -> np.ndarray:
            return state.J_e[2].copy()

    objective = _objective(braced, "constrained", np.r_[1.0, 0, 0, 0, 0, 0])
    strategy = BracedGradientProjection(Objective([*objective.terms, Height()], [*objective.weights, 2.0]))
    step = GradientProjectionStep(braced, strategy)
    xdot = np.array([0.02, 0.0, 0.0, 0.0, 0.0, 0.0])
    for q in qs[:3]:
        _assert_same(strategy.velocity(braced.state(q, hessians=True), xdot), step(q, xdot))
        _assert_same(strategy.objective.gradient(braced.state(q, hessians=True)), step.gradient(q))
        assert step.value(q) == pytest.approx(strategy.objective.value(braced.state(q)), rel=1e-13)


def test_fused_step_raises_what_the_reference_raises(paper) -> None:
    sc, qs = paper
    braced = sc.braced
    # a bracing region so small that {b} is outside it: BarrierError, same message
    strategy = BracedGradientProjection(_objective(braced, "constrained", np.r_[1.0, 0, 0, 0, 0, 0], r_max=1e-3))
    step = GradientProjectionStep(braced, strategy)
    xdot = np.zeros(6)
    ref = _outcome(lambda: strategy.velocity(braced.state(qs[0], hessians=True), xdot))
    assert ref[0] == "BarrierError"
    assert _outcome(lambda: step(qs[0], xdot)) == ref
    with pytest.raises(BarrierError):
        step.gradient(qs[0])
    # J1 singular (the PUMA's wrist aligned, q5 = 0): SingularityError from the reference's own check
    q = np.zeros(braced.n)
    q[1], q[2] = 0.3, -0.4
    ok = BracedGradientProjection(_objective(braced, "constrained", np.r_[1.0, 0, 0, 0, 0, 0], r_max=50.0))
    ref = _outcome(lambda: ok.velocity(braced.state(q, hessians=True), xdot))
    assert ref[0] == "SingularityError"
    assert _outcome(lambda: GradientProjectionStep(braced, ok)(q, xdot)) == ref
    with pytest.raises(SingularityError):
        GradientProjectionStep(braced, ok)(q, xdot)
    # bad inputs
    with pytest.raises(InputError):
        step(qs[0][:-1], xdot)
    with pytest.raises(InputError):
        step(np.full(braced.n, np.nan), xdot)
    with pytest.raises(InputError):
        step(qs[0], np.zeros(3))
    with pytest.raises(InputError):
        GradientProjectionStep(braced, sc.strategy("braced_min_norm"))  # type: ignore[arg-type]


def _unloaded_braced() -> BracedRobot:
    """Chain 1 = one joint about the world z; {b} on its link moves horizontally and the surface normal
    is z, so Xᵀ C1 X = 0: the contact carries no load from chain 1."""
    joints = [
        ("0 0 0.1", "0 0 0", "0 0 1"),
        ("0.3 0 0", "0.4 0 0", "0 1 0"),
        ("0.3 0 0.1", "0 0.3 0", "1 0 0"),
        ("0.2 0.1 0", "0 0 0.5", "0 1 0"),
        ("0.2 0 0", "0.2 0 0", "0 0 1"),
        ("0.1 0 0.1", "0 0 0", "1 0 0"),
    ]
    parts = ['<robot name="unloaded">', '<link name="base"/>']
    parent = "base"
    for i, (xyz, rpy, axis) in enumerate(joints, start=1):
        parts += [
            f'<link name="l{i}"/>',
            f'<joint name="j{i}" type="revolute"><parent link="{parent}"/><child link="l{i}"/>'
            f'<origin xyz="{xyz}" rpy="{rpy}"/><axis xyz="{axis}"/>'
            '<limit lower="-3" upper="3" effort="1" velocity="1"/></joint>',
        ]
        parent = f"l{i}"
    parts += [
        '<link name="tip"/>',
        '<joint name="t" type="fixed"><parent link="l6"/><child link="tip"/><origin xyz="0.1 0 0"/></joint>',
        "</robot>",
    ]
    robot = Robot.from_urdf("\n".join(parts), tip="tip").with_point_frame("pad", "l1", (0.2, 0.0, 0.0))
    return BracedRobot(robot, Brace("pad", Surface(np.zeros(3), (0.0, 0.0, 1.0))))


def test_fused_step_warns_like_the_reference_when_the_contact_is_unloaded() -> None:
    braced = _unloaded_braced()
    assert braced.split.n1 == 1
    strategy = BracedGradientProjection(_objective(braced, "constrained", np.r_[0, 0, 1.0, 0, 0, 0], r_max=50.0))
    step = GradientProjectionStep(braced, strategy)
    q = np.array([0.3, 0.5, -0.4, 0.8, 0.2, -0.6])
    xdot = np.array([0.0, 0.0, 0.01, 0.0, 0.0, 0.0])
    with pytest.warns(UnloadedContactWarning):
        ref = strategy.velocity(braced.state(q, hessians=True), xdot)
    with pytest.warns(UnloadedContactWarning):
        got = step(q, xdot)
    _assert_same(ref, got)


@pytest.mark.parametrize("model", ["constrained", "projection"])
def test_fused_step_raises_numerical_error_like_the_reference_when_the_compliance_overflows(paper, model) -> None:
    sc, qs = paper
    robot = load_model("paper-robot")
    object.__setattr__(robot, "stiffness", np.full(robot.n, 1e-320))  # 1/K overflows (range check bypassed)
    braced = BracedRobot(robot, sc.braced.brace)
    strategy = BracedGradientProjection(_objective(braced, model, np.r_[1.0, 0, 0, 0, 0, 0], r_max=50.0))
    xdot = np.array([0.0, 0.0, 0.01, 0.0, 0.0, 0.0])
    backends = ["numpy", "numba"] if numba_available() else ["numpy"]
    with np.errstate(all="ignore"):
        ref = _outcome(lambda: strategy.velocity(braced.state(qs[0], hessians=True), xdot))
        assert ref[0] == "NumericalError"
        for backend in backends:
            step = GradientProjectionStep(braced, strategy, backend=backend)
            assert _outcome(lambda s=step: s(qs[0], xdot)) == ref
            with pytest.raises(NumericalError):
                step.value(qs[0])


def test_cross3_and_theta_z_are_bit_for_bit_numpys() -> None:
    rng = np.random.default_rng(0)
    for _ in range(500):
        a, b = rng.normal(size=3) * 10 ** rng.uniform(-8, 3), rng.normal(size=3)
        assert np.array_equal(cross3(a, b), np.cross(a, b))
        za, zb = a / np.linalg.norm(a), b / np.linalg.norm(b)
        # an independent reference: NumPy's own cross product and atan2 (theta_z must be exactly this)
        assert theta_z(za, zb) == np.arctan2(np.linalg.norm(np.cross(za, zb)), za @ zb)
        assert abs(theta_z(za, zb) - np.arccos(np.clip(za @ zb, -1.0, 1.0))) < 1e-7


def test_inverse_and_placements(paper) -> None:
    sc, qs = paper
    m = np.random.default_rng(1).normal(size=(6, 6))
    np.testing.assert_allclose(inverse(m) @ m, np.eye(6), atol=1e-12)
    assert inverse(np.zeros((3, 3))) is None
    for q in qs[:5]:  # forward kinematics alone gives state()'s placements bit for bit
        st = sc.braced.state(q)
        e, r_e, (b,), (r_b,) = sc.braced.frame_placements(q)
        for x, y in ((b, st.split.b), (e, st.e), (r_b, st.split.R_b), (r_e, st.R_e)):
            assert np.array_equal(x, y)


@pytest.mark.parametrize("gradient", ["analytic", "finite-difference"])
def test_fused_step_with_the_joint_limit_term_equals_the_reference(paper, gradient: str) -> None:
    from bracekit.objective import JointLimits

    sc, qs = paper
    braced = sc.braced
    base = _objective(braced, "constrained", np.r_[1.0, 0, 0, 0, 0, 0])
    obj = Objective([*base.terms, JointLimits(sc.robot.lower, sc.robot.upper)], [*base.weights, 3.0])
    strategy = BracedGradientProjection(obj, alpha=-0.7, gradient=gradient)
    step = GradientProjectionStep(braced, strategy)
    rng = np.random.default_rng(8)
    rtol = RTOL if gradient == "analytic" else 1e-7
    for q in qs[:6]:
        xdot = rng.normal(scale=0.05, size=6)
        st = braced.state(q, hessians=True)
        _assert_same(strategy.velocity(st, xdot), step(q, xdot), rtol=rtol)
        _assert_same(strategy.dg_dq(st), step.gradient(q), rtol=rtol)
        assert step.value(q) == pytest.approx(obj.value(st), rel=1e-13)
