"""Tests of the several-brace validation: the MuJoCo model, the stacked static solve and validate_several_braces.

References: Pinocchio's own frame Jacobians and placements (the stacked KKT residual rebuilt here), the
one-brace static solve of bracekit.validate.statics, MuJoCo against the static solve, and the stacked
constrained compliance against both.
"""

from __future__ import annotations

import mujoco
import numpy as np
import pinocchio as pin
import pytest

from bracekit.compliance.first_order import constrained_compliance
from bracekit.contact import Brace, Surface
from bracekit.errors import InputError
from bracekit.kinematics import BracedRobot
from bracekit.model.robot import Robot
from bracekit.simulation.scenario import load_scenario
from bracekit.validate.contacts import plane_contacts
from bracekit.validate.mujoco_check import brace_geom_names, build_mujoco_model, mujoco_static_deflection
from bracekit.validate.runner import DEFAULT_DIRECTIONS, ValidationReport, check_compliance, validation_configurations
from bracekit.validate.statics import (
    PlaneContact,
    contact_set_points,
    solve_static_equilibrium,
    solve_statics,
)
from helpers import random_chain_urdf, random_unit, solve_planes

pytestmark = pytest.mark.slow  # MuJoCo simulations

LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED


def braced_on_planes(robot: Robot, q: np.ndarray, frames: list[str], normals: list[np.ndarray]) -> BracedRobot:
    """Each frame braced on a plane through its position at q, with the given normal."""
    model = robot.model
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    braces = [
        Brace(f, Surface(data.oMf[model.getFrameId(f)].translation.copy(), nh))
        for f, nh in zip(frames, normals, strict=True)
    ]
    return BracedRobot(robot, braces)


@pytest.fixture(scope="module")
def paper() -> tuple[BracedRobot, np.ndarray]:
    """The paper robot at its start: {b} on a horizontal table, a point of HEBI link 9 against a wall (y)."""
    sc = load_scenario("paper")
    q = validation_configurations(sc, 1)[0]
    robot = sc.braced.robot.with_point_frame("pad", "link9", (0.0, 0.0, 0.03))
    return braced_on_planes(robot, q, ["brace", "pad"], [np.array([0.0, 0.0, 1.0]), np.array([0.0, -1.0, 0.0])]), q


def random_braced(seed: int, links: list[int]) -> tuple[BracedRobot, np.ndarray]:
    """A random 9-joint chain with a point frame on each link of `links`, braced on random planes at random q."""
    rng = np.random.default_rng(seed)
    n = 9
    robot = Robot.from_urdf(random_chain_urdf(n, seed=seed), tip="tip").with_stiffness(rng.uniform(100.0, 300.0, n))
    names = [f"p{i}" for i in range(len(links))]
    robot = robot.with_point_frames(
        [(name, f"l{link}", tuple(rng.uniform(-0.05, 0.05, 3)), None) for name, link in zip(names, links, strict=True)]
    )
    q = rng.uniform(-2.0, 2.0, n)
    return braced_on_planes(robot, q, names, [random_unit(rng) for _ in links]), q


def several(report: ValidationReport) -> dict:
    """The report as JSON, with the models it compared (``rel_err_models``)."""
    data = report.to_json()
    data["rel_err_models"] = report.models
    return data


def arguments(braced: BracedRobot) -> tuple:
    robot = braced.robot
    surfaces = [(b.surface.point, b.surface.normal) for b in braced.braces]
    return robot.model, robot.stiffness, list(braced.brace_ids), robot.tip_id, surfaces


# ------------------------------------------------------------------------------------------ MuJoCo model
def test_mujoco_model_has_a_sphere_and_plane_per_brace_each_colliding_only_with_its_own() -> None:
    braced, q = random_braced(7, [4, 6, 8])
    model, K, ids, tip, surfaces = arguments(braced)
    radius = 1e-4
    xml = build_mujoco_model(model, q, K, tip, plane_contacts(braced, [1.0, 2.0, 3.0]), sphere_radius=radius)
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    d.qpos[:] = q
    mujoco.mj_forward(m, d)
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    geoms = [
        (mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, s), mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, p))
        for s, p in (brace_geom_names(i) for i in range(3))
    ]
    for i, ((sphere, _), fid, (_, nh)) in enumerate(zip(geoms, ids, surfaces, strict=True)):
        np.testing.assert_allclose(d.geom_xpos[sphere], data.oMf[fid].translation + radius * nh, atol=1e-12)
        for j, (_, plane) in enumerate(geoms):
            collides = bool(m.geom_contype[sphere] & m.geom_conaffinity[plane]) or bool(
                m.geom_contype[plane] & m.geom_conaffinity[sphere]
            )
            assert collides == (i == j)
    # springs' rest: K (q − q_s) = Σ J_b_iᵀ [P_i n̂_i; 0], from Pinocchio's Jacobians
    pin.computeJointJacobians(model, data, q)
    tau = sum(
        pin.getFrameJacobian(model, data, fid, LWA)[:3].T @ (P * nh)
        for fid, (_, nh), P in zip(ids, surfaces, [1.0, 2.0, 3.0], strict=True)
    )
    np.testing.assert_allclose(K * (q - m.qpos_spring), tau, atol=1e-12)
    np.testing.assert_allclose(
        m.qpos_spring,
        contact_set_points(
            model, q, K, [PlaneContact(f, pt, nh, p) for f, (pt, nh), p in zip(ids, surfaces, [1, 2, 3], strict=True)]
        ),
    )


def test_mujoco_settles_with_each_contact_carrying_its_preload() -> None:
    braced, q = random_braced(5, [3, 6])
    model, K, _, tip, _ = arguments(braced)
    res = mujoco_static_deflection(model, q, K, tip, plane_contacts(braced, [1.5, 0.7]), np.zeros(6))
    np.testing.assert_allclose(res.contact_forces, [1.5, 0.7], rtol=1e-5)
    np.testing.assert_allclose(res.q_preloaded, q, atol=1e-7)
    assert res.contacts_opened == (False, False) and not res.contact_opened
    assert np.linalg.norm(res.deflection) < 1e-9


# ------------------------------------------------------------------------------------------ static solve
def test_several_brace_static_solve_satisfies_the_stacked_kkt_equations() -> None:
    braced, q = random_braced(7, [4, 6, 8])
    model, K, ids, tip, surfaces = arguments(braced)
    w = np.array([0.4, -0.3, 0.2, 0.03, -0.02, 0.04])
    res = solve_statics(model, q, K, tip, plane_contacts(braced, 2.0), w)
    data = model.createData()
    pin.computeJointJacobians(model, data, q)
    pin.updateFramePlacements(model, data)
    J_b0 = [pin.getFrameJacobian(model, data, fid, LWA) for fid in ids]
    q_s = q - sum(J[:3].T @ (2.0 * nh) for J, (_, nh) in zip(J_b0, surfaces, strict=True)) / K
    pin.computeJointJacobians(model, data, res.q)
    pin.updateFramePlacements(model, data)
    torque = K * (res.q - q_s) - pin.getFrameJacobian(model, data, tip, LWA).T @ w
    for fid, (point, nh), fc, f in zip(ids, surfaces, res.contact_wrenches, res.contact_forces, strict=True):
        np.testing.assert_allclose(fc, np.concatenate([f * nh, np.zeros(3)]), atol=1e-12)  # frictionless
        torque -= pin.getFrameJacobian(model, data, fid, LWA).T @ fc
        assert abs(nh @ (data.oMf[fid].translation - point)) < 1e-12  # b_i stays on its plane
    np.testing.assert_allclose(torque, 0.0, atol=1e-9)
    assert np.all(res.contact_forces > 0.0)


def test_several_brace_static_solve_with_one_brace_equals_the_one_brace_solve() -> None:
    braced, q = random_braced(5, [3])
    model, K, ids, tip, surfaces = arguments(braced)
    w = np.array([0.3, 0.1, -0.2, 0.0, 0.02, 0.01])
    multi = solve_planes(model, q, K, ids, tip, surfaces, w, preload=1.0)
    one = solve_static_equilibrium(model, q, K, ids[0], tip, *surfaces[0], w, preload=1.0)
    np.testing.assert_allclose(multi.q, one.q, atol=1e-12)
    np.testing.assert_allclose(multi.deflection, one.deflection, atol=1e-12)
    assert multi.contact_forces[0] == pytest.approx(one.contact_force, abs=1e-9)


def test_several_brace_static_solve_linearises_to_the_constrained_compliance() -> None:
    braced, q = random_braced(7, [4, 6, 8])
    model, K, _, tip, _ = arguments(braced)
    c_e = constrained_compliance(braced.state(q))
    for w in (np.array([1e-3, 0, 0, 0, 0, 0]), np.array([0, 0, 0, 0, 1e-4, 1e-4])):
        res = solve_statics(model, q, K, tip, plane_contacts(braced, 1e-3), w)
        assert np.linalg.norm(res.deflection - c_e @ w) < 1e-4 * np.linalg.norm(c_e @ w)


def test_several_brace_inputs_are_checked() -> None:
    braced, q = random_braced(5, [3, 6])
    model, K, ids, tip, surfaces = arguments(braced)
    off = [(surfaces[0][0] + 1e-3 * surfaces[0][1], surfaces[0][1]), surfaces[1]]
    with pytest.raises(InputError, match="brace point 0 is not on the surface"):
        solve_planes(model, q, K, ids, tip, off, np.zeros(6))
    with pytest.raises(InputError, match="preload"):
        plane_contacts(braced, [1.0, -1.0])
    friction = BracedRobot(
        braced.robot, [braced.braces[0], Brace("p1", braced.braces[1].surface, "point_with_friction")]
    )
    with pytest.raises(InputError, match="no MuJoCo model of the contact type 'point_with_friction'"):
        check_compliance(friction, [q])
    moved = braced_on_planes(braced.robot, q + 0.1, ["p0", "p1"], [b.surface.normal for b in braced.braces])
    with pytest.raises(InputError, match="from the surface"):
        check_compliance(moved, [q], mujoco=False)


# ------------------------------------------------------------------------------------------ validation
def test_paper_robot_on_a_table_and_a_wall_matches_mujoco_and_the_static_solve(
    paper: tuple[BracedRobot, np.ndarray],
) -> None:
    braced, q = paper
    report = several(check_compliance(braced, [q]))
    s = report["summary"]
    assert len(report["cases"]) == len(DEFAULT_DIRECTIONS) and report["n_failed"] == 0
    assert report["n_ok"] >= 8  # +z lifts {b} off the table by more than the 1 N preload
    assert s["constrained_vs_mujoco"]["median"] < 0.01 and s["constrained_vs_static"]["median"] < 0.01
    assert s["constrained_vs_mujoco"]["max"] < 0.01
    assert s["mujoco_vs_static"]["max"] < 1e-4
    assert "projection" not in report["rel_err_models"]  # the paper's projection model is for one brace
    for case in report["cases"]:  # the opened case is the one where the unilateral static solve opens a contact
        assert (case["status"] == "contact_opened") == case["opened_static"]
        if case["status"] == "ok":
            assert min(case["contact_forces_static"]) > 0.0 and min(case["contact_forces_mujoco"]) > 0.0


def test_paper_robot_first_order_error_vanishes_with_the_load(paper: tuple[BracedRobot, np.ndarray]) -> None:
    braced, q = paper
    small = several(check_compliance(braced, [q], force=0.05, moment=0.005, preload=0.1, mujoco=False))
    assert small["n_ok"] >= len(DEFAULT_DIRECTIONS) - 1  # +z pulls the table contact (same load-to-preload ratio)
    assert small["summary"]["constrained_vs_static"]["max"] < 1e-3


@pytest.mark.parametrize(("seed", "links"), [(5, [3, 6]), (7, [4, 6, 8])])
def test_random_chain_with_several_braces_matches_mujoco_and_the_static_solve(seed: int, links: list[int]) -> None:
    braced, q = random_braced(seed, links)
    loads = [DEFAULT_DIRECTIONS[i] for i in (0, 5, 6, 9)]
    report = several(check_compliance(braced, [q], directions=loads, preload=2.0))
    s = report["summary"]
    assert report["n_ok"] == len(loads)
    assert s["constrained_vs_mujoco"]["median"] < 0.01 and s["constrained_vs_static"]["median"] < 0.01
    assert s["mujoco_vs_static"]["max"] < 1e-4
    small = several(
        check_compliance(braced, [q], directions=loads, force=0.05, moment=0.005, preload=0.2, mujoco=False)
    )
    assert small["summary"]["constrained_vs_static"]["max"] < 1e-3
