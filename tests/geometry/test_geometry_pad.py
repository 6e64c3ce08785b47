"""Tests of placing a brace on a link's collision surface (bracekit.geometry.pad).

References: the xArm7's STL triangles read without coal (geometry_refs.read_stl): the pad must lie in the
plane of one of them and inside it (barycentric coordinates), its axis along that triangle's normal, pointing
into the link; the paper robot's default capsule (radius 0.04 m about the segment between its joint origins).
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from bracekit.errors import ContactError, PadPlacementWarning
from bracekit.geometry.pad import link_axis, offset_depth, pad_by_offset, pad_on_surface
from bracekit.model.geometry import DEFAULT_LINK_RADIUS
from bracekit.model.robot import Robot
from bracekit.model.shipped import load_model
from geometry_refs import read_stl, xarm7


@pytest.fixture(scope="module")
def robot() -> Robot:
    return xarm7()


def _on_triangles(point: np.ndarray, tri: np.ndarray, tol: float = 1e-9) -> np.ndarray:
    """The unit normals of the triangles (t, 3, 3) that `point` lies on (in their plane and inside them)."""
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    normal = np.cross(b - a, c - a)
    area = np.linalg.norm(normal, axis=1)
    keep = area > 1e-14
    a, b, c, normal, area = a[keep], b[keep], c[keep], normal[keep], area[keep]
    unit = normal / area[:, None]
    height = np.einsum("ij,ij->i", point - a, unit)
    # barycentric coordinates from the sub-triangles' signed areas
    u = np.einsum("ij,ij->i", np.cross(c - b, point - b), unit) / area
    v = np.einsum("ij,ij->i", np.cross(a - c, point - c), unit) / area
    w = 1.0 - u - v
    on = (np.abs(height) < tol) & (u > -1e-9) & (v > -1e-9) & (w > -1e-9)
    return unit[on]


@pytest.mark.parametrize(("fraction", "angle"), [(0.3, 90.0), (0.2, 0.0), (0.35, 200.0), (0.25, 300.0)])
def test_a_surface_pad_lies_on_the_mesh_with_the_inward_normal(robot: Robot, fraction, angle) -> None:
    pad = pad_on_surface(robot, "link4", fraction, angle)
    mesh = read_stl(next(e.source for e in robot.geometry if e.link == "link4"))  # link frame = joint frame here
    normals = _on_triangles(pad.point, mesh)
    assert len(normals) >= 1  # on the surface
    assert np.min(np.linalg.norm(np.cross(normals, pad.axis), axis=1)) < 1e-9  # ⟂ to the surface
    assert np.linalg.norm(pad.axis) == pytest.approx(1.0) and pad.depth == 0.0
    # inward: the outermost point along −axis, so a point a little outward is off the link
    assert offset_depth(robot, "link4", pad.point - 1e-3 * pad.axis) == 0.0
    # inside by 1 mm: along the nearest axis direction the face is at most √3 mm away
    assert 1e-3 - 1e-12 <= offset_depth(robot, "link4", pad.point + 1e-3 * pad.axis) <= np.sqrt(3.0) * 1e-3
    # on the ray from the link's axis (through the surface's centroid) at `angle` about it
    o, o_next = link_axis(robot, "link4")
    z = (o_next - o) / np.linalg.norm(o_next - o)
    area = 0.5 * np.linalg.norm(np.cross(mesh[:, 1] - mesh[:, 0], mesh[:, 2] - mesh[:, 0]), axis=1)
    centroid = area @ mesh.mean(axis=1) / area.sum()
    x = np.array([1.0, 0.0, 0.0]) - z * z[0]
    x /= np.linalg.norm(x)
    out = np.cos(np.radians(angle)) * x + np.sin(np.radians(angle)) * np.cross(z, x)
    radial = (pad.point - centroid) - z * float(z @ (pad.point - centroid))
    assert float(radial @ out) > 0.0 and np.linalg.norm(np.cross(radial, out)) < 1e-9
    assert float(z @ (pad.point - o)) == pytest.approx(fraction * np.linalg.norm(o_next - o), abs=1e-9)


def test_an_offset_is_snapped_to_the_surface_and_warns_with_its_depth_inside(robot: Robot) -> None:
    pad = pad_on_surface(robot, "link4", 0.3, 90.0)
    with pytest.warns(PadPlacementWarning, match=r"lies 0\.0100 m inside the collision geometry of link 'link4'"):
        snapped = pad_by_offset(robot, "link4", pad.point + 0.01 * pad.axis, -pad.axis)
    np.testing.assert_allclose(snapped.point, pad.point, atol=1e-9)
    np.testing.assert_allclose(snapped.axis, pad.axis, atol=1e-9)
    assert snapped.depth == pytest.approx(0.01)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        outside = pad_by_offset(robot, "link4", pad.point - 0.05 * pad.axis, -pad.axis)  # outside: no warning
    np.testing.assert_allclose(outside.point, pad.point, atol=1e-9)
    assert outside.depth == 0.0
    with pytest.raises(ContactError, match="misses"):
        pad_by_offset(robot, "link4", [1.0, 1.0, 1.0], [1.0, 0.0, 0.0])


def test_a_fraction_off_the_geometry_is_refused_with_its_span(robot: Robot) -> None:
    with pytest.raises(ContactError, match=r"spans the fractions -0\.\d+ to 0\.\d+ of its axis"):
        pad_on_surface(robot, "link4", 0.9, 90.0)


def test_without_collision_geometry_the_pad_sits_on_the_default_capsule() -> None:
    robot = load_model("paper-robot")
    pad = pad_on_surface(robot, "link2", 0.5, 90.0)
    o, o_next = link_axis(robot, "link2")
    centre = o + 0.5 * (o_next - o)
    radial = pad.point - centre
    # the tessellated capsule (48 segments) is within r (1 − cos(π/48)) of the round one
    assert np.linalg.norm(radial) == pytest.approx(DEFAULT_LINK_RADIUS, abs=DEFAULT_LINK_RADIUS * 2.2e-3)
    np.testing.assert_allclose(pad.axis, -radial / np.linalg.norm(radial), atol=0.07)


def test_the_angles_about_the_forearm_near_its_wrist_give_distinct_pads(robot: Robot) -> None:
    """At fraction 0.5 the line through the surface's centroid leaves link4 (its housing bends away from it):
    the rays start from the cross-section's centroid, so each angle gives its own pad on the STL surface."""
    mesh = read_stl(next(e.source for e in robot.geometry if e.link == "link4"))
    pads = [pad_on_surface(robot, "link4", 0.5, float(a)) for a in range(0, 180, 15)]
    for pad in pads:
        assert len(_on_triangles(pad.point, mesh)) >= 1
    points = np.array([p.point for p in pads])
    gaps = np.linalg.norm(points[:, None] - points[None], axis=2)[np.triu_indices(len(points), 1)]
    assert gaps.min() > 1e-3  # no two of the twelve angles give the same pad
