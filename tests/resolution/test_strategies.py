"""Redundancy resolution: the task twist is realised exactly, the contact is kept, the null space descends g.

The braced strategies are also compared with the paper's formulas assembled here from Pinocchio alone
(:class:`Pieces`: H from the surface frame, S_t1 and S_t2 from the placements, J2 from the LOCAL Jacobian, g
and its central differences from those pieces), on the paper robot (n1 = 6, eq:q1 with J1⁻¹ H) and on random
chains with n1 ≠ 6 (dq1/db̃ an orthonormal basis of the contact-keeping chain-1 motions).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from bracekit import (
    Brace,
    BracedGradientProjection,
    BracedMinNorm,
    BracedRobot,
    FreeSpaceMinNorm,
    InputError,
    Robot,
    Surface,
    load_model,
    load_scenario,
)
from bracekit.errors import SingularityError
from bracekit.model.shipped import model_path
from bracekit.objective import (
    BraceAngle,
    ComplianceIndex,
    ConditionNumber,
    Objective,
    RegionBarrier,
    braced_gradient,
)
from bracekit.resolution.strategies import with_beta_x
from helpers import random_chain_urdf, random_unit

Q0 = np.array([0.0, 0.194, -2.598, 0.0, -0.737, -2.498, -1.898, 3.142, 2.106, 2.438, 0.867])
LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
WEIGHTS = (0.5, 100.0, 0.6, 0.01)  # the paper's α1…α4


@pytest.fixture(scope="module")
def paper():
    sc = load_scenario("paper")
    rng = np.random.default_rng(7)
    return sc, [Q0 + rng.normal(scale=0.15, size=11) for _ in range(4)]


def _braced_at(sc, q):
    """The scenario's brace moved so that the surface passes through b at q (the contact is closed)."""
    b = sc.braced.state(q).split.b
    brace = sc.braced.brace
    return BracedRobot(sc.robot, Brace(brace.frame, Surface(b, brace.surface.normal), region_radius=0.5))


# ------------------------------------------------------------------------- independent reference pieces
class Pieces:
    """The braced kinematics at q from Pinocchio and the paper's definitions only (no bracekit code)."""

    def __init__(self, model: pin.Model, tip: str, brace: str, q: np.ndarray) -> None:
        data = model.createData()
        pin.framesForwardKinematics(model, data, q)
        tip_id, b_id = model.getFrameId(tip), model.getFrameId(brace)
        self.b, self.e = data.oMf[b_id].translation.copy(), data.oMf[tip_id].translation.copy()
        self.R_b, R_e = data.oMf[b_id].rotation.copy(), data.oMf[tip_id].rotation.copy()
        self.J_e = pin.computeFrameJacobian(model, data, q, tip_id, LWA).copy()
        self.J_b = pin.computeFrameJacobian(model, data, q, b_id, LWA).copy()
        self.n1 = n1 = model.joints[model.frames[b_id].parentJoint].idx_v + 1
        self.J1 = self.J_b[:, :n1]
        # eq:J2: twist of e relative to {b}, at e, in {b}'s axes, from the tip's LOCAL Jacobian (e's axes)
        local = pin.computeFrameJacobian(model, data, q, tip_id, pin.ReferenceFrame.LOCAL)[:, n1:]
        rot = self.R_b.T @ R_e
        self.J2 = np.vstack([rot @ local[:3], rot @ local[3:]])

    def at_e(self, twists: np.ndarray) -> np.ndarray:
        """S_t1 applied to twists (6×m) at b: v_e = v_b + ω × (e − b), axes unchanged."""
        v, w = twists[:3], twists[3:]
        return np.vstack([v + np.cross(w.T, self.e - self.b).T, w])

    def in_world(self, twists: np.ndarray) -> np.ndarray:
        """S_t2 applied to twists (6×m) in {b}'s axes."""
        return np.vstack([self.R_b @ twists[:3], self.R_b @ twists[3:]])

    def compliance(self, K: np.ndarray, normal: np.ndarray, model: str) -> np.ndarray:
        """C_e = S_t1 C̃1 S_t1ᵀ + S_t2 C2 S_t2ᵀ (eq:Ce with the dual wrench maps) for X = [n̂; 0]."""
        n1 = self.n1
        c1 = self.J1 @ np.diag(1.0 / K[:n1]) @ self.J1.T
        x = np.r_[normal, 0.0, 0.0, 0.0][:, None]
        if model == "constrained":
            c1t = c1 - c1 @ x @ np.linalg.inv(x.T @ c1 @ x) @ x.T @ c1
        else:
            t = np.eye(6) - x @ x.T
            c1t = t @ c1 @ t
        c2 = self.J2 @ np.diag(1.0 / K[n1:]) @ self.J2.T
        s1, s2 = self.at_e(np.eye(6)), self.in_world(np.eye(6))
        return s1 @ c1t @ s1.T + s2 @ c2 @ s2.T


def h_point(frame: np.ndarray) -> np.ndarray:
    """eq:H_point from the tangent frame {t} (columns x̂_t, ŷ_t, ẑ_t): slide along x̂_t, ŷ_t; turn freely."""
    x, y, z = frame.T
    o = np.zeros(3)
    return np.column_stack([np.r_[x, o], np.r_[y, o], np.r_[o, x], np.r_[o, y], np.r_[o, z]])


class Problem:
    """A braced robot with the objective g of eq:objective and its independent evaluation."""

    def __init__(self, ref: pin.Model, braced: BracedRobot, beta: np.ndarray, model: str, centre, r_max) -> None:
        self.ref, self.braced, self.beta, self.model = ref, braced, beta / np.linalg.norm(beta), model
        self.centre, self.r_max = np.asarray(centre, dtype=float), r_max
        self.tip, self.brace = braced.robot.tip, braced.brace.frame
        self.normal = braced.brace.surface.normal
        self.K = braced.robot.stiffness
        terms = [ConditionNumber(), ComplianceIndex(beta, model), BraceAngle(), RegionBarrier(r_max, self.centre)]
        self.objective = Objective(terms, list(WEIGHTS))

    def pieces(self, q: np.ndarray) -> Pieces:
        return Pieces(self.ref, self.tip, self.brace, q)

    def g(self, q: np.ndarray) -> float:
        p = self.pieces(q)
        jjt = p.J_e @ p.J_e.T
        k = np.sqrt(np.trace(jjt) * np.trace(np.linalg.inv(jjt))) / 6.0
        ci = np.linalg.norm(self.beta @ p.compliance(self.K, self.normal, self.model))
        theta = np.arccos(np.clip(self.normal @ p.R_b[:, 2], -1.0, 1.0))
        r2 = np.sum((p.b - self.centre) ** 2)
        d = self.r_max**2 / (self.r_max**2 - r2)
        return float(np.dot(WEIGHTS, [k, ci, theta, d]))

    def dg_dq(self, q: np.ndarray, step: float = 1e-5) -> np.ndarray:
        eye = np.eye(q.size) * step
        return np.array([(self.g(q + eye[i]) - self.g(q - eye[i])) / (2.0 * step) for i in range(q.size)])


def paper_problem(sc, q: np.ndarray, model: str) -> Problem:
    braced = _braced_at(sc, q)
    frame = braced.brace.surface.frame
    centre = braced.brace.surface.point + 0.06 * frame[:, 0] - 0.03 * frame[:, 1]  # r = 0.067 m
    ref = pin.buildModelFromUrdf(str(model_path("paper-robot")))
    return Problem(ref, braced, np.r_[0.0, 0.6, 0.8, 0.0, 0.0, 0.0], model, centre, 0.15)


def chain_problem(n: int, brace_link: int, seed: int, model: str) -> tuple[Problem, np.ndarray]:
    urdf = random_chain_urdf(n, seed=seed, brace_link=brace_link)
    robot = Robot.from_urdf(urdf, tip="tip", stiffness=np.linspace(80.0, 240.0, n))
    rng = np.random.default_rng(seed)
    q = rng.uniform(-2.0, 2.0, n)
    b = BracedRobot(robot, Brace("brace", Surface(np.zeros(3), [0, 0, 1]))).state(q).split.b
    braced = BracedRobot(robot, Brace("brace", Surface(b, random_unit(rng))))
    frame = braced.brace.surface.frame
    centre = b + 0.05 * frame[:, 0] + 0.04 * frame[:, 1]
    return Problem(pin.buildModelFromXML(urdf), braced, rng.normal(size=6), model, centre, 0.5), q


# ------------------------------------------------------------------------------------------------ tests
def test_free_space_min_norm_is_the_pseudo_inverse_solution(paper) -> None:
    sc, qs = paper
    ref = pin.buildModelFromUrdf(str(model_path("paper-robot")))
    xdot = np.array([0.05, -0.02, 0.03, 0.1, 0.0, -0.1])
    for q in qs:
        j = Pieces(ref, "tool", "brace", q).J_e
        assert np.allclose(FreeSpaceMinNorm().velocity(sc.braced.state(q), xdot), np.linalg.pinv(j) @ xdot, atol=1e-12)


def test_braced_min_norm_is_the_pseudo_inverse_of_an_independent_A_on_the_paper_robot(paper) -> None:
    sc, qs = paper
    rng = np.random.default_rng(2)
    for q in qs:
        pr = paper_problem(sc, q, "constrained")
        p = pr.pieces(q)
        assert p.n1 == 6
        np.testing.assert_allclose(p.in_world(p.J2), p.J_e[:, 6:], atol=1e-12)  # premise: S_t2 J2 = J_e,2
        H = h_point(pr.braced.brace.surface.frame)
        A = np.hstack([p.at_e(H), p.in_world(p.J2)])  # eq:braced_kin
        st = pr.braced.state(q)
        np.testing.assert_allclose(st.split.A, A, atol=1e-12)
        xdot = rng.normal(scale=0.05, size=6)
        y = np.linalg.lstsq(A, xdot, rcond=None)[0]  # [ḃ; q̇2], the minimum-norm solution
        np.testing.assert_allclose(np.linalg.pinv(A) @ xdot, y, atol=1e-12)
        expected = np.r_[np.linalg.solve(p.J1, H @ y[:5]), y[5:]]  # eq:q1
        got = BracedMinNorm().velocity(st, xdot)
        np.testing.assert_allclose(got, expected, rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize(("n", "brace_link"), [(9, 5), (11, 7)])
def test_braced_min_norm_on_chains_with_n1_not_6_is_the_min_norm_contact_keeping_motion(n, brace_link) -> None:
    # with an orthonormal dq1/db̃, min ‖[b̃̇; q̇2]‖ is min ‖q̇‖ subject to J_e q̇ = ẋ and n̂ᵀ ṗ_b = 0
    pr, q = chain_problem(n, brace_link, seed=n, model="constrained")
    p = pr.pieces(q)
    assert p.n1 == brace_link != 6
    st = pr.braced.state(q)
    np.testing.assert_allclose(
        st.split.A, np.hstack([p.at_e(p.J1 @ st.split.chain1_map), p.in_world(p.J2)]), atol=1e-12
    )
    rng = np.random.default_rng(n)
    for _ in range(3):
        xdot = rng.normal(scale=0.05, size=6)
        stacked = np.vstack([p.J_e, pr.normal @ p.J_b[:3]])
        expected = np.linalg.pinv(stacked) @ np.r_[xdot, 0.0]
        np.testing.assert_allclose(BracedMinNorm().velocity(st, xdot), expected, rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("model", ["constrained", "projection"])
def test_braced_gradient_projection_equals_an_independent_assembly_on_the_paper_robot(paper, model: str) -> None:
    sc, qs = paper
    rng = np.random.default_rng(5)
    for q in qs[:2]:
        pr = paper_problem(sc, q, model)
        p = pr.pieces(q)
        H = h_point(pr.braced.brace.surface.frame)
        A = np.hstack([p.at_e(H), p.in_world(p.J2)])
        a_pinv = np.linalg.pinv(A)
        G = np.linalg.solve(p.J1, H)  # dq1/db̃ = J1⁻¹ H (eq:q1)
        dg = pr.dg_dq(q)
        grad = np.r_[G.T @ dg[:6], dg[6:]]  # eq:grad_g
        xdot = rng.normal(scale=0.05, size=6)
        alpha = -1.0
        y = a_pinv @ xdot + (np.eye(A.shape[1]) - a_pinv @ A) @ (alpha * grad)  # eq:grad_proj
        expected = np.r_[G @ y[:5], y[5:]]
        st = pr.braced.state(q, hessians=True)
        for mode in ("analytic", "finite-difference"):
            got = BracedGradientProjection(pr.objective, alpha=alpha, gradient=mode).velocity(st, xdot)
            assert np.linalg.norm(got - expected) <= 1e-6 * np.linalg.norm(expected), mode
        # the null-space term matters here: leaving it out would be caught
        assert np.linalg.norm(expected - np.r_[G @ (a_pinv @ xdot)[:5], (a_pinv @ xdot)[5:]]) > 1e-3


@pytest.mark.parametrize("model", ["constrained", "projection"])
def test_braced_gradient_projection_equals_an_independent_assembly_on_a_chain_with_n1_not_6(model: str) -> None:
    pr, q = chain_problem(9, 5, seed=21, model=model)
    p = pr.pieces(q)
    # N: orthonormal basis of the contact-keeping joint motions (n̂ᵀ J_b[:3] q̇ = 0); the result is basis-free
    N = np.linalg.svd((pr.normal @ p.J_b[:3])[None, :])[2][1:].T
    AN = p.J_e @ N
    an_pinv = np.linalg.pinv(AN)
    alpha = -0.5
    xdot = np.random.default_rng(1).normal(scale=0.05, size=6)
    grad = N.T @ pr.dg_dq(q)
    expected = N @ (an_pinv @ xdot + (np.eye(N.shape[1]) - an_pinv @ AN) @ (alpha * grad))
    st = pr.braced.state(q, hessians=True)
    for mode in ("analytic", "finite-difference"):
        got = BracedGradientProjection(pr.objective, alpha=alpha, gradient=mode).velocity(st, xdot)
        assert np.linalg.norm(got - expected) <= 1e-6 * np.linalg.norm(expected), mode
    assert np.linalg.norm(expected - N @ (an_pinv @ xdot)) > 1e-3


def test_with_beta_x_replaces_the_compliance_direction_of_the_objective_only() -> None:
    obj = load_scenario("paper").objective()
    strategy = BracedGradientProjection(obj, alpha=-2.0)
    beta = np.r_[0.0, 3.0, 4.0, 0.0, 0.0, 0.0]
    new = with_beta_x(strategy, beta)
    assert new.alpha == -2.0 and new.objective.weights == obj.weights
    for old_t, new_t in zip(obj.terms, new.objective.terms, strict=True):
        if isinstance(old_t, ComplianceIndex):
            np.testing.assert_allclose(new_t.beta_x, beta / 5.0)
            assert new_t.model == old_t.model
        else:
            assert new_t is old_t
    assert with_beta_x(BracedMinNorm(), beta) == BracedMinNorm()
    no_ci = BracedGradientProjection(Objective([ConditionNumber()], [1.0]))
    assert with_beta_x(no_ci, beta) is no_ci
    with pytest.raises(InputError):
        with_beta_x(strategy, np.zeros(6))


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
            assert abs(n_hat @ (st.split.J_b[:3] @ qdot)) < 1e-10


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


@pytest.mark.parametrize("component", range(6))
def test_a_tip_twist_too_large_to_invert_is_refused_not_overflowed(component: int) -> None:
    from bracekit.errors import InputError
    from bracekit.resolution.strategies import MAX_TIP_TWIST, tip_twist

    xdot = np.zeros(6)
    xdot[component] = 5e307  # J⁺ẋ overflows with this (found by hypothesis)
    with pytest.raises(InputError, match="at most 1e"):
        tip_twist(xdot)
    xdot[component] = -MAX_TIP_TWIST  # the bound itself is accepted
    assert np.array_equal(tip_twist(xdot), xdot)


@pytest.mark.parametrize("where", range(6))
@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf, 2e12])
def test_tip_twist_refuses_a_float_array_with_a_bad_component_anywhere(where: int, bad: float) -> None:
    """The float (6,) array of a control loop takes a quick path: NaN, ±inf or a huge value are still refused."""
    from bracekit.resolution.strategies import tip_twist

    x = np.full(6, 0.1)
    x[where] = bad
    with pytest.raises(InputError):
        tip_twist(x)
    ok = np.full(6, 0.1)
    assert tip_twist(ok) is ok  # the array itself, as as_array gives it
