"""braced_qp against independent references: the closed forms written here (SVD pseudo-inverses over the braced
motions N = null(G) of G = [X_iᵀ J_b_i], from SciPy), the URDF limits, and Pinocchio's brace Jacobians."""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
import pytest
import scipy.linalg

from bracekit.errors import InputError, NumericalError, SingularityError
from bracekit.kinematics import BracedRobot
from bracekit.resolution.qp import BracedQP
from bracekit.resolution.task_space import POSE, TaskSpace, select
from bracekit.simulation.run import run_scenario
from bracekit.simulation.scenario import load_scenario
from bracekit.simulation.simulate import solve_start

pytest.importorskip("qpsolvers")


def _task_rows(state: Any, xdot: np.ndarray, space: TaskSpace) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(N, S J_e N, S ẋ) with N an orthonormal basis of null(G) from SciPy (independent of bracekit's own N)."""
    g = np.vstack([x.T @ j for x, j in zip(state.X_i, state.J_b_i, strict=True)])
    n = scipy.linalg.null_space(g)
    b, x = select(space, state.R_e, state.J_e @ n, xdot)
    return n, b, x


def braced_min_norm_rates(state: Any, xdot: np.ndarray, space: TaskSpace = POSE) -> np.ndarray:
    """q̇ = N (S J_e N)⁺ S ẋ: the least-norm joint rates that keep every contact and do the task rows."""
    n, b, x = _task_rows(state, xdot, space)
    return n @ (np.linalg.pinv(b) @ x)


def braced_gradient_projection_rates(
    state: Any, xdot: np.ndarray, dg_dq: np.ndarray, alpha: float, space: TaskSpace = POSE
) -> np.ndarray:
    """q̇ = N [B⁺ S ẋ + α (I − B⁺ B) Nᵀ ∂g/∂q], B = S J_e N: eq:grad_proj over the braced motions."""
    n, b, x = _task_rows(state, xdot, space)
    b_pinv = np.linalg.pinv(b)
    grad = n.T @ np.asarray(dg_dq, dtype=float)
    return n @ (b_pinv @ x + alpha * (grad - b_pinv @ (b @ grad)))


@pytest.fixture(scope="module")
def paper() -> Any:
    sc = load_scenario("paper")
    start = solve_start(sc.braced, sc.task.position(0.0), sc.guess, rotation=sc.task.rotation)
    return sc, start.q


@pytest.fixture(scope="module")
def two() -> Any:
    sc = load_scenario("two-braces")
    start = solve_start(sc.braced, sc.task.position(0.0), sc.guess, rotation=sc.task.rotation)
    return sc, start.q


def _xdot(seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).normal(size=6) * np.array([0.05, 0.05, 0.05, 0.1, 0.1, 0.1])


@pytest.mark.parametrize("solver, tol", [("daqp", 1e-9), ("proxqp", 1e-7)])
def test_without_active_inequalities_the_qp_is_the_braced_min_norm(paper: Any, solver: str, tol: float) -> None:
    sc, q = paper
    qp = BracedQP(None, dt=0.05, solver=solver, clearance_margin=None, space=sc.task_space)
    qdot = qp.velocity(sc.braced.state(q), _xdot())
    ref = braced_min_norm_rates(sc.braced.state(q), _xdot(), sc.task_space)
    assert np.max(np.abs(qdot - ref)) < tol * max(1.0, np.max(np.abs(ref)))


def test_with_the_objective_the_qp_is_the_projected_gradient(paper: Any) -> None:
    sc, q = paper
    objective = sc.objective()
    qp = BracedQP(objective, alpha=-0.7, dt=0.05, clearance_margin=None, space=sc.task_space)
    state = sc.braced.state(q, hessians=True)
    grad = objective.gradient(state)
    assert np.linalg.norm(grad) > 0
    qdot = qp.velocity(state, _xdot(1))
    ref = braced_gradient_projection_rates(sc.braced.state(q), _xdot(1), grad, -0.7, sc.task_space)
    assert np.max(np.abs(qdot - ref)) < 1e-9 * max(1.0, np.max(np.abs(ref)))
    # the gradient moves q̇ away from the minimum norm (the reference is not trivially the same)
    assert np.max(np.abs(ref - braced_min_norm_rates(sc.braced.state(q), _xdot(1), sc.task_space))) > 1e-6


def test_several_braces_give_the_closed_form_too(two: Any) -> None:
    sc, q = two
    space = TaskSpace("position")
    qp = BracedQP(None, dt=0.05, clearance_margin=None, space=space)
    st = sc.braced.state(q)
    qdot = qp.velocity(st, _xdot(2))
    ref = braced_min_norm_rates(st, _xdot(2), space)
    assert np.max(np.abs(qdot - ref)) < 1e-9 * max(1.0, np.max(np.abs(ref)))


def test_the_contact_holds_to_1e_9_on_every_step(two: Any) -> None:
    sc, q = two
    qp = BracedQP(sc.objective(), gradient="finite-difference", dt=0.05, space=sc.task_space)
    for step in range(5):
        st = sc.braced.state(q)
        qdot = qp.velocity(st, _xdot(step))
        offset = np.concatenate(
            [
                b.X().T @ np.concatenate([b.surface.normal * b.surface.signed_distance(p), np.zeros(3)])
                for b, p in zip(sc.braced.braces, st.b_i, strict=True)
            ]
        )
        assert np.max(np.abs(st.G @ qdot + qp.baumgarte / qp.dt * offset)) < 1e-9
        q = q + qdot * 0.01


def test_position_limits_hold_where_the_minimum_norm_breaks_them(paper: Any) -> None:
    sc, q = paper
    robot = sc.braced.robot
    x = _xdot(3)
    ref = braced_min_norm_rates(sc.braced.state(q), x, sc.task_space)
    # a step long enough that the minimum-norm rate uses the whole distance to one joint's limit (γ = 0.5: half)
    room = np.where(ref > 0, robot.upper - q, q - robot.lower) / np.abs(ref)
    dt = 0.55 * float(np.min(room))  # 55 % of the room: beyond γ = 0.5
    qp = BracedQP(None, dt=dt, limit_gain=0.5, clearance_margin=None, space=sc.task_space)
    qdot = qp.velocity(sc.braced.state(q), x)
    upper, lower = q + 0.5 * (robot.upper - q), q + 0.5 * (robot.lower - q)
    assert np.any(q + ref * dt > upper + 1e-6) or np.any(q + ref * dt < lower - 1e-6)
    assert np.all(q + qdot * dt <= upper + 1e-9) and np.all(q + qdot * dt >= lower - 1e-9)
    st = sc.braced.state(q)  # the task and the contact still hold exactly
    assert np.max(np.abs(st.G @ qdot)) < 1e-9
    assert np.max(np.abs(st.J_e @ qdot - x)) < 1e-9


def test_velocity_limits_hold_where_the_minimum_norm_breaks_them(paper: Any) -> None:
    sc, q = paper
    vmax = sc.braced.robot.model.velocityLimit
    x = _xdot(3)
    ref = braced_min_norm_rates(sc.braced.state(q), x, sc.task_space)
    x = x * 1.3 * float(np.min(vmax / np.abs(ref)))  # the minimum norm runs one joint at 1.3 × its URDF limit
    ref = ref * 1.3 * float(np.min(vmax / np.abs(ref)))
    assert np.max(np.abs(ref) / vmax) > 1.29
    qdot = BracedQP(None, dt=0.05, clearance_margin=None, space=sc.task_space).velocity(sc.braced.state(q), x)
    assert np.all(np.abs(qdot) <= vmax + 1e-9)
    st = sc.braced.state(q)
    assert np.max(np.abs(st.G @ qdot)) < 1e-9
    assert np.max(np.abs(st.J_e @ qdot - x)) < 1e-9


def test_an_infeasible_qp_names_its_constraint_set(paper: Any) -> None:
    sc, q = paper
    qp = BracedQP(None, dt=0.05, clearance_margin=None, space=sc.task_space)
    with pytest.raises(NumericalError, match="joint position and velocity limits cannot hold together with"):
        qp.velocity(sc.braced.state(q), _xdot(4) * 1e3)


def test_a_weighted_task_is_the_equality_at_high_weight(paper: Any) -> None:
    sc, q = paper
    weighted = BracedQP(None, dt=0.05, task_weight=1e8, clearance_margin=None, space=sc.task_space)
    qdot = weighted.velocity(sc.braced.state(q), _xdot(5))
    ref = braced_min_norm_rates(sc.braced.state(q), _xdot(5), sc.task_space)
    assert np.max(np.abs(qdot - ref)) < 1e-6 * max(1.0, np.max(np.abs(ref)))


def test_too_few_contact_motions_raise_or_are_damped() -> None:
    """Panda with a contact that takes 3 rows: 4 motions for 6 pose rows; the weighted task is least squares."""
    sc = load_scenario("panda")
    brace = dataclasses.replace(sc.braced.brace, contact="point_with_friction")
    braced = BracedRobot(sc.braced.robot, brace)
    q = np.array(sc.guess, dtype=float)
    with pytest.raises(SingularityError, match="singular"):
        BracedQP(None, dt=0.05, clearance_margin=None).velocity(braced.state(q), _xdot(6))
    damped = BracedQP(None, dt=0.05, task_weight=1e8, clearance_margin=None, baumgarte=0.0)
    qdot = damped.velocity(braced.state(q), _xdot(6))
    st = braced.state(q)
    y = np.linalg.lstsq(st.J_e @ st.N, _xdot(6), rcond=None)[0]  # least squares over the contact motions
    assert np.max(np.abs(qdot - st.N @ y)) < 1e-5 * max(1.0, np.max(np.abs(st.N @ y)))
    b = st.J_e @ st.N  # the damped least squares: (w BᵀB + (1 + λ) I) y = w Bᵀ ẋ, σ_min/σ_max(B) = 0 (4 < 6 rows)
    yd = np.linalg.solve(1e8 * b.T @ b + (1 + damped.damping) * np.eye(b.shape[1]), 1e8 * b.T @ _xdot(6))
    assert np.max(np.abs(qdot - st.N @ yd)) < 1e-9
    assert np.max(np.abs(st.G @ qdot)) < 1e-9


def test_bad_parameters_are_refused() -> None:
    with pytest.raises(InputError, match="alpha"):
        BracedQP(None, alpha=1.0)
    with pytest.raises(InputError, match="solver"):
        BracedQP(None, solver="nope")
    with pytest.raises(InputError, match="baumgarte"):
        BracedQP(None, baumgarte=2.0)


def test_the_paper_run_keeps_the_links_clear_where_gradient_projection_does_not() -> None:
    sc = dataclasses.replace(load_scenario("paper"), strategies=["braced_gradient_projection", "braced_qp"])
    out = run_scenario(sc, both_models=False).summary["strategies"]
    qp, gp = out["braced_qp"], out["braced_gradient_projection"]
    assert qp["completed"] and gp["completed"]
    assert gp["min_link_clearance_m"] < -0.1
    assert qp["min_link_clearance_m"] > -1e-4
    assert qp["max_contact_violation_m"] < 1e-9
    assert qp["max_joint_limit_violation_rad"] == 0.0
    assert qp["Ci_mean"] < out["braced_gradient_projection"]["Ci_mean"] * 1.05


@pytest.mark.parametrize("name", ["paper", "panda", "panda-holding", "two-braces"])
def test_braced_qp_runs_every_shipped_scenario(name: str) -> None:
    """A tenth of each shipped task; where the metrics agree (n1 ≠ 6, or several braces) and no inequality is
    active, braced_qp's path is gradient projection's (two independent solutions of one problem)."""
    sc = load_scenario(name)
    sc = dataclasses.replace(sc, task=dataclasses.replace(sc.task, turns=0.1))
    sc = dataclasses.replace(sc, strategies=["braced_gradient_projection", "braced_qp"])
    res = run_scenario(sc, both_models=False)
    out = res.summary["strategies"]["braced_qp"]
    assert out["completed"], out["failure"]
    assert out["max_contact_violation_m"] < 1e-9
    assert out["max_joint_limit_violation_rad"] == 0.0
    if name != "paper":
        runs = next(iter(res.trajectories.values()))
        qp, gp = runs["braced_qp"].q, runs["braced_gradient_projection"].q
        assert qp.shape == gp.shape and np.max(np.abs(qp - gp)) < 1e-8


def test_a_missing_solver_is_named(monkeypatch: pytest.MonkeyPatch) -> None:
    import sys

    from bracekit.errors import MissingDependencyError

    monkeypatch.setitem(sys.modules, "qpsolvers", None)
    with pytest.raises(MissingDependencyError, match=r"bracekit\[qp\]"):
        BracedQP(None)


def test_a_link_at_or_inside_the_least_clearance_may_not_go_deeper(paper: Any) -> None:
    """Links 4, 5 (0.01 m) and 7 (0.04 m) count as inside with c_min = 0.05 m; the minimum-norm step takes one
    deeper, braced_qp's does not: checked on the clearance itself, a short step along q̇ (first order, h = 1e-5 s)."""
    from bracekit.kinematics.clearance import Clearance

    sc, q = paper
    clearance = Clearance(sc.braced)

    def links(x: np.ndarray) -> dict[int, float]:
        return {d.joint: d.clearance for d in clearance.links(x, gradient=False)}

    base = links(q)
    inside = [j for j, c in base.items() if c < 0.05]
    assert len(inside) == 3
    h = 1e-5
    x = _xdot(7)
    ref = braced_min_norm_rates(sc.braced.state(q), x, sc.task_space)
    rate = {j: (links(q + h * ref)[j] - base[j]) / h for j in inside}
    if min(rate.values()) > -1e-3:  # none deepens at a rate: the opposite twist does
        x, ref = -x, -ref
        rate = {j: (links(q + h * ref)[j] - base[j]) / h for j in inside}
    assert min(rate.values()) < -1e-3
    qp = BracedQP(None, dt=0.05, clearance_margin=0.1, clearance_min=0.05, space=sc.task_space)
    qdot = qp.velocity(sc.braced.state(q), x)
    after = links(q + h * qdot)
    assert all((after[j] - base[j]) / h > -1e-4 for j in inside)
    st = sc.braced.state(q)
    assert np.max(np.abs(st.G @ qdot)) < 1e-9 and np.max(np.abs(st.J_e @ qdot - x)) < 1e-9
