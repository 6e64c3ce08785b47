"""Tests of the collision geometry read from a URDF (bracekit.geometry.collision) and its primitives' clearance.

References: the collision elements written into the URDF by hand, the clearance of a box and of a mesh box
computed here from their corners (a box's least height over a plane is at a corner), coal's own error text
for a mesh it cannot read.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from bracekit.contact import Brace, Surface
from bracekit.errors import ContactError, ModelError
from bracekit.kinematics import BracedRobot
from bracekit.kinematics.clearance import Clearance, geometry_of
from bracekit.model.robot import Robot
from bracekit.model.shipped import load_model
from bracekit.simulation.run import run_scenario
from geometry_refs import box_triangles, write_ascii_stl
from helpers import random_chain_urdf


def _with(text: str, link: str, xml: str) -> str:
    return text.replace(f'<link name="{link}"><inertial>', f'<link name="{link}">{xml}<inertial>')


def _mesh_robot(tmp_path: Path, mesh: str = "box.stl") -> str:
    """A 5-joint chain with a mesh box (0.1 × 0.06 × 0.04 m) on l2 and a box primitive on l4."""
    write_ascii_stl(tmp_path / "box.stl", box_triangles((0.05, 0.03, 0.02)))
    text = random_chain_urdf(5, seed=3, brace_link=3)
    text = _with(text, "l2", f'<collision><geometry><mesh filename="{tmp_path / mesh}"/></geometry></collision>')
    return _with(
        text, "l4", '<collision><origin xyz="0.05 0 0"/><geometry><box size="0.2 0.05 0.03"/></geometry></collision>'
    )


def test_the_summary_says_which_geometry_the_clearance_uses(tmp_path: Path) -> None:
    paper = load_model("paper-robot")
    plane = Surface([0.0, 0.0, -1.0], [0.0, 0.0, 1.0])
    bare = BracedRobot(paper.with_point_frame("b", "link2", [0.1, 0.0, 0.0]), Brace("b", plane))
    assert geometry_of(bare) == "capsules (no collision geometry in the URDF)"
    assert paper.geometry == () and Clearance(bare).mesh is None
    panda = load_model("panda")
    assert {e.kind for e in panda.geometry} == {"cylinder"}  # primitives only: capsule fits as before
    braced_panda = BracedRobot(panda.with_point_frame("b", "panda_link5", [0.0, 0.1, 0.0]), Brace("b", plane))
    assert geometry_of(braced_panda).startswith("capsules fitted to the URDF's collision primitives")
    assert Clearance(braced_panda).mesh is None
    robot = Robot.from_urdf(_mesh_robot(tmp_path), tip="tip")
    assert [e.kind for e in robot.geometry] == ["mesh", "box"]
    braced = BracedRobot(robot, Brace("brace", plane))
    assert geometry_of(braced) == "meshes and primitives from the URDF (2 elements, coal)"


def test_a_mesh_that_cannot_be_found_or_read_is_one_error_naming_it(tmp_path: Path) -> None:
    text = _mesh_robot(tmp_path, mesh="missing.stl")
    with pytest.raises(ModelError, match=r"collision mesh .*missing\.stl not found"):
        Robot.from_urdf(text, tip="tip")
    (tmp_path / "broken.stl").write_text("solid x\n nonsense\n", encoding="utf-8")
    with pytest.raises(ModelError, match=r"cannot read the collision mesh .*broken\.stl"):
        Robot.from_urdf(_mesh_robot(tmp_path, mesh="broken.stl"), tip="tip")
    package = _mesh_robot(tmp_path).replace(str(tmp_path / "box.stl"), "package://somepkg/box.stl")
    with pytest.raises(ModelError, match=r"package://somepkg/box\.stl not found.*package_dirs"):
        Robot.from_urdf(package, tip="tip")
    (tmp_path / "somepkg").mkdir()
    write_ascii_stl(tmp_path / "somepkg" / "box.stl", box_triangles((0.05, 0.03, 0.02)))
    found = Robot.from_urdf(package, tip="tip", package_dirs=[tmp_path])
    assert found.geometry[0].source == str(tmp_path / "somepkg" / "box.stl")


@pytest.mark.parametrize("seed", range(3))
def test_a_mesh_box_and_a_box_primitive_have_their_corners_clearance_from_a_plane(tmp_path: Path, seed) -> None:
    robot = Robot.from_urdf(_mesh_robot(tmp_path), tip="tip")
    plane = Surface([0.0, 0.0, -0.3], [0.0, 0.0, 1.0])
    braced = BracedRobot(robot, Brace("brace", plane))  # the brace sits on l3: no mesh there
    q = np.random.default_rng(seed).uniform(-1.5, 1.5, robot.n)
    found = {d.joint: d.clearance for d in Clearance(braced).links(q, gradient=False)}
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, q)
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)
    for link, half, offset in (("l2", (0.05, 0.03, 0.02), 0.0), ("l4", (0.1, 0.025, 0.015), 0.05)):
        place = data.oMf[robot.frame_id(link)]
        points = (corners * half + [offset, 0.0, 0.0]) @ np.array(place.rotation).T + np.array(place.translation)
        assert found[robot.frame_joint(link)] == pytest.approx(points[:, 2].min() + 0.3, abs=1e-9)
    assert set(found) == {1, 3}  # the links with collision geometry; the others have none to count


def test_the_pad_radius_is_a_length() -> None:
    with pytest.raises(ContactError, match="pad_radius"):
        Brace("b", Surface([0.0, 0.0, 0.0], [0.0, 0.0, 1.0]), pad_radius=-0.01)


def test_a_run_summary_says_the_paper_robot_uses_capsules(short_scenario_file: Path) -> None:
    result = run_scenario(short_scenario_file, both_models=False)
    assert result.summary["geometry"] == "capsules (no collision geometry in the URDF)"
