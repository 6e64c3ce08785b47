"""Tests of redundancy resolution with several braces (the strategies over the braced motions N, the objective).

References: the constraint G = [X_iᵀ J_b_i] and J_e from Pinocchio models built independently from the same URDF
text, and the KKT system of the equality-constrained least-squares problem each strategy solves: braced minimum
norm is min ‖q̇‖² s.t. G q̇ = 0, S J_e q̇ = S ẋ; gradient projection is min ‖q̇ − α ∂g/∂q‖² under the same
constraints. ∂g/∂q is checked against central differences of C_i computed from the bordered Lagrange system.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from bracekit.compliance.measures import region_barrier
from bracekit.contact import Brace, Surface
from bracekit.errors import SingularityError
from bracekit.kinematics import BracedRobot
from bracekit.model.robot import Robot
from bracekit.model.shipped import load_model
from bracekit.objective import BraceAngle, JointLimitBarrier, Objective, RegionBarrier
from bracekit.objective.compliance_index import ComplianceIndex
from bracekit.resolution import BracedGradientProjection, BracedMinNorm, TaskSpace
from helpers import pin_frame_jacobian, pin_frame_placement, random_chain_urdf, random_unit

PAPER_Q = np.array([0.0, 0.194, -2.598, 0.0, -0.737, -2.498, -1.898, 3.142, 2.106, 2.438, 0.867])


def braces_through(model: pin.Model, q: np.ndarray, frames: list[str], contacts: list[str], rng) -> list[Brace]:
    """Braces on `frames`, each on a plane of random normal through the frame's position at q (region 0.2 m)."""
    out = []
    for frame, contact in zip(frames, contacts, strict=True):
        b = pin_frame_placement(model, frame, q).translation
        centre = b + rng.uniform(-0.03, 0.03, 3)
        normal = random_unit(rng)
        centre -= normal * (normal @ (centre - b))  # the plane passes through b
        out.append(Brace(frame, Surface(centre, normal), contact=contact, region_radius=0.2, pad_axis=False))
    return out


def paper_case(rng, contacts: tuple[str, str] = ("point_with_friction", "frictionless_point")):
    """The paper robot braced at its pad `brace` and at a point of the HEBI link `link9`, planes through both."""
    robot = load_model("paper-robot").with_point_frames([("pad", "link9", (0.02, 0.0, 0.03), None)])
    model = robot.model  # the reference G and J_e below use their own Data (helpers.pin_frame_jacobian)
    q = PAPER_Q + rng.uniform(-0.2, 0.2, PAPER_Q.size)
    braces = braces_through(model, q, ["brace", "pad"], list(contacts), rng)
    return BracedRobot(robot, braces), model, q


def chain_case(rng, n: int = 10) -> tuple[BracedRobot, pin.Model, np.ndarray]:
    text = random_chain_urdf(n, seed=int(rng.integers(1000)), brace_link=3)
    robot = Robot.from_urdf(text, tip="tip").with_point_frames([("pad", "l6", (0.03, -0.02, 0.05), None)])
    robot = robot.with_stiffness(rng.uniform(50.0, 500.0, n))
    model = robot.model
    q = rng.uniform(-2.5, 2.5, n)
    braces = braces_through(model, q, ["brace", "pad"], ["point_with_friction", "frictionless_point"], rng)
    return BracedRobot(robot, braces), model, q


def reference(braced: BracedRobot, model: pin.Model, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(G, J_e) from Pinocchio's own frame Jacobians (helpers.pin_frame_jacobian, a fresh Data)."""
    g = np.vstack([b.X().T @ pin_frame_jacobian(model, b.frame, q) for b in braced.braces])
    return g, pin_frame_jacobian(model, braced.robot.tip, q)


def kkt_rates(g: np.ndarray, sj: np.ndarray, sx: np.ndarray, v: np.ndarray) -> np.ndarray:
    """argmin ‖q̇ − v‖² s.t. G q̇ = 0, S J_e q̇ = S ẋ, from the bordered KKT system."""
    a = np.vstack([g, sj])
    rhs = np.concatenate([np.zeros(g.shape[0]), sx])
    m = a.shape[0]
    kkt = np.block([[np.eye(a.shape[1]), a.T], [a, np.zeros((m, m))]])
    return np.linalg.solve(kkt, np.concatenate([v, rhs]))[: a.shape[1]]


def selection(space: TaskSpace, rotation: np.ndarray) -> np.ndarray:
    return np.eye(6) if space.is_pose else space.selection(rotation)


@pytest.mark.parametrize("case", [paper_case, chain_case])
@pytest.mark.parametrize("space", [TaskSpace("pose"), TaskSpace("position"), TaskSpace("position+axis")])
def test_braced_min_norm_with_two_braces_keeps_every_contact_and_equals_the_kkt_solve(case, space) -> None:
    rng = np.random.default_rng(3)
    for _ in range(3):
        braced, model, q = case(rng)
        st = braced.state(q)
        xdot = rng.normal(size=6)
        qdot = BracedMinNorm(space=space).velocity(st, xdot)
        g, j_e = reference(braced, model, q)
        s = selection(space, pin_frame_placement(model, braced.robot.tip, q).rotation)
        scale = np.linalg.norm(xdot)
        np.testing.assert_allclose(g @ qdot, 0.0, atol=1e-10 * scale)
        np.testing.assert_allclose(s @ j_e @ qdot, s @ xdot, atol=1e-10 * scale)
        ref = kkt_rates(g, s @ j_e, s @ xdot, np.zeros(q.size))
        np.testing.assert_allclose(qdot, ref, atol=1e-10 * np.linalg.norm(ref))


def several_objective(
    braced: BracedRobot, beta: np.ndarray, w_ci: float, w_d: float = 0.0, w_q: float = 0.0, w_theta: float = 0.0
) -> Objective:
    """w_Ci C_i + w_d Σ_i d_i (+ w_q h(q)) (+ w_θ Σ θ_z,i): the objective's terms with several braces, by hand."""
    terms: list = [ComplianceIndex(beta)]
    weights = [w_ci]
    for i, b in enumerate(braced.braces):
        if w_d and b.region_radius is not None:
            terms.append(RegionBarrier(b.region_radius, b.surface.point, name=f"d_{i}", brace=i))
            weights.append(w_d)
        if w_theta and b.pad_axis:
            terms.append(BraceAngle(name=f"theta_z_{i}", brace=i))
            weights.append(w_theta)
    if w_q:
        terms.append(JointLimitBarrier(braced.robot.lower, braced.robot.upper))
        weights.append(w_q)
    return Objective(terms, weights)


def reference_objective(braced: BracedRobot, model: pin.Model, beta: np.ndarray, w_ci: float, w_d: float):
    """g(q) = w_Ci ‖βᵀ C_e‖ + w_d Σ d_i with C_e from the bordered system [[K, −Gᵀ], [G, 0]]."""
    k = braced.robot.stiffness

    def g(q: np.ndarray) -> float:
        gg, j_e = reference(braced, model, q)
        n, c = q.size, gg.shape[0]
        bordered = np.block([[np.diag(k), -gg.T], [gg, np.zeros((c, c))]])
        c_e = j_e @ np.linalg.solve(bordered, np.vstack([j_e.T, np.zeros((c, 6))]))[:n]
        out = w_ci * np.linalg.norm(beta @ c_e)
        for brace in braced.braces:
            r = np.linalg.norm(pin_frame_placement(model, brace.frame, q).translation - brace.surface.point)
            out += w_d * region_barrier(r, brace.region_radius)
        return float(out)

    return g


@pytest.mark.parametrize("case", [paper_case, chain_case])
def test_gradient_projection_with_two_braces_equals_the_kkt_solve_with_the_objective_gradient(case) -> None:
    rng = np.random.default_rng(5)
    beta = np.array([1.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    space = TaskSpace("position")
    for _ in range(2):
        braced, model, q = case(rng)
        st = braced.state(q, hessians=True)
        objective = several_objective(braced, beta, 100.0, 0.01)
        strategy = BracedGradientProjection(objective, alpha=-0.5, space=space)
        g_ref = reference_objective(braced, model, beta, 100.0, 0.01)
        assert objective.value(st) == pytest.approx(g_ref(q), rel=1e-9)
        step = 1e-5
        grad_ref = np.array([(g_ref(q + step * e) - g_ref(q - step * e)) / (2 * step) for e in np.eye(q.size)])
        grad = strategy.dg_dq(st)  # analytic: the kinematic Hessians of J_e and of every J_b_i
        np.testing.assert_allclose(grad, grad_ref, atol=1e-7 * np.linalg.norm(grad_ref))
        fd = BracedGradientProjection(objective, alpha=-0.5, space=space, gradient="finite-difference").dg_dq(st)
        np.testing.assert_allclose(fd, grad_ref, atol=1e-7 * np.linalg.norm(grad_ref))
        xdot = rng.normal(size=6)
        qdot = strategy.velocity(st, xdot)
        gg, j_e = reference(braced, model, q)
        s = space.selection(st.R_e)
        ref = kkt_rates(gg, s @ j_e, s @ xdot, -0.5 * grad_ref)
        np.testing.assert_allclose(qdot, ref, atol=1e-7 * np.linalg.norm(ref))
        np.testing.assert_allclose(gg @ qdot, 0.0, atol=1e-10 * np.linalg.norm(qdot))


def test_a_task_the_braces_leave_no_motion_for_raises_a_singularity_error() -> None:
    rng = np.random.default_rng(8)
    n = 7
    text = random_chain_urdf(n, seed=8, brace_link=3)
    robot = Robot.from_urdf(text, tip="tip").with_point_frames([("pad", "l6", (0.03, 0.0, 0.04), None)])
    q = rng.uniform(-2.0, 2.0, n)
    braces = braces_through(robot.model, q, ["brace", "pad"], ["point_with_friction", "point_with_friction"], rng)
    st = BracedRobot(robot, braces).state(q)  # 6 rows of G: one braced motion for the 6-D pose
    assert st.N.shape == (n, 1)
    with pytest.raises(SingularityError, match=r"1 braced motion\(s\) for 6 task rows"):
        BracedMinNorm().velocity(st, np.ones(6))
    with pytest.raises(SingularityError, match=r"1 braced motion\(s\) for 3 task rows"):
        ci = Objective([ComplianceIndex(np.ones(6))], [1.0])
        BracedGradientProjection(ci, space=TaskSpace("position")).velocity(st, np.ones(6))
    # the paper robot with {b} of link9 stuck (3 rows): only rotations about it and joints 10, 11 move the tip, 5
    # motions for the 6-D pose although N has 7 columns
    braced, _, q = paper_case(rng, ("frictionless_point", "point_with_friction"))
    st = braced.state(q)
    assert st.N.shape == (11, 7)
    with pytest.raises(SingularityError, match="S J_e N is singular"):
        BracedMinNorm().velocity(st, np.ones(6))
    BracedMinNorm(space=TaskSpace("position")).velocity(st, np.ones(6))  # the position alone is reachable


def test_every_term_of_an_objective_enters_it_with_several_braces_none_is_left_out() -> None:
    from bracekit.objective.condition_number import ConditionNumber

    rng = np.random.default_rng(7)
    beta = np.array([0.0, 0.0, 2.0, 0.0, 0.0, 0.0])
    braced, model, q = paper_case(rng)
    objective = several_objective(braced, beta, 100.0, 0.01)
    objective = Objective([ConditionNumber(), *objective.terms], [0.5, *objective.weights])
    # independent: k of Pinocchio's J_e, C_i of the KKT equilibrium and each brace's region barrier
    j = pin_frame_jacobian(model, braced.robot.tip, q)
    k = np.sqrt(np.trace(j @ j.T) * np.trace(np.linalg.inv(j @ j.T))) / 6.0
    expected = 0.5 * k + reference_objective(braced, model, beta / 2.0, 100.0, 0.01)(q)
    st = braced.state(q, hessians=True)
    assert objective.value(st) == pytest.approx(expected, rel=1e-9)
    step = 1e-6
    g = lambda x: objective.value(braced.state(x))  # noqa: E731
    fd = np.array([(g(q + step * e) - g(q - step * e)) / (2 * step) for e in np.eye(q.size)])
    np.testing.assert_allclose(objective.gradient(st), fd, atol=1e-6 * np.linalg.norm(fd))


def chan_dubey(q: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> float:
    """Σ_j span_j² / (4 (q_max,j − q_j)(q_j − q_min,j)) − 1 over the bounded joints, written out here."""
    out = 0.0
    for qj, lo, hi in zip(q, lower, upper, strict=True):
        if np.isfinite(lo) and np.isfinite(hi):
            out += (hi - lo) ** 2 / (4.0 * (hi - qj) * (qj - lo)) - 1.0
    return out


def inside_limits(braced: BracedRobot, q: np.ndarray, rng) -> np.ndarray:
    """q with every bounded joint moved into its range, some of them near a limit (within 5 % of the span)."""
    lo, hi = braced.robot.lower, braced.robot.upper
    bounded = np.isfinite(lo) & np.isfinite(hi)
    out = q.copy()
    span = hi[bounded] - lo[bounded]
    out[bounded] = lo[bounded] + span * rng.uniform(0.02, 0.98, bounded.sum())
    near = np.flatnonzero(bounded)[:2]
    out[near[0]] = lo[near[0]] + 0.03 * (hi[near[0]] - lo[near[0]])
    out[near[1]] = hi[near[1]] - 0.04 * (hi[near[1]] - lo[near[1]])
    return out


@pytest.mark.parametrize("case", [paper_case, chain_case])
def test_the_joint_limit_barrier_of_the_several_brace_objective_matches_central_differences(case) -> None:
    rng = np.random.default_rng(11)
    beta = np.array([0.0, 0.6, 0.8, 0.0, 0.0, 0.0])
    braced, model, q = case(rng)
    q = inside_limits(braced, q, rng)
    frames, contacts = [b.frame for b in braced.braces], [b.contact for b in braced.braces]
    braced = BracedRobot(braced.robot, braces_through(model, q, frames, contacts, rng))  # planes through q's pads
    lower, upper = braced.robot.lower, braced.robot.upper
    w_q = 0.05
    objective = several_objective(braced, beta, 100.0, 0.01, w_q=w_q)
    g_ref = reference_objective(braced, model, beta, 100.0, 0.01)
    st = braced.state(q, hessians=True)
    h = chan_dubey(q, lower, upper)
    assert h > 0.0
    assert objective.values(st)["joint_limit_barrier"] == pytest.approx(h, rel=1e-12)
    assert objective.value(st) == pytest.approx(g_ref(q) + w_q * h, rel=1e-9)
    step = 1e-6
    total = lambda x: g_ref(x) + w_q * chan_dubey(x, lower, upper)  # noqa: E731
    grad_ref = np.array([(total(q + step * e) - total(q - step * e)) / (2 * step) for e in np.eye(q.size)])
    grad = objective.gradient(st)
    np.testing.assert_allclose(grad, grad_ref, atol=1e-6 * np.linalg.norm(grad_ref))
    # the barrier's share is a large part of the gradient near the limits: the check above sees it
    no_limits = several_objective(braced, beta, 100.0, 0.01).gradient(st)
    assert np.linalg.norm(grad - no_limits) > 0.1 * np.linalg.norm(grad)


@pytest.mark.parametrize("case", [paper_case, chain_case])
def test_a_zero_joint_limit_weight_leaves_the_several_brace_objective_bit_identical(case) -> None:
    rng = np.random.default_rng(12)
    beta = np.array([1.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    braced, _, q = case(rng)
    st = braced.state(q, hessians=True)
    plain = several_objective(braced, beta, 100.0, 0.01)
    zero = Objective([*plain.terms, JointLimitBarrier(braced.robot.lower, braced.robot.upper)], [*plain.weights, 0.0])
    assert zero.value(st) == plain.value(st)
    np.testing.assert_array_equal(zero.gradient(st), plain.gradient(st))
    # the value before the barrier existed: C_i and d alone, summed as w_Ci C_i + w_d Σ d_i
    vals = plain.values(st)
    assert plain.value(st) == 100.0 * vals["Ci"] + 0.01 * sum(v for k, v in vals.items() if k.startswith("d_"))


def test_the_two_brace_scenario_passes_its_joint_limit_weight_to_the_stacked_objective() -> None:
    from bracekit.simulation.scenario import load_scenario

    scenario = load_scenario("two-braces")
    objective = scenario.objective()
    # the braced-conditioning barrier is on by default and zero here (σ_min/σ_max of J_e N ≈ 0.3 > r₀ = 0.01)
    assert objective.names == ("Ci", "d_0", "d_1", "joint_limit_barrier", "conditioning")
    assert tuple(objective.weights) == (100.0, 0.2, 0.2, 0.01, 0.01)
    q = scenario.guess
    lower, upper = scenario.robot.lower, scenario.robot.upper
    st = scenario.braced.state(q)
    plain = several_objective(scenario.braced, scenario.beta_x(0.0), 100.0, 0.2)
    assert objective.value(st) == pytest.approx(plain.value(st) + 0.01 * chan_dubey(q, lower, upper), rel=1e-12)


def test_theta_z_of_each_brace_with_a_pad_axis_enters_the_several_brace_objective() -> None:
    from dataclasses import replace

    rng = np.random.default_rng(11)
    braced, model, q = paper_case(rng)
    pads = [replace(b, pad_axis=True) if b.frame == "brace" else b for b in braced.braces]  # `brace` has a pad axis
    braced = BracedRobot(braced.robot, pads)
    st = braced.state(q)
    beta = np.array([1.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    base = several_objective(braced, beta, 100.0)
    with_theta = several_objective(braced, beta, 100.0, w_theta=0.3)
    # independent: the angle between each pad-axis brace's normal and the z axis of its frame (Pinocchio)
    angles = []
    for brace in braced.braces:
        if brace.pad_axis:
            z = pin_frame_placement(model, brace.frame, q).rotation[:, 2]
            angles.append(float(np.arccos(np.clip(z @ brace.surface.normal, -1.0, 1.0))))
    assert angles  # the pad `brace` has one
    assert with_theta.value(st) - base.value(st) == pytest.approx(0.3 * sum(angles), rel=1e-9, abs=1e-12)
    assert sum(v for k, v in with_theta.values(st).items() if k.startswith("theta_z_")) == pytest.approx(sum(angles))


def test_the_fused_step_with_several_braces_runs_the_reference_or_the_kernel_and_says_so() -> None:
    """The NumPy backend runs the reference step; "auto" the compiled kernel of several braces where numba is."""
    from bracekit.resolution import GradientProjectionStep
    from bracekit.resolution.fused import numba_available

    rng = np.random.default_rng(21)
    braced, _, q = paper_case(rng)
    beta = np.array([1.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    strategy = BracedGradientProjection(several_objective(braced, beta, 100.0, 0.01), space=TaskSpace("position"))
    for backend in ("numpy", "auto"):
        step = GradientProjectionStep(braced, strategy, backend=backend)  # type: ignore[arg-type]
        xdot = rng.normal(size=6)
        expected = strategy.velocity(braced.state(q, hessians=True), xdot)
        if backend == "auto" and numba_available():
            assert step.uses_kernel and step.fallback_reason is None
            assert np.max(np.abs(step(q, xdot) - expected)) <= 1e-12 * np.max(np.abs(expected))
        else:
            assert not step.uses_kernel and "several braces" in (step.fallback_reason or "")
            np.testing.assert_array_equal(step(q, xdot), expected)
        np.testing.assert_array_equal(step.gradient(q), strategy.dg_dq(braced.state(q, hessians=True)))
        assert step.value(q) == strategy.objective.value(braced.state(q))
