"""The preloaded (second-order) compliance against central differences of the nonlinear static solve it linearises.

References: :func:`bracekit.validate.statics.solve_static_equilibrium` (Newton on the nonlinear equilibrium with
gravity, a base tool wrench, any constraint wrenches X and a penalty contact), the ``constrained`` C_e and the
free-space J K⁻¹ Jᵀ (no loads), and finite differences of the potential energy (stability).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pinocchio as pin
import pytest

from bracekit.compliance import end_effector_compliance, free_space_compliance, preloaded_compliance
from bracekit.compliance.preloaded import loaded_free_space_compliance, tangent_stiffness
from bracekit.contact import Brace, Surface
from bracekit.errors import InputError, NumericalError
from bracekit.kinematics import BracedRobot
from bracekit.model.robot import Robot
from bracekit.simulation import Scenario, load_scenario, solve_start
from bracekit.validate.statics import solve_static_equilibrium
from helpers import random_chain_urdf

CONTACTS = ["frictionless_point", "point_with_friction", "soft_finger"]
TOOL = np.array([3.0, -2.0, -5.0, 0.3, 0.2, -0.4])  # a tool force (N) and a tool moment (N·m)


@pytest.fixture(scope="module")
def paper_start() -> tuple[Scenario, np.ndarray]:
    sc = load_scenario("paper")
    return sc, solve_start(sc.braced, sc.task.position(0.0), sc.guess).q


def rebrace(braced: BracedRobot, contact: str, k_env: float | None) -> BracedRobot:
    brace = dataclasses.replace(braced.brace, contact=contact, environment_stiffness=k_env)
    return BracedRobot(braced.robot, brace)


def static_fd(
    braced: BracedRobot, q: np.ndarray, preload: float, gravity: bool, tool: np.ndarray | None, contact: bool = True
) -> np.ndarray:
    """Central differences (±10 mN, ±10 mN·m) of the tip deflection of the nonlinear equilibrium about q."""
    robot, surface = braced.robot, braced.brace.surface
    args = (robot.model, q, robot.stiffness, braced.brace_id, robot.tip_id, surface.point, surface.normal)
    kw = {
        "preload": preload,
        "gravity": gravity,
        "base_wrench": tool,
        "environment_stiffness": braced.brace.environment_stiffness,
        "constraint_wrenches": braced.split.X,
        "contact": contact,
    }
    h = 1e-2
    fd = np.empty((6, 6))
    for j in range(6):
        dw = np.zeros(6)
        dw[j] = h
        plus = solve_static_equilibrium(*args, dw, **kw).deflection
        minus = solve_static_equilibrium(*args, -dw, **kw).deflection
        fd[:, j] = (plus - minus) / (2.0 * h)
    return fd


def rel(c: np.ndarray, ref: np.ndarray) -> float:
    return float(np.linalg.norm(c - ref) / np.linalg.norm(ref))


@pytest.mark.parametrize("k_env", [None, 2e3])
@pytest.mark.parametrize("contact", CONTACTS)
def test_without_loads_it_is_the_constrained_model(paper_start, contact: str, k_env: float | None) -> None:
    sc, q = paper_start
    braced = rebrace(sc.braced, contact, k_env)
    c0 = preloaded_compliance(braced, q)
    ce = end_effector_compliance(braced.state(q), "constrained")
    assert np.max(np.abs(c0 - ce)) <= 1e-12 * np.max(np.abs(ce))


def test_positional_preload_call_and_zero_preload(paper_start) -> None:
    sc, q = paper_start
    ce = end_effector_compliance(sc.braced.state(q), "constrained")
    np.testing.assert_allclose(preloaded_compliance(sc.braced, q, 0.0), ce, rtol=0, atol=1e-12 * np.abs(ce).max())


@pytest.mark.parametrize("contact", CONTACTS)
def test_paper_robot_with_gravity_preload_tool_wrench_and_soft_surface_matches_the_static_solve(
    paper_start, contact: str
) -> None:
    sc, q = paper_start
    braced = rebrace(sc.braced, contact, 2e3)
    fd = static_fd(braced, q, 20.0, True, TOOL)
    c = preloaded_compliance(braced, q, 20.0, gravity=True, wrench=TOOL)
    err = rel(c, fd)
    assert err < 1e-6
    # the first-order model (K alone) and the symmetrised C are measurably off: the loads' terms matter
    assert rel(end_effector_compliance(braced.state(q)), fd) > 1e-2
    assert rel(0.5 * (c + c.T), fd) > 1e-3
    assert rel(c, c.T) > 1e-3  # a dead tool moment makes the compliance non-symmetric


def test_finite_environment_stiffness_lets_the_contact_deflect(paper_start) -> None:
    sc, q = paper_start
    rigid = preloaded_compliance(sc.braced, q, 20.0, gravity=True)
    soft = rebrace(sc.braced, "frictionless_point", 2e3)
    c = preloaded_compliance(soft, q, 20.0, gravity=True)
    np.testing.assert_allclose(c, static_fd(soft, q, 20.0, True, None), rtol=0, atol=1e-6 * np.abs(c).max())
    np.testing.assert_allclose(c, c.T, rtol=0, atol=1e-15 * np.abs(c).max())  # no tool moment: symmetric
    assert np.linalg.eigvalsh(c - rigid).min() > -1e-12 * np.abs(c).max()  # a soft surface adds compliance
    assert np.linalg.norm(c - rigid) > 1e-3 * np.linalg.norm(c)


@pytest.mark.parametrize("preload", [0.0, 50.0])
def test_preload_alone_matches_the_static_solve(paper_start, preload: float) -> None:
    sc, q = paper_start
    fd = static_fd(sc.braced, q, preload, False, None)
    c = preloaded_compliance(sc.braced, q, preload)
    assert rel(c, fd) < 1e-6
    if preload:
        first = end_effector_compliance(sc.braced.state(q), "constrained")
        assert rel(first, fd) > 100 * rel(c, fd)  # the preload term matters here


@pytest.fixture(scope="module")
def random_chain() -> tuple[BracedRobot, np.ndarray]:
    """The 9-joint random chain of tests/helpers.py (0.5 kg links), braced on link 5 on a tilted plane through b."""
    robot = Robot.from_urdf(random_chain_urdf(9, seed=3, brace_link=5), tip="tip", stiffness=np.linspace(60, 120, 9))
    q = np.random.default_rng(7).uniform(-1.0, 1.0, 9)
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, q)
    b = data.oMf[robot.model.getFrameId("brace")].translation.copy()
    surface = Surface(point=b, normal=np.array([0.2, -0.3, 1.0]) / np.linalg.norm([0.2, -0.3, 1.0]))
    return BracedRobot(robot, Brace("brace", surface, environment_stiffness=5e3)), q


@pytest.mark.parametrize("contact", ["frictionless_point", "soft_finger"])
def test_random_chain_with_all_loads_matches_the_static_solve(random_chain, contact: str) -> None:
    braced, q = random_chain
    braced = rebrace(braced, contact, 5e3)
    tool = np.array([1.0, 0.5, -2.0, 0.1, -0.2, 0.05])
    fd = static_fd(braced, q, 5.0, True, tool)
    c = preloaded_compliance(braced, q, 5.0, gravity=True, wrench=tool)
    assert rel(c, fd) < 1e-6
    assert rel(end_effector_compliance(braced.state(q)), fd) > 1e-3


def test_loaded_free_space_compliance_matches_the_free_static_solve(paper_start) -> None:
    sc, q = paper_start
    c = loaded_free_space_compliance(sc.braced, q, gravity=True, wrench=TOOL)
    fd = static_fd(sc.braced, q, 0.0, True, TOOL, contact=False)
    assert rel(c, fd) < 1e-6
    free = free_space_compliance(sc.braced.state(q))
    assert rel(free, fd) > 1e-2
    np.testing.assert_allclose(
        loaded_free_space_compliance(sc.braced, q), free, rtol=0, atol=1e-12 * np.abs(free).max()
    )


def test_gravity_term_is_the_hessian_of_the_potential_energy(paper_start) -> None:
    """K_t with gravity minus K_t without is ∂²V_g/∂q², V_g from Pinocchio's potential energy (central differences)."""
    sc, q = paper_start
    model, data = sc.robot.model, sc.robot.model.createData()
    st = sc.braced.state(q, hessians=True)
    dk = tangent_stiffness(st, 0.0, gravity=True) - tangent_stiffness(st, 0.0)
    h, n = 1e-4, q.size
    energy = lambda x: pin.computePotentialEnergy(model, data, x)  # noqa: E731
    hess = np.empty((n, n))
    for i in range(n):
        for k in range(n):
            ei, ek = h * np.eye(n)[i], h * np.eye(n)[k]
            hess[i, k] = (energy(q + ei + ek) - energy(q + ei - ek) - energy(q - ei + ek) + energy(q - ei - ek)) / (
                4 * h * h
            )
    np.testing.assert_allclose(dk, hess, rtol=0, atol=1e-5 * np.abs(hess).max())


def test_unstable_loaded_equilibrium_is_a_numerical_error(paper_start) -> None:
    """Soft joints under gravity: the potential energy on the allowed motions has a negative curvature (FD)."""
    sc, q = paper_start
    r = sc.robot
    soft = BracedRobot(dataclasses.replace(r, stiffness=np.full(r.n, 10.0)), sc.braced.brace)
    with pytest.raises(NumericalError, match="unstable"):
        preloaded_compliance(soft, q, gravity=True)
    # independent: V(q) = ½ (q − q_s)ᵀ K (q − q_s) + V_g(q) restricted to Xᵀ J_b δq = 0 is not convex at q
    model, data = r.model, r.model.createData()
    st = soft.state(q)
    a = st.split.J_b.T @ soft.split.X
    z = np.linalg.svd(a.T)[2][1:].T  # allowed joint motions (n × (n − 1))
    k = soft.robot.stiffness
    q_s = q + pin.computeGeneralizedGravity(model, data, q) / k
    energy = lambda x: 0.5 * (x - q_s) @ (k * (x - q_s)) + pin.computePotentialEnergy(model, data, x)  # noqa: E731
    h, m = 1e-4, z.shape[1]
    hess = np.empty((m, m))
    for i in range(m):
        for j in range(m):
            zi, zj = h * z[:, i], h * z[:, j]
            hess[i, j] = (energy(q + zi + zj) - energy(q + zi - zj) - energy(q - zi + zj) + energy(q - zi - zj)) / (
                4 * h * h
            )
    assert np.linalg.eigvalsh(0.5 * (hess + hess.T)).min() < -0.1


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"preload": -1.0}, "preload"),
        ({"preload": np.nan}, "preload"),
        ({"preload": "1"}, "preload"),
        ({"preload": True}, "preload"),
        ({"gravity": 1}, "gravity"),
        ({"wrench": np.ones(3)}, "wrench"),
        ({"wrench": [np.nan] * 6}, "wrench"),
    ],
)
def test_bad_input_is_an_input_error(paper_start, kwargs: dict, match: str) -> None:
    sc, q = paper_start
    with pytest.raises(InputError, match=match):
        preloaded_compliance(sc.braced, q, **kwargs)


def test_a_runs_compliance_is_the_one_its_model_names(paper_start) -> None:
    from bracekit.compliance.preloaded import run_compliance

    sc, q = paper_start
    st = sc.braced.state(q)
    for model in ("constrained", "projection"):
        np.testing.assert_array_equal(run_compliance(st, model, True), end_effector_compliance(st, model))
        np.testing.assert_array_equal(run_compliance(st, model, False), free_space_compliance(st))
    loaded = run_compliance(st, "preloaded", True, preload=5.0, gravity=True)
    np.testing.assert_array_equal(loaded, preloaded_compliance(sc.braced, q, 5.0, gravity=True))
    assert rel(loaded, end_effector_compliance(st, "constrained")) > 1e-4  # the preload and gravity change it
    free = run_compliance(st, "preloaded", False, gravity=True)
    np.testing.assert_array_equal(free, loaded_free_space_compliance(sc.braced, q, gravity=True))
