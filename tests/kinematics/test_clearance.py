"""Tests of the link capsules (bracekit.model.geometry) and the link clearance (bracekit.kinematics.clearance).

References: capsules read off the URDF text by hand, the plane distance of end points placed by an independent
Pinocchio model, and central finite differences of the clearance.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from bracekit.contact import Brace, Surface
from bracekit.errors import InputError, ModelError
from bracekit.kinematics import BracedRobot
from bracekit.kinematics.clearance import Clearance, link_clearance, link_clearance_gradient
from bracekit.model.geometry import DEFAULT_LINK_RADIUS
from bracekit.model.robot import Robot
from bracekit.model.shipped import load_model
from bracekit.objective import central_difference
from helpers import random_chain_urdf


def _with_collisions(text: str) -> str:
    """The random chain with a cylinder on l1, a sphere and a mesh on l2, a box on l3 (l4.. keep defaults)."""
    geometry = {
        "l1": '<collision><origin xyz="0.1 0 0" rpy="0 1.5707963267948966 0"/>'
        '<geometry><cylinder radius="0.03" length="0.2"/></geometry></collision>',
        "l2": '<collision><origin xyz="0 0.05 0"/><geometry><sphere radius="0.06"/></geometry></collision>'
        '<collision><geometry><mesh filename="package://none/l2.stl"/></geometry></collision>',
        "l3": '<collision><geometry><box size="0.02 0.3 0.04"/></geometry></collision>',
        "l4": '<collision><geometry><mesh filename="package://none/l4.stl"/></geometry></collision>',
    }
    for link, xml in geometry.items():
        text = text.replace(f'<link name="{link}"><inertial>', f'<link name="{link}">{xml}<inertial>')
    return text


def test_capsules_come_from_cylinders_spheres_boxes_and_default_for_meshes_and_bare_links() -> None:
    robot = Robot.from_urdf(_with_collisions(random_chain_urdf(5, seed=3)), tip="tip")
    caps = {c.link: c for c in robot.link_capsules()}
    cyl = caps["l1"]  # along the x axis of l1 (z turned by +90° about y), centred at x = 0.1
    np.testing.assert_allclose(sorted([cyl.a[0], cyl.b[0]]), [0.0, 0.2], atol=1e-12)
    np.testing.assert_allclose([cyl.a[1:], cyl.b[1:]], 0.0, atol=1e-12)
    assert cyl.radius == 0.03
    sphere = caps["l2"]  # the mesh of l2 is not read
    np.testing.assert_allclose([sphere.a, sphere.b], [[0, 0.05, 0]] * 2, atol=1e-12)
    assert sphere.radius == 0.06
    box = caps["l3"]  # the bounding capsule along the 0.3 m edge, radius the half-diagonal of 0.02 × 0.04
    np.testing.assert_allclose([box.a, box.b], [[0, -0.15, 0], [0, 0.15, 0]], atol=1e-12)
    assert box.radius == pytest.approx(np.hypot(0.01, 0.02))
    default = caps["j4"]  # only a mesh: the default capsule from joint 4 to joint 5
    np.testing.assert_allclose(default.b, robot.model.jointPlacements[5].translation)
    assert default.radius == DEFAULT_LINK_RADIUS
    np.testing.assert_allclose(caps["j5"].b, [0.1, 0.02, 0.03])  # the last joint's default capsule ends at the tip
    assert len(robot.with_stiffness(100.0).link_capsules(0.01)) == 5


def test_the_paper_robot_has_default_capsules_and_bad_inputs_are_refused() -> None:
    robot = load_model("paper-robot")
    assert robot.collisions == ()
    assert {c.radius for c in robot.link_capsules()} == {DEFAULT_LINK_RADIUS}
    with pytest.raises(InputError, match="link_radius"):
        robot.link_capsules(-1.0)
    bad = _with_collisions(random_chain_urdf(5, seed=3)).replace('radius="0.06"', 'radius="wide"')
    with pytest.raises(ModelError, match="collision"):
        Robot.from_urdf(bad, tip="tip")


def _braced(region: float | None, centre: tuple[float, float] = (0.0, 0.0)) -> BracedRobot:
    text = random_chain_urdf(6, seed=11, brace_link=3)
    robot = Robot.from_urdf(_with_collisions(text), tip="tip")
    return BracedRobot(robot, Brace("brace", Surface([*centre, -0.2], [0.0, 0.0, 1.0]), region_radius=region))


@pytest.mark.parametrize("seed", range(5))
def test_clearance_is_the_lowest_capsule_end_over_the_plane_and_its_gradient_matches_finite_differences(seed) -> None:
    braced = _braced(None)
    q = np.random.default_rng(seed).uniform(-2.0, 2.0, braced.n)
    state = braced.state(q)
    value, link = link_clearance(state)
    model, data = braced.robot.model, braced.robot.model.createData()
    pin.forwardKinematics(model, data, q)
    skip = model.frames[braced.brace_id].parentJoint
    expected = min(
        (data.oMi[c.joint].act(end)[2] + 0.2 - c.radius, c.joint - 1)
        for c in braced.robot.link_capsules()
        if c.joint != skip
        for end in (c.a, c.b)
    )
    assert value == pytest.approx(expected[0], abs=1e-12)
    assert link == expected[1]
    fd = central_difference(lambda x: link_clearance(braced.state(x))[0], q, 1e-6)
    np.testing.assert_allclose(link_clearance_gradient(state), fd, atol=1e-7)
    clearance = Clearance(braced)
    for d in clearance.links(q):
        fd = central_difference(lambda x, j=d.joint: {e.joint: e.clearance for e in clearance.links(x, False)}[j], q)
        np.testing.assert_allclose(d.gradient, fd, atol=1e-7)


def test_the_region_limits_the_obstacle_and_the_brace_link_is_excepted() -> None:
    q = np.random.default_rng(0).uniform(-2.0, 2.0, 6)
    tiny = _braced(0.5, centre=(9.0, 9.0))  # far from the arm: no link is over the region
    assert link_clearance(tiny.state(q)) == (np.inf, -1)
    np.testing.assert_array_equal(link_clearance_gradient(tiny.state(q)), np.zeros(6))
    whole = link_clearance(_braced(None).state(q))
    assert link_clearance(_braced(50.0).state(q)) == whole
    assert all(c.joint != 3 for c in Clearance(_braced(None)).capsules)  # the brace sits on l3 (joint 3)
