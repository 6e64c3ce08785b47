"""Tests of bracekit.validate.mujoco_check: the MuJoCo mirror of a braced chain against the Pinocchio statics."""

from __future__ import annotations

import time
from pathlib import Path

import mujoco
import numpy as np
import pinocchio as pin
import pytest

from bracekit.validate.mujoco_check import (
    TIP_SITE,
    MujocoResult,
    MujocoValidationError,
    brace_geom_names,
    build_mujoco_model,
    mujoco_static_deflection,
)
from bracekit.validate.plane_contact import PlaneContact
from bracekit.validate.statics import solve_static_equilibrium

pytestmark = pytest.mark.slow  # MuJoCo simulations

Q0 = np.array([0.2, -0.4, 0.9, 0.3, -0.5, 0.4, 0.6, -0.2])
K = 170.0 * np.linspace(0.7, 1.3, 8)
NORMAL = np.array([0.0, 0.3, 1.0]) / np.linalg.norm([0.0, 0.3, 1.0])
PRELOAD = 0.1  # N
PAPER_URDF = Path(__file__).resolve().parents[2] / "src" / "bracekit" / "model" / "urdf" / "paper_robot.urdf"


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
    pin.framesForwardKinematics(model, data, Q0)
    return {"model": model, "b": b, "e": e, "point": data.oMf[b].translation.copy()}


def args(arm: dict) -> tuple:
    return (arm["model"], Q0, K, arm["b"], arm["e"], arm["point"], NORMAL)


def contact(arm: dict, preload: float = 0.0, point: np.ndarray | None = None) -> PlaneContact:
    return PlaneContact(arm["b"], arm["point"] if point is None else point, NORMAL, preload)


def build(arm: dict, preload: float = 0.0, **kw: object) -> str:
    return build_mujoco_model(arm["model"], Q0, K, arm["e"], [contact(arm, preload)], **kw)  # type: ignore[arg-type]


def deflect(arm: dict, w: np.ndarray, preload: float, **kw: object) -> MujocoResult:
    return mujoco_static_deflection(arm["model"], Q0, K, arm["e"], [contact(arm, preload)], w, **kw)  # type: ignore[arg-type]


def rel(x: np.ndarray, ref: np.ndarray) -> float:
    return float(np.linalg.norm(x - ref) / np.linalg.norm(ref))


# ------------------------------------------------------------------------------------------ the model
def test_mjcf_mirrors_pinocchio_kinematics(arm: dict) -> None:
    radius = 0.005
    xml = build(arm, sphere_radius=radius)
    assert '<compiler angle="radian"' in xml
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    np.testing.assert_allclose(m.qpos_spring, Q0, atol=1e-15)  # radians, unshifted without preload
    np.testing.assert_allclose(m.jnt_stiffness, K)
    assert np.all(m.dof_damping > 0) and np.all(m.opt.gravity == 0)
    site = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, TIP_SITE)
    sphere = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, brace_geom_names(0)[0])
    model, data = arm["model"], arm["model"].createData()
    rng = np.random.default_rng(1)
    for q in [Q0, *rng.uniform(-np.pi, np.pi, (4, 8))]:
        d.qpos[:] = q
        mujoco.mj_kinematics(m, d)
        pin.framesForwardKinematics(model, data, q)
        np.testing.assert_allclose(d.site_xpos[site], data.oMf[arm["e"]].translation, atol=1e-12)
        np.testing.assert_allclose(d.site_xmat[site].reshape(3, 3), data.oMf[arm["e"]].rotation, atol=1e-12)
    # at q0 the sphere touches the plane at b
    d.qpos[:] = Q0
    mujoco.mj_kinematics(m, d)
    np.testing.assert_allclose(d.geom_xpos[sphere], arm["point"] + radius * NORMAL, atol=1e-12)
    # only the sphere and the plane can collide, frictionless
    plane = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, brace_geom_names(0)[1])
    for g1 in range(m.ngeom):
        for g2 in range(g1 + 1, m.ngeom):
            collide = (m.geom_contype[g1] & m.geom_conaffinity[g2]) or (m.geom_contype[g2] & m.geom_conaffinity[g1])
            assert bool(collide) == ({g1, g2} == {sphere, plane})
    assert m.geom_condim[sphere] == 1 and m.geom_condim[plane] == 1


def test_preload_shifts_the_spring_rest(arm: dict) -> None:
    m = mujoco.MjModel.from_xml_string(build(arm, preload=0.5))
    assert np.abs(m.qpos_spring - Q0).max() > 1e-4


# ------------------------------------------------------------------------------------------------ (c)
LOADS = [
    np.array([0.2, 0.0, 0.0, 0.0, 0.0, 0.0]),
    np.array([0.0, 0.12, -0.16, 0.0, 0.0, 0.0]),
    np.array([0.0, 0.0, 0.0, 0.02, 0.0, 0.01]),
    np.array([-0.1, 0.05, -0.2, 0.005, -0.01, 0.0]),
]


@pytest.mark.parametrize("wrench", LOADS)
def test_mujoco_reproduces_nonlinear_statics(arm: dict, wrench: np.ndarray) -> None:
    ref = solve_static_equilibrium(*args(arm), wrench, preload=PRELOAD, bilateral=False)
    assert not ref.contact_opened
    t0 = time.perf_counter()
    res = deflect(arm, wrench, preload=PRELOAD)
    elapsed = time.perf_counter() - t0
    assert res.converged and not res.contact_opened
    assert elapsed < 3.0, f"settling took {elapsed:.2f} s"
    np.testing.assert_allclose(res.q_preloaded, Q0, atol=1e-9)  # q0 is the preloaded equilibrium
    assert rel(res.deflection, ref.deflection) < 1e-5
    np.testing.assert_allclose(res.q, ref.q, atol=1e-8)
    assert res.contact_force == pytest.approx(ref.contact_force, rel=1e-5)


def test_agreement_improves_with_a_smaller_sphere(arm: dict) -> None:
    """A rolling sphere constrains its centre, not b: the mismatch is proportional to the radius."""
    w = LOADS[0]
    ref = solve_static_equilibrium(*args(arm), w, preload=PRELOAD)
    big = rel(deflect(arm, w, preload=PRELOAD, sphere_radius=0.005).deflection, ref.deflection)
    small = rel(deflect(arm, w, preload=PRELOAD).deflection, ref.deflection)
    assert small < big / 10 and big < 1e-4


# ------------------------------------------------------------------------------------------------ (d)
def test_pull_beyond_preload_opens_the_contact(arm: dict) -> None:
    w = np.array([0.0, 0.0, 0.5, 0.0, 0.0, 0.0])
    ref = solve_static_equilibrium(*args(arm), w, preload=PRELOAD, bilateral=False)
    assert ref.contact_opened
    res = deflect(arm, w, preload=PRELOAD)
    assert res.contact_opened and res.contact_force == 0.0
    assert rel(res.deflection, ref.deflection) < 1e-5


def test_instability_is_reported(arm: dict) -> None:
    with pytest.raises(MujocoValidationError, match="unstable"):
        deflect(arm, np.array([1e7, 0, 0, 0, 0, 0]), preload=PRELOAD)


def test_no_settling_within_budget_is_reported(arm: dict) -> None:
    with pytest.raises(MujocoValidationError, match="did not settle"):
        deflect(arm, LOADS[0], preload=PRELOAD, max_steps=200)


def test_brace_off_the_plane_is_reported(arm: dict) -> None:
    away = arm["point"] - 0.01 * NORMAL  # plane 1 cm below b: no contact under the preload
    with pytest.raises(MujocoValidationError, match="no sphere"):
        mujoco_static_deflection(arm["model"], Q0, K, arm["e"], [contact(arm, PRELOAD, away)], LOADS[0])


# ------------------------------------------------------------------------------------ shipped robot
@pytest.mark.skipif(not PAPER_URDF.exists(), reason="paper_robot.urdf not shipped yet")
def test_paper_robot_mujoco_matches_statics() -> None:
    model = pin.buildModelFromUrdf(str(PAPER_URDF))
    if not (model.existFrame("brace") and model.existFrame("tool")) or model.nq != model.nv:
        pytest.skip("paper_robot.urdf has no brace/tool frames or non-revolute joints")
    b, e = model.getFrameId("brace"), model.getFrameId("tool")
    q = np.zeros(model.nq)
    q[: min(11, model.nq)] = [0.1, np.pi / 4, np.pi, 0.2, np.pi / 4, 0.1, 0.3, -0.6, 0.8, 0.4, -0.3][: model.nq]
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    point, normal, k = data.oMf[b].translation.copy(), np.array([0.0, 0.0, 1.0]), np.full(model.nq, 170.0)
    w = np.array([0.3, -0.2, -0.4, 0.01, 0.0, 0.02])
    ref = solve_static_equilibrium(model, q, k, b, e, point, normal, w, preload=PRELOAD)
    res = mujoco_static_deflection(model, q, k, e, [PlaneContact(b, point, normal, PRELOAD)], w)
    assert rel(res.deflection, ref.deflection) < 1e-5
