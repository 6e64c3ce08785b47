"""Tests of bracekit.objective: each term's analytic gradient, the weighted objective and ∇g (eq:grad_g).

Two finite-difference references: bracekit's own `finite_difference_gradient` (the paper's δq = 1e-5) over
the term values, and an independent central-difference loop over values computed here from a separate
Pinocchio model (k from eigenvalues of JJᵀ, C_i from the KKT / spring / printed-projection compliances,
θ_z from arccos, d from the barrier formula). The analytic gradients must match both to 1e-6 relative.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from bracekit.contact import Brace, Surface
from bracekit.errors import BarrierError, InputError, UnloadedContactWarning
from bracekit.kinematics import BracedRobot
from bracekit.model.robot import Robot
from bracekit.model.shipped import load_model, model_path
from bracekit.objective import (
    BraceAngle,
    ComplianceIndex,
    ConditionNumber,
    Objective,
    RegionBarrier,
    TermContext,
    braced_gradient,
    finite_difference_gradient,
)
from bracekit.validate.statics import lagrange_compliance
from helpers import pin_frame_jacobian, pin_frame_placement, random_chain_urdf, random_unit

SETTINGS = settings(max_examples=15, deadline=None)
PAPER_URDF = model_path("paper-robot")
WRIST_DOWN_Q = np.array([0.0, 0.1924, -2.594, 0.0, -0.74, -3.1416, 0.2, -3.0734, 1.9224, 0.2834, 0.3])
RTOL = 1e-6

CHAINS = st.tuples(st.integers(7, 10), st.integers(0, 10_000)).flatmap(
    lambda t: st.tuples(st.just(t[0]), st.just(t[1]), st.integers(2, t[0] - 1))
)


class Setup:
    """A braced robot, its surface, a β_x, a region, and an independent Pinocchio model with references."""

    def __init__(self, urdf: str | None, seed: int, env: float | None = None, normal: np.ndarray | None = None):
        rng = np.random.default_rng(seed)
        if urdf is None:
            self.ref, self.tip = pin.buildModelFromUrdf(str(PAPER_URDF)), "tool"
            stiffness = rng.uniform(120.0, 220.0, 11)
            robot = load_model("paper-robot", stiffness=stiffness)
        else:
            self.ref, self.tip = pin.buildModelFromXML(urdf), "tip"
            stiffness = rng.uniform(50.0, 500.0, self.ref.nv)
            robot = Robot.from_urdf(urdf, tip="tip", stiffness=stiffness)
        self.K = stiffness
        self.normal = random_unit(rng) if normal is None else normal
        self.centre = rng.normal(scale=0.1, size=3)
        self.env = env
        surface = Surface(self.centre, self.normal)
        self.braced = BracedRobot(robot, Brace("brace", surface, environment_stiffness=env))
        self.n1 = self.braced.split.n1
        self.beta = random_unit(rng, 6)
        self.r_max = 0.0  # set per configuration by with_region

    def region(self, q: np.ndarray, margin: float = 0.3) -> RegionBarrier:
        """A region around the surface point that contains b(q) with some margin."""
        r = np.linalg.norm(pin_frame_placement(self.ref, "brace", q).translation - self.centre)
        self.r_max = r + margin
        return RegionBarrier(self.r_max, self.centre)

    # --- independent values from the reference Pinocchio model ------------------------------------
    def k(self, q: np.ndarray) -> float:
        # tr(JJᵀ) = ‖J‖_F²; with Jᵀ = QR, (JJᵀ)⁻¹ = R⁻¹R⁻ᵀ, so tr((JJᵀ)⁻¹) = ‖R⁻¹‖_F² (no squaring of cond J)
        J = pin_frame_jacobian(self.ref, self.tip, q)
        r = np.linalg.qr(J.T, mode="r")
        return math.sqrt(np.sum(J * J) * np.sum(np.linalg.inv(r) ** 2)) / 6.0

    def compliance(self, q: np.ndarray, model: str) -> np.ndarray:
        J, Jb = pin_frame_jacobian(self.ref, self.tip, q), pin_frame_jacobian(self.ref, "brace", q)
        a = Jb[:3].T @ self.normal
        if model == "constrained" and self.env is None:
            return lagrange_compliance(J, self.K, a)
        if model == "constrained":  # joint springs plus a contact spring k_env along n̂
            return J @ np.linalg.solve(np.diag(self.K) + self.env * np.outer(a, a), J.T)
        # the paper's projection model, eq:C1wave_detail and eq:Ce with the dual maps
        n1 = self.n1
        P = np.zeros((6, 6))
        P[:3, :3] = np.outer(self.normal, self.normal)
        T = np.eye(6) - P
        j1 = Jb[:, :n1]
        c1t = T @ (j1 / self.K[:n1]) @ j1.T @ T
        d = (
            pin_frame_placement(self.ref, "brace", q).translation
            - pin_frame_placement(self.ref, self.tip, q).translation
        )
        S1 = np.eye(6)
        S1[:3, 3:] = [[0.0, -d[2], d[1]], [d[2], 0.0, -d[0]], [-d[1], d[0], 0.0]]
        je2 = J[:, n1:]
        return S1 @ c1t @ S1.T + (je2 / self.K[n1:]) @ je2.T

    def ci(self, q: np.ndarray, model: str) -> float:
        return float(np.linalg.norm(self.beta @ self.compliance(q, model)))

    def theta(self, q: np.ndarray) -> float:
        z_b = pin_frame_placement(self.ref, "brace", q).rotation[:, 2]
        return math.acos(float(np.clip(self.normal @ z_b, -1.0, 1.0)))

    def d(self, q: np.ndarray) -> float:
        r = np.linalg.norm(pin_frame_placement(self.ref, "brace", q).translation - self.centre)
        return self.r_max**2 / (self.r_max**2 - r**2)


def central_differences(fn: Callable[[np.ndarray], float], q: np.ndarray, h: float = 2e-5) -> np.ndarray:
    """Our own central-difference loop (independent of bracekit's finite_difference_gradient).

    Richardson-extrapolated (steps h and h/2), so the truncation error is O(h⁴) and h can stay large
    enough that round-off in the reference values (eigvalsh, KKT solves) does not matter.
    """

    def central(step: float) -> np.ndarray:
        out = np.empty(q.size)
        for i in range(q.size):
            dq = np.zeros(q.size)
            dq[i] = step
            out[i] = (fn(q + dq) - fn(q - dq)) / (2.0 * step)
        return out

    return (4.0 * central(h / 2) - central(h)) / 3.0


def assert_gradient_close(analytic: np.ndarray, reference: np.ndarray, rtol: float = RTOL) -> None:
    err = np.linalg.norm(analytic - reference)
    assert err <= rtol * np.linalg.norm(reference) + 1e-12, (err, np.linalg.norm(reference), analytic, reference)


def check_terms(s: Setup, q: np.ndarray) -> None:
    """Every term: analytic gradient vs bracekit's FD and vs our FD of independent values."""
    state = s.braced.state(q, hessians=True)
    region = s.region(q)
    cases: list[tuple[object, Callable[[np.ndarray], float]]] = [
        (ConditionNumber(), s.k),
        (ComplianceIndex(s.beta, "constrained"), lambda x: s.ci(x, "constrained")),
        (BraceAngle(), s.theta),
        (region, s.d),
    ]
    if s.env is None:
        cases.append((ComplianceIndex(s.beta, "projection"), lambda x: s.ci(x, "projection")))
    for term, ref_value in cases:
        analytic = term.gradient(state)  # type: ignore[attr-defined]
        assert term.value(state) == pytest.approx(ref_value(q), rel=1e-9)  # type: ignore[attr-defined]
        fd_bracekit = finite_difference_gradient(s.braced, term.value, q)  # type: ignore[attr-defined]
        fd_ours = central_differences(ref_value, q)
        assert_gradient_close(analytic, fd_ours)
        assert_gradient_close(analytic, fd_bracekit)
        assert np.linalg.norm(analytic) > 0.0


# ---------------------------------------------------------------------------------------------- gradients
def paper_configurations(count: int, seed: int) -> list[np.ndarray]:
    ref = pin.buildModelFromUrdf(str(PAPER_URDF))
    rng = np.random.default_rng(seed)
    out: list[np.ndarray] = []
    while len(out) < count:
        q = rng.uniform(ref.lowerPositionLimit, ref.upperPositionLimit)
        J1 = pin_frame_jacobian(ref, "brace", q)[:, :6]
        if np.linalg.cond(pin_frame_jacobian(ref, "tool", q)) < 100 and np.linalg.cond(J1) < 1e3:
            out.append(q)
    return out


@pytest.mark.parametrize("env", [None, 2e4], ids=["rigid", "k_env"])
def test_term_gradients_match_finite_differences_on_the_paper_robot(env: float | None) -> None:
    s = Setup(None, seed=1, env=env)
    with warnings.catch_warnings():
        warnings.simplefilter("error", UnloadedContactWarning)
        for q in [WRIST_DOWN_Q, *paper_configurations(3, seed=2)]:
            check_terms(s, q)


@SETTINGS
@given(chain=CHAINS, qseed=st.integers(0, 2**31), elastic=st.booleans())
def test_term_gradients_match_finite_differences_on_random_chains(
    chain: tuple[int, int, int], qseed: int, elastic: bool
) -> None:
    n, seed, link = chain
    s = Setup(random_chain_urdf(n, seed=seed, brace_link=link), seed=seed, env=5e3 if elastic else None)
    q = np.random.default_rng(qseed).uniform(-3.0, 3.0, n)
    with warnings.catch_warnings():
        warnings.simplefilter("error", UnloadedContactWarning)
        check_terms(s, q)


@pytest.mark.parametrize("model", ["constrained", "projection"])
def test_weighted_objective_gradient_matches_finite_differences(model: str) -> None:
    s = Setup(None, seed=4)
    weights = [0.5, 100.0, 0.6, 0.01]  # the paper's α1..α4
    for q in paper_configurations(2, seed=5):
        region = s.region(q)
        g = Objective([ConditionNumber(), ComplianceIndex(s.beta, model), BraceAngle(), region], weights)  # type: ignore[arg-type]
        state = s.braced.state(q, hessians=True)

        def ref_g(x: np.ndarray) -> float:
            return weights[0] * s.k(x) + weights[1] * s.ci(x, model) + weights[2] * s.theta(x) + weights[3] * s.d(x)

        assert g.value(state) == pytest.approx(ref_g(q), rel=1e-9)
        assert g.values(state)["Ci"] == pytest.approx(s.ci(q, model), rel=1e-9)
        assert g.names == ("k", "Ci", "theta_z", "d")
        analytic = g.gradient(state)
        assert_gradient_close(analytic, central_differences(ref_g, q))
        assert_gradient_close(analytic, finite_difference_gradient(s.braced, g.value, q))


def test_zero_weight_terms_are_skipped_even_when_they_could_not_be_evaluated() -> None:
    s = Setup(None, seed=6)
    q = WRIST_DOWN_Q
    outside = RegionBarrier(1e-3, s.centre + 10.0)  # b is far outside this region
    g = Objective([BraceAngle(), outside], [1.0, 0.0])
    state = s.braced.state(q, hessians=True)
    assert g.value(state) == pytest.approx(s.theta(q), rel=1e-12)
    assert_gradient_close(g.gradient(state), central_differences(s.theta, q))


# ---------------------------------------------------------------------------------------------- ∇g
def hand_H(normal: np.ndarray, frame: np.ndarray) -> np.ndarray:
    x, y, z = frame.T
    o = np.zeros(3)
    assert np.allclose(z, normal)
    return np.column_stack([np.r_[x, o], np.r_[y, o], np.r_[o, x], np.r_[o, y], np.r_[o, z]])  # eq:H_point


def test_braced_gradient_is_the_chain_rule_through_J1_inverse_H_for_n1_6() -> None:
    s = Setup(None, seed=7, normal=np.array([0.0, 0.0, 1.0]))
    rng = np.random.default_rng(8)
    for q in paper_configurations(3, seed=9):
        state = s.braced.state(q, hessians=True)
        region = s.region(q)
        g = Objective([ConditionNumber(), ComplianceIndex(s.beta), BraceAngle(), region], [0.5, 100.0, 0.6, 0.01])
        dg = g.gradient(state)
        J1 = pin_frame_jacobian(s.ref, "brace", q)[:, :6]
        G1 = np.linalg.solve(J1, hand_H(s.normal, s.braced.brace.surface.frame))  # J1⁻¹ H, computed here
        expected = np.concatenate([G1.T @ dg[:6], dg[6:]])
        grad = braced_gradient(state, dg)
        assert grad.shape == (5 + 5,)
        np.testing.assert_allclose(grad, expected, rtol=1e-9, atol=1e-12 * np.linalg.norm(expected))
        # directional derivative of g along a braced motion [ḃ; q̇2] equals ∇gᵀ [ḃ; q̇2]
        bdot, q2dot = rng.normal(size=5), rng.normal(size=5)
        qdot = np.concatenate([G1 @ bdot, q2dot])
        h = 1e-6
        slope = (g.value(s.braced.state(q + h * qdot)) - g.value(s.braced.state(q - h * qdot))) / (2 * h)
        assert grad @ np.concatenate([bdot, q2dot]) == pytest.approx(slope, rel=1e-6, abs=1e-9)


@pytest.mark.parametrize("link", [4, 7])
def test_braced_gradient_gives_the_slope_of_g_along_braced_motion_for_n1_not_6(link: int) -> None:
    s = Setup(random_chain_urdf(9, seed=70 + link, brace_link=link), seed=70 + link)
    q = np.random.default_rng(link).uniform(-2.5, 2.5, 9)
    state = s.braced.state(q, hessians=True)
    term = ComplianceIndex(s.beta)
    grad = braced_gradient(state, term.gradient(state))
    G = state.split.chain1_map
    assert grad.shape == (G.shape[1] + 9 - link,)
    rng = np.random.default_rng(1)
    for _ in range(3):
        c, q2dot = rng.normal(size=G.shape[1]), rng.normal(size=9 - link)
        qdot = np.concatenate([G @ c, q2dot])
        slope = (s.ci(q + 1e-6 * qdot, "constrained") - s.ci(q - 1e-6 * qdot, "constrained")) / 2e-6
        assert grad @ np.concatenate([c, q2dot]) == pytest.approx(slope, rel=1e-6, abs=1e-12)


# ---------------------------------------------------------------------------------------------- errors
@pytest.mark.parametrize(
    "term",
    [ConditionNumber(), ComplianceIndex(np.r_[1.0, 0, 0, 0, 0, 0]), ComplianceIndex(np.ones(6), "projection")],
    ids=["k", "Ci-constrained", "Ci-projection"],
)
def test_analytic_gradient_without_hessians_is_an_input_error(term: object) -> None:
    s = Setup(None, seed=10)
    state = s.braced.state(WRIST_DOWN_Q)  # hessians=False
    with pytest.raises(InputError, match="hessians=True"):
        term.gradient(state)  # type: ignore[attr-defined]
    with pytest.raises(InputError, match="hessians=True"):
        Objective([term], [1.0]).gradient(state)  # type: ignore[list-item]


def test_region_barrier_raises_barrier_error_outside_the_region() -> None:
    s = Setup(None, seed=11)
    state = s.braced.state(WRIST_DOWN_Q, hessians=True)
    r = np.linalg.norm(state.split.b - s.centre)
    for r_max in (0.5 * r, r):
        term = RegionBarrier(r_max, s.centre)
        with pytest.raises(BarrierError):
            term.value(state)
        with pytest.raises(BarrierError):
            term.gradient(state)
    assert RegionBarrier(2 * r, s.centre).radius(state) == pytest.approx(r, rel=1e-12)


@pytest.mark.parametrize("r_max", [0.0, -1.0, np.nan])
def test_region_barrier_needs_a_positive_radius(r_max: float) -> None:
    with pytest.raises(InputError):
        RegionBarrier(r_max, np.zeros(3))


def test_objective_rejects_mismatched_or_negative_weights() -> None:
    with pytest.raises(InputError):
        Objective([ConditionNumber(), BraceAngle()], [1.0])
    with pytest.raises(InputError, match="theta_z"):
        Objective([ConditionNumber(), BraceAngle()], [1.0, -0.1])
    with pytest.raises(InputError):
        Objective([ConditionNumber()], [np.nan])


def test_compliance_index_term_rejects_an_unknown_model() -> None:
    with pytest.raises(InputError):
        ComplianceIndex(np.ones(6), "exact")  # type: ignore[arg-type]


@pytest.mark.parametrize("beta", [np.zeros(6), np.r_[1.0, 0.0, 0.0]], ids=["zero", "three-components"])
def test_compliance_index_term_rejects_a_bad_beta_x_with_an_input_error(beta: np.ndarray) -> None:
    # errors.py: every error a user can cause derives from InputError (compliance_index() does this)
    with pytest.raises(InputError):
        ComplianceIndex(beta)


# ---------------------------------------------------------------------------------------------- bad input
@pytest.mark.parametrize(
    ("terms", "weights"),
    [
        (None, None),
        ("k", [1.0]),
        ([ConditionNumber()], "1"),
        ([ConditionNumber()], [1.0, 2.0]),
        ([ConditionNumber()], [np.nan]),
        ([ConditionNumber()], [-1.0]),
        ([ConditionNumber()], [True]),
        (["k"], [1.0]),
    ],
)
def test_objective_refuses_bad_terms_and_weights_with_input_errors(terms: object, weights: object) -> None:
    with pytest.raises(InputError) as info:
        Objective(terms, weights)  # type: ignore[arg-type]
    assert "\n" not in str(info.value)


def test_term_constructors_refuse_bad_values_with_input_errors() -> None:
    for make in (
        lambda: ComplianceIndex("x"),
        lambda: ComplianceIndex([[1, 0], [0]]),
        lambda: ComplianceIndex(np.zeros(6)),
        lambda: ComplianceIndex([0, 0, 1, 0, 0, 0], model=None),
        lambda: RegionBarrier("0.1", np.zeros(3)),
        lambda: RegionBarrier(0.1, [0.0, "a", 0.0]),
        lambda: RegionBarrier(0.1, [0.0, 0.0]),
        lambda: BraceAngle(name=3),
        lambda: ConditionNumber(name=""),
    ):
        with pytest.raises(InputError) as info:
            make()
        assert "\n" not in str(info.value)


def test_an_objective_needs_a_braced_state() -> None:
    objective = Objective([ConditionNumber()], [1.0])
    for fn in (objective.value, objective.values, objective.gradient):
        with pytest.raises(InputError, match="BracedState"):
            fn("state")  # type: ignore[arg-type]


def test_brace_angle_needs_a_brace_with_a_pad_axis() -> None:
    robot = Robot.from_urdf(random_chain_urdf(7, seed=4), tip="tip").with_point_frame("pad", "l4", (0.0, 0.0, 0.05))
    braced = BracedRobot(robot, Brace("pad", Surface((0.0, 0.0, 0.0), (0.0, 0.0, 1.0)), pad_axis=False))
    state = braced.state(np.full(7, 0.2))
    term = BraceAngle()
    for call in (
        lambda: term.value(state),
        lambda: term.gradient(state),
        lambda: term.numba_params(braced, 1.0),
        lambda: BraceAngle.from_scenario(TermContext(braced, np.eye(6)[0], "constrained")),
    ):
        with pytest.raises(InputError, match="pad axis"):
            call()
