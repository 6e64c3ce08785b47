"""Tests of bracekit.validate.mjcf: a brace on link 2 of the paper robot, whose centre of mass cannot translate.

Link 2's origin lies on the joint-1 and joint-2 axes, so MuJoCo's ``body_invweight0`` of link 2 is 0. The
references: the nonlinear static solve (MuJoCo's settled deflection), the constrained first-order model
within the validation's usual tolerance, and the settling rule itself, which must still fail on the hard,
unregularised contact a sphere on the link's own body makes.
"""

from __future__ import annotations

import re

import mujoco
import numpy as np
import pinocchio as pin
import pytest

from bracekit.simulation.scenario import load_scenario
from bracekit.validate.environment_check import run_environment_validation
from bracekit.validate.mjcf import brace_geom_names, build_mujoco_model
from bracekit.validate.mujoco_check import mujoco_static_deflection
from bracekit.validate.plane_contact import PlaneContact
from bracekit.validate.runner import run_validation
from bracekit.validate.session import MujocoSession
from bracekit.validate.statics import solve_statics
from helpers import scenario_text

pytestmark = pytest.mark.slow  # MuJoCo simulations

#: The paper scenario's start guess (rad).
Q0 = np.array([0.0, 0.194, -2.598, 0.0, -0.737, -2.498, -1.898, 3.142, 2.106, 2.438, 0.867])
MJ_MINVAL = 1e-15  # MuJoCo's floor of the regulariser R


@pytest.fixture(scope="module")
def link2() -> dict:
    """The paper robot with a frame half-way along link 2 (joint 2 → joint 3), on a horizontal plane at Q0."""
    robot = load_scenario("paper").braced.robot
    model = pin.Model(robot.model)
    offset = 0.5 * model.jointPlacements[3].translation
    fid = model.addFrame(pin.Frame("pad2", 2, 0, pin.SE3(np.eye(3), offset), pin.FrameType.OP_FRAME))
    data = model.createData()
    pin.framesForwardKinematics(model, data, Q0)
    contact = PlaneContact(fid, data.oMf[fid].translation.copy(), np.array([0.0, 0.0, 1.0]), preload=1.0)
    return {"model": model, "K": robot.stiffness, "tip": robot.tip_id, "contact": contact}


def _xml(s: dict) -> str:
    return build_mujoco_model(s["model"], Q0, s["K"], s["tip"], [s["contact"]])


def _sphere_on_the_link(xml: str) -> str:
    """The same model with the sphere on the link's own body (the sphere's massless body removed)."""
    name = brace_geom_names(0)[0]
    pattern = rf'<body name="{name}" pos="([^"]*)"><geom name="{name}" ([^>]*)/></body>'
    out, count = re.subn(pattern, rf'<geom name="{name}" pos="\1" \2/>', xml)
    assert count == 1
    return out


def test_link2_has_no_mobility_at_its_centre_of_mass_and_the_sphere_body_has(link2: dict) -> None:
    xml = _xml(link2)
    m = mujoco.MjModel.from_xml_string(xml)
    sphere = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, brace_geom_names(0)[0])
    body = int(m.geom_bodyid[sphere])
    assert m.body_invweight0[int(m.body_parentid[body]), 0] == 0.0  # link 2: the case this model must handle
    assert m.body_invweight0[body, 0] > 1e-3
    sim = MujocoSession(xml, link2["K"], Q0)
    _, settled = sim.settle_until(np.zeros(6), 20_000, 1e-11, "preload settling")
    assert settled
    assert sim.d.nefc == 1 and sim.d.efc_R[0] > 1e6 * MJ_MINVAL  # a regularised contact
    hard = MujocoSession(_sphere_on_the_link(xml), link2["K"], Q0)
    hard.settle_until(np.zeros(6), 2_000, 1e-11, "preload settling")
    assert hard.d.nefc == 0 or hard.d.efc_R[0] <= MJ_MINVAL  # the link's body: R at MuJoCo's floor


def test_the_settling_rule_still_fails_the_hard_contact(link2: dict) -> None:
    # the sphere on link 2's own body: R at the floor, the contact drops in and out, never settles
    hard = MujocoSession(_sphere_on_the_link(_xml(link2)), link2["K"], Q0)
    _, settled = hard.settle_until(np.zeros(6), 60_000, 1e-11, "preload settling")
    assert not settled
    sim = MujocoSession(_xml(link2), link2["K"], Q0)
    steps, settled = sim.settle_until(np.zeros(6), 60_000, 1e-11, "preload settling")
    assert settled and steps < 20_000


@pytest.mark.parametrize("wrench", [[0.5, 0, 0, 0, 0, 0], [0, 0, -0.5, 0, 0, 0], [0, 0, 0, 0, 0.035, 0.035]])
def test_link2_brace_settles_to_the_static_solve(link2: dict, wrench: list[float]) -> None:
    w = np.array(wrench, dtype=float)
    args = (link2["model"], Q0, link2["K"], link2["tip"], [link2["contact"]], w)
    res = mujoco_static_deflection(*args)
    ref = solve_statics(*args, bilateral=False)
    assert not res.contact_opened and not ref.contact_opened
    err = np.linalg.norm(res.deflection - ref.deflection) / np.linalg.norm(ref.deflection)
    assert err < 1e-5  # as the other braces (test_mujoco_check)
    assert abs(res.contact_force - ref.contact_force) < 1e-5 * abs(ref.contact_force)


def test_a_link2_scenario_validates(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """The paper scenario braced half-way along link 2: every case runs, C_e within 1 %, rigid and soft surface.

    The soft surface's solref is derived from the sphere body's ``body_invweight0`` (:func:`soft_contact_solref`):
    on link 2's own body it was 0, and no k_env case settled.
    """
    text = scenario_text(theta_z=0.0)
    text, n1 = re.subn(r'(?m)^frame = "brace".*$', 'link = "link2"\nframe = "pad2"\noffset = [0.2159, 0.0, 0.0]', text)
    text, n2 = re.subn(r"(?m)^point = .*$", "point = [0.21185, 0.0, 0.04162]", text, count=1)
    text, n3 = re.subn(r"theta_z = 0\.6", "theta_z = 0.0", text)
    assert (n1, n2, n3) == (1, 1, 1)
    path = tmp_path / "link2.toml"
    path.write_text(text, encoding="utf-8")
    rep = run_validation(path, configs=1)
    s = rep.summary()
    assert s["n_failed"] == 0 and s["n_ok"] >= 8
    assert s["constrained_vs_mujoco"]["median"] < 0.01  # the validation's verdict (validate.verdict)
    assert s["mujoco_vs_static"]["max"] < 1e-5
    assert abs(s["constrained_vs_mujoco"]["median"] - s["constrained_vs_static"]["median"]) < 1e-5
    env = run_environment_validation(path, configs=1)
    for row in env.rows:
        st = row.report.model_stats("constrained")
        assert row.report.counts()["failed"] == 0 and st["n_cases"] >= 5
        assert st["median_rel_err_mujoco"] < 0.01
        assert row.report.mujoco_vs_static()["max_rel_err"] < 1e-5
