"""Tests of bracekit.validate.statics: the Lagrange (KKT) compliance and the nonlinear braced statics."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from bracekit.validate.statics import (
    StaticSolveError,
    frame_jacobian_derivative,
    lagrange_compliance,
    preload_rest_configuration,
    solve_static_equilibrium,
)

LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
Q0 = np.array([0.2, -0.4, 0.9, 0.3, -0.5, 0.4, 0.6, -0.2])
K = 170.0 * np.linspace(0.7, 1.3, 8)
NORMAL = np.array([0.0, 0.3, 1.0]) / np.linalg.norm([0.0, 0.3, 1.0])


def make_arm() -> pin.Model:
    """8-joint spatial arm (RZ RY RY RX unaligned RZ RY RX, tilted placements), brace on link 5 (n1 = 5)."""
    model = pin.Model()
    joints = [
        pin.JointModelRZ(), pin.JointModelRY(), pin.JointModelRY(), pin.JointModelRX(),
        pin.JointModelRevoluteUnaligned(np.array([0.0, 0.6, 0.8])), pin.JointModelRZ(),
        pin.JointModelRY(), pin.JointModelRX(),
    ]  # fmt: skip
    offsets = [(0, 0, 0.3), (0, 0.05, 0.1), (0.35, 0, 0), (0.3, -0.03, 0.02), (0.1, 0, 0), (0.2, 0.02, 0),
               (0.12, 0, 0.03), (0.1, 0, 0)]  # fmt: skip
    parent = 0
    for i, (jm, off) in enumerate(zip(joints, offsets, strict=True)):
        R = pin.rpy.rpyToMatrix(0.1 * i, -0.05 * i, 0.07 * i)
        parent = model.addJoint(parent, jm, pin.SE3(R, np.array(off, dtype=float)), f"j{i + 1}")
        model.appendBodyToJoint(parent, pin.Inertia.FromSphere(1.0, 0.05), pin.SE3.Identity())
        model.addFrame(pin.Frame(f"l{i + 1}", parent, pin.SE3.Identity(), pin.FrameType.BODY))
        if i == 0:  # a point on the axis of joint 1: it cannot move along any normal
            model.addFrame(pin.Frame("on_axis", parent, pin.SE3.Identity(), pin.FrameType.OP_FRAME))
        if i == 4:
            placement = pin.SE3(np.eye(3), np.array([0.15, 0.02, -0.04]))
            model.addFrame(pin.Frame("brace", parent, placement, pin.FrameType.OP_FRAME))
    tool = pin.SE3(pin.rpy.rpyToMatrix(0.3, 0.2, 0.1), np.array([0.1, 0.0, 0.05]))
    model.addFrame(pin.Frame("tool", parent, tool, pin.FrameType.OP_FRAME))
    return model


@pytest.fixture(scope="module")
def arm() -> dict:
    model = make_arm()
    data = model.createData()
    b, e = model.getFrameId("brace"), model.getFrameId("tool")
    pin.computeJointJacobians(model, data, Q0)
    pin.updateFramePlacements(model, data)
    Je = pin.getFrameJacobian(model, data, e, LWA)
    Jb = pin.getFrameJacobian(model, data, b, LWA)[:3]
    return {
        "model": model, "b": b, "e": e, "point": data.oMf[b].translation.copy(),
        "Je": Je, "a": Jb.T @ NORMAL,
    }  # fmt: skip


def closed_form(J: np.ndarray, k: np.ndarray, a: np.ndarray) -> np.ndarray:
    Ki = np.diag(1.0 / k)
    a = a.reshape(len(k), -1)
    return J @ Ki @ J.T - J @ Ki @ a @ np.linalg.solve(a.T @ Ki @ a, a.T @ Ki @ J.T)


def solve(arm: dict, wrench: np.ndarray, **kw: object):
    return solve_static_equilibrium(arm["model"], Q0, K, arm["b"], arm["e"], arm["point"], NORMAL, wrench, **kw)


def rel(x: np.ndarray, ref: np.ndarray) -> float:
    return float(np.linalg.norm(x - ref) / np.linalg.norm(ref))


# ---------------------------------------------------------------------------------------------- (a)
def test_lagrange_matches_closed_form_and_is_symmetric_psd(arm: dict) -> None:
    C = lagrange_compliance(arm["Je"], K, arm["a"])
    assert C.shape == (6, 6)
    np.testing.assert_allclose(C, closed_form(arm["Je"], K, arm["a"]), rtol=0, atol=1e-13)
    np.testing.assert_allclose(C, C.T, rtol=0, atol=1e-15)
    ev = np.linalg.eigvalsh(0.5 * (C + C.T))
    assert ev.min() > -1e-14
    # the constraint removes compliance: C_free − C is PSD
    C_free = arm["Je"] @ np.diag(1.0 / K) @ arm["Je"].T
    assert np.linalg.eigvalsh(C_free - C).min() > -1e-14


def test_lagrange_several_constraints_random() -> None:
    rng = np.random.default_rng(0)
    for n, m in [(7, 1), (9, 2), (11, 3)]:
        J = rng.normal(size=(6, n))
        k = rng.uniform(50.0, 300.0, n)
        a = rng.normal(size=(n, m))
        C = lagrange_compliance(J, k, a)
        np.testing.assert_allclose(C, closed_form(J, k, a), rtol=1e-10, atol=1e-14)


def test_lagrange_rejects_unloaded_constraint_and_bad_input(arm: dict) -> None:
    with pytest.raises(StaticSolveError, match="no load"):
        lagrange_compliance(arm["Je"], K, np.zeros(8))
    with pytest.raises(ValueError):
        lagrange_compliance(arm["Je"], -K, arm["a"])
    with pytest.raises(ValueError):
        lagrange_compliance(arm["Je"][:, :7], K, arm["a"])


def test_jacobian_derivative_matches_finite_differences(arm: dict) -> None:
    model = arm["model"]
    data = model.createData()
    q = Q0 + 0.1
    pin.computeJointJacobians(model, data, q)
    pin.updateFramePlacements(model, data)
    h = 1e-6
    for fid in (arm["b"], arm["e"]):
        dJ = frame_jacobian_derivative(model, data, fid)
        fd = np.zeros_like(dJ)
        for k in range(model.nv):
            dq = np.zeros(model.nv)
            dq[k] = h
            Jp = pin.computeFrameJacobian(model, model.createData(), q + dq, fid, LWA)
            Jm = pin.computeFrameJacobian(model, model.createData(), q - dq, fid, LWA)
            fd[:, :, k] = (Jp - Jm) / (2 * h)
        np.testing.assert_allclose(dJ, fd, rtol=0, atol=1e-8)


# ---------------------------------------------------------------------------------------------- (b)
DIRECTIONS = [
    np.array([1.0, 0, 0, 0, 0, 0]),
    np.array([0, 0.6, -0.8, 0, 0, 0]),
    np.array([0.48, 0.6, 0.64, 0, 0, 0]),
    np.array([0, 0, 0, 0.1, 0, 0]),
    np.array([0, 0, 0, 0, -0.06, 0.08]),
    np.array([0.5, -0.5, 0.5, 0.03, 0.04, 0.0]) / np.sqrt(0.75),
]


@pytest.mark.parametrize("direction", DIRECTIONS)
def test_nonlinear_statics_agree_with_lagrange_to_first_order(arm: dict, direction: np.ndarray) -> None:
    C = lagrange_compliance(arm["Je"], K, arm["a"])
    errors = []
    scales = (0.05, 0.5)  # forces 0.05–0.5 N, moments 0.005–0.05 N·m
    for s in scales:
        w = s * direction
        res = solve(arm, w)
        assert res.converged and res.residual <= 1e-12 and not res.contact_opened
        err = rel(res.deflection, C @ w)
        assert err < 1e-2, f"load {s}: {err:.2e}"
        errors.append(err)
    # first-order theory: the relative error grows linearly with the load
    ratio = errors[1] / errors[0]
    assert 0.7 * 10 < ratio < 1.3 * 10, ratio


def test_zero_wrench_keeps_q0_and_reports_preload(arm: dict) -> None:
    res = solve(arm, np.zeros(6), preload=0.3)
    np.testing.assert_allclose(res.q, Q0, atol=1e-14)
    np.testing.assert_allclose(res.deflection, 0.0, atol=1e-14)
    assert res.contact_force == pytest.approx(0.3, abs=1e-12)


def test_equilibrium_residuals_hold(arm: dict) -> None:
    """Check the returned q against the equilibrium equations, independently of the solver."""
    model, w, P = arm["model"], np.array([-0.2, 0.1, -0.3, 0.01, 0.02, -0.01]), 0.2
    res = solve(arm, w, preload=P)
    rest = Q0 - arm["a"] * P / K
    data = model.createData()
    pin.computeJointJacobians(model, data, res.q)
    pin.updateFramePlacements(model, data)
    Je = pin.getFrameJacobian(model, data, arm["e"], LWA)
    Jb = pin.getFrameJacobian(model, data, arm["b"], LWA)[:3]
    torque = K * (res.q - rest) - Je.T @ w - Jb.T @ NORMAL * res.contact_force
    assert np.abs(torque / K).max() < 1e-12
    assert abs(NORMAL @ (data.oMf[arm["b"]].translation - arm["point"])) < 1e-12
    assert res.contact_force > P  # this load presses


# ---------------------------------------------------------------------------------------------- (d)
def test_pulling_load_opens_a_unilateral_contact(arm: dict) -> None:
    w = np.array([0.0, 0.0, 5.0, 0.0, 0.0, 0.0])  # lifts b off the plane
    bil = solve(arm, w, preload=0.5)
    assert bil.contact_force < 0.0 and not bil.contact_opened
    uni = solve(arm, w, preload=0.5, bilateral=False)
    assert uni.contact_opened and uni.contact_force == 0.0
    model, data = arm["model"], arm["model"].createData()
    pin.framesForwardKinematics(model, data, uni.q)
    assert NORMAL @ (data.oMf[arm["b"]].translation - arm["point"]) > 0.0  # b left the plane
    # small pull below the preload: the contact holds
    held = solve(arm, 0.01 * w, preload=0.5, bilateral=False)
    assert not held.contact_opened and 0.0 < held.contact_force < 0.5


def test_free_solution_matches_free_compliance_to_first_order(arm: dict) -> None:
    w = np.array([0.0, 0.0, 0.05, 0.0, 0.0, 0.0])
    res = solve(arm, w, preload=0.0, bilateral=False)  # any pull opens a contact without preload
    assert res.contact_opened
    C_free = arm["Je"] @ np.diag(1.0 / K) @ arm["Je"].T
    assert rel(res.deflection, C_free @ w) < 1e-2


def test_non_convergence_raises(arm: dict) -> None:
    with pytest.raises(StaticSolveError, match="did not converge"):
        solve(arm, np.array([0.5, 0, 0, 0, 0, 0]), max_iter=1)


def test_contact_without_load_path_raises(arm: dict) -> None:
    model = arm["model"]
    fid = model.getFrameId("on_axis")
    data = model.createData()
    pin.framesForwardKinematics(model, data, Q0)
    with pytest.raises(StaticSolveError, match="carries no load"):
        solve_static_equilibrium(
            model, Q0, K, fid, arm["e"], data.oMf[fid].translation, np.array([0.0, 0.0, 1.0]), np.ones(6)
        )


def test_bad_inputs(arm: dict) -> None:
    with pytest.raises(ValueError, match="not on the surface"):
        solve_static_equilibrium(
            arm["model"], Q0, K, arm["b"], arm["e"], arm["point"] + 0.01 * NORMAL, NORMAL, np.zeros(6)
        )
    with pytest.raises(ValueError, match="unit"):
        solve_static_equilibrium(arm["model"], Q0, K, arm["b"], arm["e"], arm["point"], 2 * NORMAL, np.zeros(6))
    with pytest.raises(ValueError, match="preload"):
        solve(arm, np.zeros(6), preload=-1.0)
    with pytest.raises(ValueError, match="stiffness"):
        solve_static_equilibrium(arm["model"], Q0, -K, arm["b"], arm["e"], arm["point"], NORMAL, np.zeros(6))


# ------------------------------------------------------------------------- gravity, base wrench, penalty contact
T1 = np.cross(NORMAL, [1.0, 0.0, 0.0]) / np.linalg.norm(np.cross(NORMAL, [1.0, 0.0, 0.0]))
T2 = np.cross(NORMAL, T1)
Z3 = np.zeros(3)
SOFT_FINGER_X = np.array([np.r_[T1, Z3], np.r_[T2, Z3], np.r_[NORMAL, Z3], np.r_[Z3, NORMAL]]).T
W0 = np.array([1.5, -0.5, -2.0, 0.2, -0.1, 0.15])


def loaded_residual(arm: dict, q: np.ndarray, rest: np.ndarray, w: np.ndarray, fc: np.ndarray) -> np.ndarray:
    """K (q − rest) + g(q) − J_eᵀ w − J_bᵀ f_c, scaled by 1/K (rad), from Pinocchio's own routines."""
    model, data = arm["model"], arm["model"].createData()
    Je = pin.computeFrameJacobian(model, data, q, arm["e"], LWA)
    Jb = pin.computeFrameJacobian(model, data, q, arm["b"], LWA)
    g = pin.computeGeneralizedGravity(model, data, q)
    return (K * (q - rest) + g - Je.T @ w - Jb.T @ fc) / K


def test_zero_wrench_keeps_q0_under_gravity_base_wrench_and_preload(arm: dict) -> None:
    kw = {"gravity": True, "base_wrench": W0, "environment_stiffness": 3e3, "constraint_wrenches": SOFT_FINGER_X}
    res = solve(arm, np.zeros(6), preload=2.0, **kw)
    np.testing.assert_allclose(res.q, Q0, atol=1e-14)
    np.testing.assert_allclose(res.contact_wrench, np.r_[2.0 * NORMAL, Z3], atol=1e-12)
    assert res.contact_force == pytest.approx(2.0, abs=1e-12)
    rest = preload_rest_configuration(
        arm["model"], Q0, K, arm["b"], NORMAL, 2.0, gravity=True, tip_frame_id=arm["e"], base_wrench=W0
    )
    assert np.abs(loaded_residual(arm, Q0, rest, W0, np.r_[2.0 * NORMAL, Z3])).max() < 1e-14
    assert np.abs(rest - Q0).max() > 1e-2  # gravity and the base wrench do move the set points


@pytest.mark.parametrize("k_env", [None, 3e3])
def test_equilibrium_with_gravity_friction_and_penalty_holds(arm: dict, k_env: float | None) -> None:
    """The returned q and contact wrench satisfy the equilibrium and the contact law, checked independently."""
    P, w = 2.0, np.array([-0.4, 0.3, -0.6, 0.03, 0.05, -0.02])
    kw = {"gravity": True, "base_wrench": W0, "environment_stiffness": k_env, "constraint_wrenches": SOFT_FINGER_X}
    res = solve(arm, w, preload=P, **kw)
    assert res.converged and res.residual <= 1e-12
    model, data = arm["model"], arm["model"].createData()
    pin.computeJointJacobians(model, data, Q0)
    g0 = pin.computeGeneralizedGravity(model, data, Q0)
    Je0 = pin.computeFrameJacobian(model, data, Q0, arm["e"], LWA)
    Jb0 = pin.computeFrameJacobian(model, data, Q0, arm["b"], LWA)
    rest = Q0 + (g0 - Je0.T @ W0 - Jb0.T @ np.r_[P * NORMAL, Z3]) / K
    assert np.abs(loaded_residual(arm, res.q, rest, W0 + w, res.contact_wrench)).max() < 1e-11
    # the contact law: φ(q) = Xᵀ [p_b − p_b0; log3(R_b R_b0ᵀ)] is 0 (rigid) or (λ0 − λ)/k_env (penalty)
    pin.framesForwardKinematics(model, data, Q0)
    M0 = data.oMf[arm["b"]].copy()
    pin.framesForwardKinematics(model, data, res.q)
    M1 = data.oMf[arm["b"]]
    phi = SOFT_FINGER_X.T @ np.r_[M1.translation - M0.translation, pin.log3(M1.rotation @ M0.rotation.T)]
    lam = SOFT_FINGER_X.T @ res.contact_wrench  # X has orthonormal columns
    expected = np.zeros(4) if k_env is None else (np.array([0, 0, P, 0]) - lam) / k_env
    np.testing.assert_allclose(phi, expected, rtol=0, atol=1e-12)
    if k_env is not None:
        assert np.abs(phi).max() > 1e-6  # a penalty contact does deflect
    assert np.abs(res.deflection).max() > 1e-4


def test_gravity_changes_the_deflection_by_its_geometric_stiffness(arm: dict) -> None:
    """With gravity balanced by the set points the response to w changes only through ∂g/∂q: small but not zero."""
    w = 0.05 * DIRECTIONS[2]
    plain, heavy = solve(arm, w), solve(arm, w, gravity=True)
    diff = rel(heavy.deflection, plain.deflection)
    assert 1e-4 < diff < 0.5


def test_free_chain_solve(arm: dict) -> None:
    w = np.array([0.0, 0.0, 0.05, 0.0, 0.0, 0.0])
    res = solve(arm, w, contact=False, gravity=True)
    assert not res.contact_opened and res.contact_force == 0.0
    model, data = arm["model"], arm["model"].createData()
    rest = Q0 + pin.computeGeneralizedGravity(model, data, Q0) / K
    assert np.abs(loaded_residual(arm, res.q, rest, w, np.zeros(6))).max() < 1e-12
    with pytest.raises(ValueError, match="free chain"):
        solve(arm, w, contact=False, preload=1.0)


def test_bad_loaded_options(arm: dict) -> None:
    with pytest.raises(ValueError, match="normal force"):
        solve(arm, np.zeros(6), constraint_wrenches=np.r_[T1, Z3][:, None])
    with pytest.raises(ValueError, match="6×c"):
        solve(arm, np.zeros(6), constraint_wrenches=np.ones((5, 2)))
    with pytest.raises(ValueError, match="environment_stiffness"):
        solve(arm, np.zeros(6), environment_stiffness=-1.0)
    with pytest.raises(ValueError, match="base_wrench"):
        solve(arm, np.zeros(6), base_wrench=np.ones(3))
