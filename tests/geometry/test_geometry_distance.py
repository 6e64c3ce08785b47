"""Tests of coal's link clearance (bracekit.geometry.distance) on the xArm7's STL meshes.

References: the STL triangles read without coal (geometry_refs.read_stl), placed by Pinocchio's frame
placements of the link frames, the signed distance of their vertices and of points 3 mm apart on their faces
from the surface's solid written out in the test (a brute-force distance: the vertices alone are an upper
bound of the mesh's distance; with the faces' points it is the mesh's within the pitch); central finite
differences of the clearance for its gradient.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from bracekit.contact import Brace, Surface
from bracekit.geometry.pad import pad_on_surface
from bracekit.kinematics import BracedRobot
from bracekit.kinematics.clearance import Clearance, geometry_of, link_clearance, link_clearance_gradient
from bracekit.model.robot import Robot
from bracekit.objective import central_difference
from bracekit.spatial import rotation_with_z
from geometry_refs import read_stl, solid_distance, surface_points, xarm7

#: The start of the xArm7 runs here: the forearm (link4) laid across a post.
Q0 = np.array([0.0, 0.3, 0.0, 0.8, 0.0, 0.5, 0.0])
#: The post's radius (m).
POST = 0.12
#: Agreement with the STL vertices (m): the meshes' resolution.
MESH_TOLERANCE = 5e-3


def _braced(robot: Robot, tilt: float = 0.05, lift: float = 0.0, pad_radius: float = 0.02) -> BracedRobot:
    """The xArm7 braced at link4 (fraction 0.3, angle 90° of its surface) on a post under the pad at Q0.

    `tilt` turns the post's top about a horizontal axis (the forearm then touches it only at the pad);
    `lift` raises it along its normal (m; the forearm then dips into it).
    """
    pad = pad_on_surface(robot, "link4", 0.3, 90.0)
    braced_robot = robot.with_point_frame("brace", "link4", pad.point, rotation_with_z(pad.axis, "pad"))
    data = braced_robot.model.createData()
    pin.framesForwardKinematics(braced_robot.model, data, Q0)
    place = data.oMf[braced_robot.frame_id("brace")]
    axis = np.array(place.rotation[:, 2])
    normal = axis + tilt * np.cross(axis, [0.0, 0.0, 1.0])
    normal /= np.linalg.norm(normal)
    surface = Surface(np.array(place.translation) + lift * normal, normal)
    brace = Brace("brace", surface, region_radius=0.1, surface_radius=POST, pad_radius=pad_radius)
    return BracedRobot(braced_robot, brace)


def _reference(
    braced: BracedRobot, q: np.ndarray, meshes: dict[str, np.ndarray], near: dict[int, float] | None = None
) -> dict[int, float]:
    """Each link's least signed point distance from the post (the braced link without the pad's ball).

    With `near` (an upper bound per link), only the links whose bound is below 0.12 m.
    """
    robot = braced.robot
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, q)
    pad = np.array(data.oMf[braced.brace_id].translation)
    surface = braced.brace.surface
    out = {}
    for link, tri in meshes.items():
        if near is not None and near[robot.frame_joint(link)] >= 0.12:
            continue
        place = data.oMf[robot.frame_id(link)]
        points = tri @ np.array(place.rotation).T + np.array(place.translation)
        if link == "link4":
            points = points[np.linalg.norm(points - pad, axis=1) >= braced.brace.pad_radius]
        out[robot.frame_joint(link)] = float(solid_distance(points, surface.point, surface.normal, POST).min())
    return out


@pytest.fixture(scope="module")
def robot() -> Robot:
    return xarm7()


@pytest.fixture(scope="module")
def meshes(robot: Robot) -> dict[str, np.ndarray]:
    """Each link's STL vertices (k, 3)."""
    return {e.link: read_stl(e.source).reshape(-1, 3) for e in robot.geometry if e.joint > 0}


@pytest.fixture(scope="module")
def surfaces(robot: Robot) -> dict[str, np.ndarray]:
    """Each link's STL vertices and points 3 mm apart on its faces (k, 3)."""
    return {e.link: surface_points(read_stl(e.source), 0.003) for e in robot.geometry if e.joint > 0}


def test_the_summary_names_the_geometry(robot: Robot) -> None:
    assert len([e for e in robot.geometry if e.kind == "mesh"]) == 8  # the base and the seven links
    assert geometry_of(_braced(robot)) == "meshes and primitives from the URDF (7 elements, coal)"
    assert Clearance(_braced(robot)).mesh is not None


@pytest.mark.parametrize("lift", [0.0, 0.03])
def test_every_link_clearance_equals_the_stl_surface_within_the_mesh_resolution(robot, meshes, surfaces, lift) -> None:
    braced = _braced(robot, lift=lift)
    clearance = Clearance(braced)
    rng = np.random.default_rng(4)
    count = 0
    for q in [Q0, *(Q0 + rng.uniform(-0.25, 0.25, 7) for _ in range(10))]:
        found = {d.joint: d.clearance for d in clearance.links(q, gradient=False)}
        corners = _reference(braced, q, meshes)
        brute = _reference(braced, q, surfaces, corners)
        assert set(found) == set(corners)  # every link, the braced link (joint 3) included
        for joint, value in found.items():
            if joint in brute and brute[joint] < 0.1:  # the links near the post
                count += 1
                assert value == pytest.approx(brute[joint], abs=MESH_TOLERANCE), (joint, q)
                if corners[joint] > 0.0:  # vertices are points of the mesh: its distance is at most theirs
                    assert value <= corners[joint] + 1e-8  # (GJK's tolerance)
        value, joint = link_clearance(braced.state(q))
        assert (value, joint) == min((v, j) for j, v in found.items())
    assert count > 20


def test_a_link_inside_the_post_has_a_negative_clearance_its_deepest_vertex(robot, meshes) -> None:
    braced = _braced(robot, lift=0.03)  # the post's top 3 cm above the pad: the forearm dips into it
    found = {d.joint: d.clearance for d in Clearance(braced).links(Q0, gradient=False)}
    brute = _reference(braced, Q0, meshes)  # the deepest vertex
    assert found[3] < -0.02 and brute[3] < -0.02
    assert found[3] == pytest.approx(brute[3], abs=MESH_TOLERANCE)


def test_the_braced_link_counts_but_for_its_pad(robot) -> None:
    lying = {d.joint: d.clearance for d in Clearance(_braced(robot, tilt=0.05)).links(Q0, gradient=False)}
    assert 0.0 <= lying[3] < 0.01  # tilted a little: only the pad touches, the rest of the forearm is near
    rolled = {d.joint: d.clearance for d in Clearance(_braced(robot, tilt=-0.4)).links(Q0, gradient=False)}
    assert rolled[3] < -0.005  # the top turned into the forearm beside the pad: the forearm is inside
    bare = {d.joint: d.clearance for d in Clearance(_braced(robot, pad_radius=0.0)).links(Q0, gradient=False)}
    assert -1e-3 < bare[3] <= 1e-9  # no exemption: the pad itself lies on the top (the link touches it)
    assert {j: v for j, v in bare.items() if j != 3} == pytest.approx({j: v for j, v in lying.items() if j != 3})


def test_the_clearance_gradient_matches_central_differences(robot) -> None:
    braced = _braced(robot, tilt=0.1)
    clearance = Clearance(braced)
    rng = np.random.default_rng(7)
    for q in [Q0 + rng.uniform(-0.1, 0.1, 7) for _ in range(4)]:
        for d in clearance.links(q):
            if d.clearance <= 0.0:
                continue
            fd = central_difference(
                lambda x, j=d.joint: {e.joint: e.clearance for e in clearance.links(x, False)}[j], q, 1e-5
            )
            np.testing.assert_allclose(d.gradient, fd, atol=1e-4)  # GJK's tolerance 1e-9 m over the step 1e-5
        value, _ = link_clearance(braced.state(q))
        if value > 0.0:
            fd = central_difference(lambda x: link_clearance(braced.state(x))[0], q, 1e-5)
            np.testing.assert_allclose(link_clearance_gradient(braced.state(q)), fd, atol=1e-4)


def test_two_braces_each_exempt_their_own_pad_through_the_same_clearance(robot) -> None:
    """The forearm on one post and the wrist (link6) on another, each post under its pad at Q0."""
    one = _braced(robot)
    pad = pad_on_surface(robot, "link6", 0.5, 0.0)
    both_robot = one.robot.with_point_frame("wrist", "link6", pad.point, rotation_with_z(pad.axis, "pad"))
    data = both_robot.model.createData()
    pin.framesForwardKinematics(both_robot.model, data, Q0)
    place = data.oMf[both_robot.frame_id("wrist")]
    axis = np.array(place.rotation[:, 2])
    normal = axis + 0.1 * np.cross(axis, [0.0, 1.0, 0.0])  # turned so that only the pad touches
    second = Brace("wrist", Surface(np.array(place.translation), normal), region_radius=0.03, surface_radius=0.04)
    both = BracedRobot(both_robot, [one.brace, second])
    clearance = Clearance(both)
    assert clearance.mesh is not None and len(clearance.mesh.obstacles) == 2
    found = {d.joint: d.clearance for d in clearance.links(Q0, gradient=False)}
    assert 0.0 <= found[3] < 0.01 and 0.0 <= found[5] < 0.01  # each braced link touches only at its pad
    bare = BracedRobot(both_robot, [one.brace, Brace("wrist", second.surface, region_radius=0.03, pad_radius=0.0)])
    assert {d.joint: d.clearance for d in Clearance(bare).links(Q0, gradient=False)}[5] <= 1e-9
