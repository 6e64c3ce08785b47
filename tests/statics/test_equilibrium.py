"""The preloaded equilibrium and its load response against Pinocchio's RNEA and nonlinear static solves."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from scipy.optimize import root

from bracekit.errors import InputError
from bracekit.model.robot import Robot
from bracekit.statics import contact_response, contact_responses, gravity_torque, load_contact_wrenches
from bracekit.validate.statics import preload_rest_configuration, solve_static_equilibrium

LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED


def rnea_torque(braced, q: np.ndarray, f_c: np.ndarray, gravity: bool) -> np.ndarray:
    """τ from Pinocchio's RNEA at v = a = 0 with f_c ([f; m] at b, world axes) as an external force."""
    model = braced.robot.model
    if not gravity:
        model = pin.Model(model)
        model.gravity = pin.Motion.Zero()
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    fid = braced.brace_id
    joint = model.frames[fid].parentJoint
    b = data.oMf[fid].translation
    at_origin = pin.Force(f_c[:3], f_c[3:] + np.cross(b, f_c[:3]))  # world axes, about the world origin
    fext = pin.StdVec_Force()
    for _ in range(model.njoints):
        fext.append(pin.Force.Zero())
    fext[joint] = data.oMi[joint].actInv(at_origin)  # in the joint's local frame, as RNEA wants
    zero = np.zeros(model.nv)
    return np.asarray(pin.rnea(model, data, q, zero, zero, fext)).copy()


@pytest.mark.parametrize("gravity", [True, False])
def test_unloaded_torques_match_rnea_with_the_preload_as_external_force(paper, chain, gravity: bool) -> None:
    for braced, q in (paper, chain()):
        r = contact_response(braced, q, preload=12.0, gravity=gravity)
        f_c0 = np.concatenate([12.0 * braced.brace.surface.normal, np.zeros(3)])
        np.testing.assert_allclose(r.f_c0, f_c0)
        ref = rnea_torque(braced, q, f_c0, gravity)
        np.testing.assert_allclose(r.tau0, ref, rtol=0, atol=1e-10 * max(1.0, np.max(np.abs(ref))))
        np.testing.assert_allclose(r.q_s, q + ref / braced.robot.stiffness, rtol=0, atol=1e-12)


def test_set_points_without_gravity_are_the_validated_preload_rest_configuration(paper) -> None:
    braced, q = paper
    robot, surface = braced.robot, braced.brace.surface
    rest = preload_rest_configuration(robot.model, q, robot.stiffness, braced.brace_id, surface.normal, 7.0)
    np.testing.assert_allclose(contact_response(braced, q, preload=7.0).q_s, rest, rtol=0, atol=1e-13)


def test_gravity_torque_of_a_horizontal_arm_opposes_gravity() -> None:
    """One link of 2 kg with its centre 0.3 m along x from a joint about y: the actuator holds −m g L."""
    urdf = """<robot name="arm"><link name="base"/>
      <link name="l1"><inertial><origin xyz="0.3 0 0"/><mass value="2.0"/>
        <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>
      <link name="tip"/>
      <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/><axis xyz="0 1 0"/>
        <limit lower="-3" upper="3" effort="10" velocity="1"/></joint>
      <joint name="t" type="fixed"><parent link="l1"/><child link="tip"/><origin xyz="0.6 0 0"/></joint></robot>"""
    robot = Robot.from_urdf(urdf, tip="tip")
    # gravity's moment about +y is r × F = (0.3, 0, 0) × (0, 0, −2·9.81): +5.886 N·m, turning x down
    np.testing.assert_allclose(gravity_torque(robot, [0.0]), [-2.0 * 9.81 * 0.3], rtol=1e-12)
    np.testing.assert_allclose(gravity_torque(robot, [np.pi / 2]), [0.0], atol=1e-12)  # hanging straight down


def finite_difference(solve, h: float = 1e-3) -> tuple[np.ndarray, np.ndarray]:
    """Central differences (per unit wrench) of (f_c (6,), τ (n,)) from `solve(w)`, six unit wrenches."""
    cols = [[], []]
    for j in range(6):
        w = np.zeros(6)
        w[j] = h
        (fp, tp), (fm, tm) = solve(w), solve(-w)
        cols[0].append((fp - fm) / (2 * h))
        cols[1].append((tp - tm) / (2 * h))
    return np.array(cols[0]).T, np.array(cols[1]).T


def assert_close(actual: np.ndarray, expected: np.ndarray, rtol: float) -> None:
    np.testing.assert_allclose(actual, expected, rtol=0, atol=rtol * np.max(np.abs(expected)))


@pytest.mark.parametrize("preload", [0.0, 20.0])
def test_frictionless_load_response_is_the_derivative_of_the_validated_static_solve(paper, preload: float) -> None:
    braced, q = paper
    robot, surface = braced.robot, braced.brace.surface
    args = (robot.model, q, robot.stiffness, braced.brace_id, robot.tip_id, surface.point, surface.normal)

    def solve(w):
        res = solve_static_equilibrium(*args, w, preload=preload)
        f_c = np.concatenate([res.contact_force * surface.normal, np.zeros(3)])
        return f_c, robot.stiffness * (contact_response(braced, q, preload=preload).q_s - res.q)

    fd_f, fd_tau = finite_difference(solve)
    r = contact_response(braced, q, preload=preload)
    assert_close(r.contact_gain, fd_f, 1e-4)
    assert_close(r.torque_gain, fd_tau, 1e-4)
    if preload > 0.0:  # the preload's geometric stiffness matters: the joint springs alone are off by more
        plain = contact_response(braced, q, preload=preload, geometric=False)
        assert np.max(np.abs(plain.torque_gain - fd_tau)) > 10 * np.max(np.abs(r.torque_gain - fd_tau))


def nonlinear_solve(braced, q0, q_s, w, *, sticking: bool, gravity: bool, preload: float, k_env=None):
    """Independent static solve (SciPy's hybrid root finder, Pinocchio kinematics): (f_c (6,), τ (n,)).

    Unknowns q (and the 3-D contact force λ when sticking): K (q_s − q) = g(q) − J_eᵀ w − J_b,vᵀ f with
    f = λ and p_b(q) = p_b(q0) (sticking), or f = n̂ (P − k_env n̂ᵀ(p_b(q) − p_b(q0))) (a compliant surface).
    """
    robot = braced.robot
    model, data = robot.model, robot.model.createData()
    k, n, nhat = robot.stiffness, robot.n, braced.brace.surface.normal

    def kin(q):
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        je = pin.getFrameJacobian(model, data, robot.tip_id, LWA)
        jb = pin.getFrameJacobian(model, data, braced.brace_id, LWA)
        g = pin.computeGeneralizedGravity(model, data, q) if gravity else np.zeros(n)
        return je, jb, data.oMf[braced.brace_id].translation.copy(), g

    b0 = kin(q0)[2]

    def force(x):
        if sticking:
            return x[n:]
        return nhat * (preload - k_env * nhat @ (kin(x[:n])[2] - b0))

    def residual(x):
        q = x[:n]
        je, jb, b, g = kin(q)
        f = force(x)
        r = (k * (q_s - q) - g + je.T @ w + jb[:3].T @ f) / k
        return np.concatenate([r, b - b0]) if sticking else r

    x0 = np.concatenate([q0, preload * nhat]) if sticking else q0.copy()
    sol = root(residual, x0, method="hybr", options={"xtol": 1e-15})
    assert np.max(np.abs(residual(sol.x))) < 1e-12
    return np.concatenate([force(sol.x), np.zeros(3)]), k * (q_s - sol.x[:n])


def test_sticking_response_with_gravity_is_the_derivative_of_a_nonlinear_solve(chain) -> None:
    braced, q = chain(stiffness=40.0)
    r = contact_response(braced, q, preload=3.0, gravity=True, friction=0.4)
    assert r.X.shape == (6, 3)  # the frictionless point sticks: a 3-D force

    def solve(w):
        return nonlinear_solve(braced, q, r.q_s, w, sticking=True, gravity=True, preload=3.0)

    fd_f, fd_tau = finite_difference(solve, h=1e-4)
    assert_close(r.contact_gain, fd_f, 1e-4)
    assert_close(r.torque_gain, fd_tau, 1e-4)
    plain = contact_response(braced, q, preload=3.0, gravity=True, friction=0.4, geometric=False)
    assert np.max(np.abs(plain.torque_gain - fd_tau)) > 10 * np.max(np.abs(r.torque_gain - fd_tau))


def test_compliant_surface_response_is_the_derivative_of_a_penalty_solve(chain) -> None:
    braced, q = chain(stiffness=40.0, k_env=500.0)
    r = contact_response(braced, q, preload=2.0, gravity=True)

    def solve(w):
        return nonlinear_solve(braced, q, r.q_s, w, sticking=False, gravity=True, preload=2.0, k_env=500.0)

    fd_f, fd_tau = finite_difference(solve, h=1e-4)
    assert_close(r.contact_gain, fd_f, 1e-4)
    assert_close(r.torque_gain, fd_tau, 1e-4)
    rigid = contact_response(chain(stiffness=40.0)[0], q, preload=2.0, gravity=True)
    assert np.max(np.abs(rigid.contact_gain - fd_f)) > 0.01 * np.max(np.abs(fd_f))  # k_env matters here


def test_without_geometric_stiffness_torques_balance_the_loads_at_q(chain) -> None:
    """δτ = −J_eᵀ w − J_bᵀ δf_c: the equilibrium at q itself, to first order, for every contact type."""
    for contact in ("frictionless_point", "point_with_friction", "soft_finger"):
        braced, q = chain(contact=contact)
        r = contact_response(braced, q, preload=1.0, geometric=False)
        st = braced.state(q)
        np.testing.assert_allclose(r.torque_gain, -st.J_e.T - st.split.J_b.T @ r.contact_gain, atol=1e-10)
        # the contact wrench stays in span(X) and b does not move along the constraints
        x = r.X
        np.testing.assert_allclose(x @ np.linalg.lstsq(x, r.contact_gain, rcond=None)[0], r.contact_gain, atol=1e-10)
        np.testing.assert_allclose(x.T @ st.split.J_b @ r.joint_gain, 0.0, atol=1e-10)


def test_pressing_the_tool_toward_the_surface_adds_normal_force(paper) -> None:
    braced, q = paper
    r = contact_response(braced, q, preload=5.0)
    down = np.array([0.0, 0.0, -1.0, 0.0, 0.0, 0.0])  # the table's normal is +z
    assert r.contact_wrench(down)[2] > 5.0
    np.testing.assert_allclose(r.contact_wrench(np.zeros(6)), r.f_c0)


def test_batch_equals_one_configuration_at_a_time(paper_path, paper) -> None:
    braced = paper[0]
    batch = contact_responses(braced, paper_path, preload=4.0, gravity=True, friction=0.3)
    for i, q in enumerate(paper_path):
        one = contact_response(braced, q, preload=4.0, gravity=True, friction=0.3)
        np.testing.assert_allclose(batch.at(i).contact_gain, one.contact_gain, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(batch.at(i).torque_gain, one.torque_gain, rtol=1e-12, atol=1e-12)


def test_only_a_frictionless_point_given_friction_sticks(chain) -> None:
    braced, _ = chain()
    assert load_contact_wrenches(braced.brace, None).shape == (6, 1)
    assert load_contact_wrenches(braced.brace, 0.0).shape == (6, 1)
    assert load_contact_wrenches(braced.brace, 0.5).shape == (6, 3)
    assert load_contact_wrenches(chain(contact="soft_finger")[0].brace, 0.5).shape == (6, 4)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"preload": -1.0}, "preload"),
        ({"preload": np.nan}, "preload"),
        ({"friction": -0.1}, "friction"),
        ({"friction": np.inf}, "friction"),
        ({"gravity": "yes"}, "gravity"),
    ],
)
def test_bad_inputs_are_input_errors(paper, kwargs, match: str) -> None:
    braced, q = paper
    with pytest.raises(InputError, match=match):
        contact_response(braced, q, **kwargs)


def test_a_configuration_with_nan_is_an_input_error(paper) -> None:
    braced, q = paper
    with pytest.raises(InputError, match="finite"):
        contact_response(braced, np.where(np.arange(q.size) == 2, np.nan, q))
