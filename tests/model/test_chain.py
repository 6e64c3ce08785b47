"""ChainFK (forward kinematics without Pinocchio's Data) against Pinocchio's own algorithms."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from bracekit.model.chain import DATA_JOINT_LIMIT, ChainFK
from bracekit.model.robot import Robot
from bracekit.model.shipped import load_model
from helpers import random_chain_urdf

LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED


def _mixed_chain(n: int, seed: int) -> str:
    """A random chain with prismatic joints and axis-aligned joints among the unaligned revolute ones."""
    text = random_chain_urdf(n, seed, brace_link=n // 2)
    text = text.replace('type="revolute"', 'type="prismatic"', 3)  # j1..j3 prismatic
    return text.replace("<axis xyz=", '<axis xyz="0 1 0" was=', 2)  # j1, j2 along y: PY


@pytest.mark.parametrize(
    "model",
    [
        pin.buildModelFromXML(_mixed_chain(12, seed=4)),
        pin.buildModelFromXML(random_chain_urdf(30, seed=5, brace_link=11)),
        load_model("paper-robot").model,  # RZ/RY joints of the PUMA and the modules
    ],
    ids=["mixed", "unaligned", "paper-robot"],
)
def test_chain_fk_gives_pinocchios_placements_and_jacobians_of_every_frame(model: pin.Model) -> None:
    fk = ChainFK(model)
    data = model.createData()
    rng = np.random.default_rng(0)
    for _ in range(3):
        q = rng.uniform(-2.0, 2.0, model.nq)
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        pose = fk.pose(q)
        for f in range(len(model.frames)):
            m = fk.frame_placement(pose, f)
            np.testing.assert_allclose(m, data.oMf[f].homogeneous, rtol=0, atol=1e-12)
            jac = fk.frame_jacobian(pose, f, m[:3, 3])
            np.testing.assert_allclose(jac, pin.getFrameJacobian(model, data, f, LWA), rtol=0, atol=1e-12)


def test_frame_kinematics_of_a_long_chain_equal_pinocchios() -> None:
    n = DATA_JOINT_LIMIT + 16
    robot = Robot.from_urdf(random_chain_urdf(n, seed=8, brace_link=40), tip="tip")
    q = np.random.default_rng(1).uniform(-1.0, 1.0, n)
    ids = [robot.tip_id, robot.frame_id("brace")]
    ours = robot.frame_kinematics(q, ids)
    data = robot.model.createData()
    pin.computeJointJacobians(robot.model, data, q)
    pin.updateFramePlacements(robot.model, data)
    for f, (m, jac) in zip(ids, ours, strict=True):
        np.testing.assert_allclose(m, data.oMf[f].homogeneous, rtol=0, atol=1e-12)
        np.testing.assert_allclose(jac, pin.getFrameJacobian(robot.model, data, f, LWA), rtol=0, atol=1e-12)
