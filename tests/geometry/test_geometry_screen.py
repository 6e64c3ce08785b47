"""Tests of the broad phase of the mesh clearance (bracekit.geometry._screen, through MeshClearance).

References: coal's distance of every (piece, obstacle) pair with no broad phase at all (the full computation the
bounds prune), with a piece that reaches into the post's solid taken at the deepest point of its hull (the
module's rule for penetration: SciPy's SLSQP on the surface's signed distance over the hull, written out in
geometry_refs); and the STL vertices placed by Pinocchio (a brute-force distance within the mesh resolution).
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest
from test_geometry_distance import MESH_TOLERANCE, POST, Q0, _braced

from bracekit.geometry.distance import MeshClearance
from bracekit.kinematics.clearance import Clearance
from bracekit.objective import central_difference
from geometry_refs import deepest_in_solid, read_stl, solid_distance, xarm7


def _below(world: np.ndarray, centre: np.ndarray, normal: np.ndarray) -> float:
    """A lower bound of max(h, ρ − r_max) over the hull of the points `world` (k, 3): for any α ∈ [0, 1] and
    horizontal unit ŵ, max(h, ρ − r_max) ≥ α h + (1 − α)(ŵᵀx − r_max), linear, so least at a point; ŵ toward
    the points' mean, α on a grid of tenths."""
    rel = world - centre
    h = rel @ normal
    flat = rel - np.outer(h, normal)
    mean = flat.mean(axis=0)
    w = mean / np.linalg.norm(mean) if np.linalg.norm(mean) > 0.0 else np.zeros(3)
    side = flat @ w - POST
    return max(float(np.min(a * h + (1.0 - a) * side)) for a in np.linspace(0.0, 1.0, 11))


def _full(mesh: MeshClearance, q: np.ndarray) -> dict[int, float]:
    """Each link's least value over every pair, coal's for every pair but those reaching into the post.

    A piece reaching in is solved (SLSQP) unless its depth cannot beat its link's least value (:func:`_below`).
    """
    robot = mesh.braced.robot
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, q)
    surface = mesh.braced.brace.surface
    out: dict[int, float] = {}
    inside: list[tuple[float, int, np.ndarray]] = []
    for k, piece in enumerate(mesh.pieces):
        frame = robot.model.getFrameId(robot.model.names[piece.joint], pin.FrameType.JOINT)
        place = np.array(data.oMf[frame].homogeneous)
        value = math.inf
        joint = piece.joint - 1
        for o, solid in enumerate(mesh.obstacles):
            pair = mesh._pair(k, o, place)[0]
            if piece.points is not None and solid.plane is not None:
                world = piece.points @ place[:3, :3].T + place[:3, 3]
                corner = float(solid_distance(world, surface.point, surface.normal, POST).min())
                if corner <= 0.0 or pair <= 0.0:
                    inside.append((_below(world, surface.point, surface.normal), joint, world))
                    pair = min(corner, 0.0)  # a point of the piece at least this deep
            value = min(value, pair)
        out[joint] = min(out.get(joint, math.inf), value)
    for low, joint, world in sorted(inside, key=lambda e: e[0]):
        if low < out[joint]:
            out[joint] = min(out[joint], deepest_in_solid(world, surface.point, surface.normal, POST, starts=2))
    return out


@pytest.fixture(scope="module")
def robot():
    return xarm7()


@pytest.mark.parametrize(("tilt", "lift"), [(0.05, 0.0), (-0.4, 0.0), (0.1, 0.03)])
def test_the_bounded_clearance_equals_coal_over_every_pair(robot, tilt, lift) -> None:
    clearance = Clearance(_braced(robot, tilt=tilt, lift=lift))
    mesh = clearance.mesh
    assert mesh is not None
    rng = np.random.default_rng(11)
    for q in [Q0, *(Q0 + rng.uniform(-0.3, 0.3, 7) for _ in range(5))]:
        full = _full(mesh, q)
        found = {d.joint: d.clearance for d in clearance.links(q, gradient=False)}
        assert found == pytest.approx(full, abs=1e-8)  # GJK's tolerance
        near = {d.joint: d.clearance for d in clearance.links(q, gradient=False, below=0.05)}
        assert near == pytest.approx({j: v for j, v in full.items() if v < 0.05}, abs=1e-8)
        value, joint = clearance.minimum(q)
        assert value == pytest.approx(min(full.values()), abs=1e-8)
        assert full[joint] == pytest.approx(value, abs=1e-8)


def test_the_bounded_clearance_equals_the_stl_vertices(robot) -> None:
    """Every link near the post within the mesh resolution of its STL vertices (the pad's ball left out)."""
    braced = _braced(robot, tilt=0.1, lift=0.01)
    clearance = Clearance(braced)
    meshes = {e.link: read_stl(e.source).reshape(-1, 3) for e in robot.geometry if e.joint > 0}
    rng = np.random.default_rng(12)
    data = braced.robot.model.createData()
    surface = braced.brace.surface
    count = 0
    for q in [Q0 + rng.uniform(-0.3, 0.3, 7) for _ in range(8)]:
        pin.framesForwardKinematics(braced.robot.model, data, q)
        pad = np.array(data.oMf[braced.brace_id].translation)
        found = {d.joint: d.clearance for d in clearance.links(q, gradient=False, below=0.1)}
        for link, verts in meshes.items():
            place = data.oMf[braced.robot.frame_id(link)]
            points = verts @ np.array(place.rotation).T + np.array(place.translation)
            if link == "link4":
                points = points[np.linalg.norm(points - pad, axis=1) >= braced.brace.pad_radius]
            brute = float(solid_distance(points, surface.point, surface.normal, POST).min())
            joint = braced.robot.frame_joint(link)
            if brute < 0.09:
                count += 1
                assert found[joint] == pytest.approx(brute, abs=MESH_TOLERANCE), (link, q)
                if brute > 0.0:  # the vertices are points of the mesh: its distance is at most theirs
                    assert found[joint] <= brute + 1e-8
    assert count > 10


@pytest.mark.parametrize(("tilt", "lift"), [(-0.4, 0.0), (0.1, 0.03)])
def test_the_gradient_inside_the_post_matches_central_differences(robot, tilt, lift) -> None:
    """A link inside the post: ∂/∂q of its deepest point's depth (the multipliers' direction) against the value."""
    clearance = Clearance(_braced(robot, tilt=tilt, lift=lift))
    rng = np.random.default_rng(3)
    inside = 0
    for q in [Q0, *(Q0 + rng.uniform(-0.05, 0.05, 7) for _ in range(3))]:
        for d in clearance.links(q):
            if d.clearance >= 0.0:
                continue
            inside += 1
            fd = central_difference(
                lambda x, j=d.joint: {e.joint: e.clearance for e in clearance.links(x, False)}[j], q, 1e-6
            )
            np.testing.assert_allclose(d.gradient, fd, atol=1e-5)
    assert inside >= 4
