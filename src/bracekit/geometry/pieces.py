"""Convex pieces of the links for coal's narrow phase, each with a bounding sphere for the broad phase.

A link's collision element becomes one convex piece: a primitive as itself (coal's Box, Cylinder, Capsule,
Sphere) and a mesh as its convex hull (qhull through SciPy, then coal's Convex with its neighbour graph, so
GJK/EPA walk it exactly). The braced link is different: its pad touches the surface by design, so the part of
its surface within the pad radius of the pad is left out (:func:`clip_surface`). Its elements are then a
triangle soup (meshes as they are, primitives tessellated) with the triangles near the pad subdivided to a
quarter of the pad radius and those touching the pad ball dropped; every remaining triangle is a piece (coal's
three-point Convex). Triangles, not hulls: a hull of the remaining surface would close the hole again.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import coal
import numpy as np
from numpy.typing import NDArray
from scipy.spatial import ConvexHull, QhullError

from bracekit.errors import ModelError
from bracekit.geometry.collision import CollisionElement

Array = NDArray[np.float64]

#: Segments around a tessellated cylinder, capsule or sphere of the braced link (chord error r (1 − cos(π/48))).
SEGMENTS = 48
#: The triangles near the pad are subdivided until their longest edge is at most this fraction of the pad radius.
REFINE = 0.25


@dataclass(frozen=True, eq=False)
class Piece:
    """A convex piece of a link: a coal shape at a fixed pose in its joint's frame.

    Attributes:
        joint: Pinocchio index of the joint that moves it.
        link: the URDF link it belongs to.
        shape: the coal shape.
        placement: 4×4 pose of the shape in the joint's frame.
        centre: centre of its bounding sphere in the joint's frame (3,), m.
        radius: its bounding sphere's radius, m.
    """

    joint: int
    link: str
    shape: Any
    placement: Array
    centre: Array
    radius: float


def _vec3s(points: Array) -> Any:
    out = coal.StdVec_Vec3s()
    for p in points:
        out.append(np.asarray(p, dtype=float))
    return out


def hull(points: Array, link: str) -> Any:
    """Coal's convex hull of points (k, 3), m; ModelError if they span no volume."""
    try:
        found = ConvexHull(points)
    except (QhullError, ValueError) as exc:
        raise ModelError(f"link {link!r}: a collision mesh spans no volume (flat or degenerate)") from exc
    return coal.Convex.convexHull(_vec3s(points[np.unique(found.simplices)]), False, "")


def _sphere_of(points: Array) -> tuple[Array, float]:
    centre = 0.5 * (points.min(axis=0) + points.max(axis=0))
    return centre, float(np.sqrt(np.max(np.sum((points - centre) ** 2, axis=1))))


def convex_piece(element: CollisionElement) -> Piece:
    """The one convex piece of an element: a primitive as itself, a mesh as its convex hull."""
    place = element.placement
    if element.kind == "mesh":
        assert element.vertices is not None
        centre, radius = _sphere_of(element.vertices)
        shape = hull(element.vertices, element.link)
        return Piece(element.joint, element.link, shape, place, place[:3, :3] @ centre + place[:3, 3], radius)
    size = element.size
    if element.kind == "box":
        shape, radius = coal.Box(*size), 0.5 * float(np.linalg.norm(size))
    elif element.kind == "cylinder":
        shape, radius = coal.Cylinder(size[0], size[1]), float(np.hypot(size[0], size[1] / 2.0))
    elif element.kind == "capsule":
        shape, radius = coal.Capsule(size[0], size[1]), size[0] + size[1] / 2.0
    else:
        shape, radius = coal.Sphere(size[0]), size[0]
    return Piece(element.joint, element.link, shape, place, place[:3, 3].copy(), float(radius))


def _grid_sphere(r: float, n: int) -> tuple[Array, NDArray[np.int64]]:
    """A UV sphere of radius r: vertices and triangles."""
    theta = np.linspace(0.0, np.pi, n // 2 + 1)
    phi = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    tt, pp = np.meshgrid(theta, phi, indexing="ij")
    verts = r * np.stack([np.sin(tt) * np.cos(pp), np.sin(tt) * np.sin(pp), np.cos(tt)], axis=-1).reshape(-1, 3)
    return verts, _grid_triangles(theta.size, n)


def _grid_triangles(rows: int, cols: int) -> NDArray[np.int64]:
    """Triangles of a rows × cols grid wrapped around in the columns."""
    out = []
    for i in range(rows - 1):
        for j in range(cols):
            a, b = i * cols + j, i * cols + (j + 1) % cols
            c, d = a + cols, b + cols
            out += [(a, b, d), (a, d, c)]
    return np.array(out, dtype=np.int64)


def surface_triangles(element: CollisionElement) -> Array:
    """The element's surface as triangles (t, 3, 3), m, in its joint's frame (primitives tessellated)."""
    n = SEGMENTS
    if element.kind == "mesh":
        assert element.vertices is not None and element.triangles is not None
        verts, tris = element.vertices, element.triangles
    elif element.kind == "box":
        verts = 0.5 * np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * element.size
        tris = np.array(ConvexHull(verts).simplices, dtype=np.int64)
    elif element.kind == "sphere":
        verts, tris = _grid_sphere(element.size[0], n)
    else:
        r, half = element.size[0], element.size[1] / 2.0
        if element.kind == "cylinder":
            phi = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
            ring = np.stack([r * np.cos(phi), r * np.sin(phi)], axis=1)
            rims = [np.column_stack([ring, np.full(n, z)]) for z in (-half, half)]
            verts = np.vstack([*rims, [[0.0, 0.0, -half]], [[0.0, 0.0, half]]])
            side = _grid_triangles(2, n)
            caps = [(2 * n, (j + 1) % n, j) for j in range(n)] + [(2 * n + 1, n + j, n + (j + 1) % n) for j in range(n)]
            tris = np.vstack([side, np.array(caps, dtype=np.int64)])
        else:  # a capsule: a sphere split at its equator and stretched by the length
            verts, tris = _grid_sphere(r, n)
            verts = verts + np.where(verts[:, 2:3] >= 0.0, 1.0, -1.0) * np.array([0.0, 0.0, half])
    place = element.placement
    world = verts @ place[:3, :3].T + place[:3, 3]
    return np.asarray(world[tris], dtype=float)


def clip_surface(triangles: Array, pad: Array, pad_radius: float) -> Array:
    """The triangles (t, 3, 3) without the pad's neighbourhood: those within `pad_radius` (m) of `pad` removed.

    Triangles that may reach the ball are split 1-to-4 until their longest edge is at most REFINE·pad_radius;
    then every triangle with a corner in the ball is dropped. The part left out is the ball and at most one
    small triangle beyond it; a kept triangle dips into the ball by at most (REFINE/2)²/2 of the radius.
    """
    tri = np.asarray(triangles, dtype=float)
    if pad_radius <= 0.0:
        return tri
    target = REFINE * pad_radius
    for _ in range(40):
        edges = np.linalg.norm(tri - np.roll(tri, 1, axis=1), axis=2).max(axis=1)
        near = np.linalg.norm(tri - pad, axis=2).min(axis=1) - edges < pad_radius
        split = near & (edges > target)
        if not split.any():
            break
        t = tri[split]
        a, b, c = t[:, 0], t[:, 1], t[:, 2]
        ab, bc, ca = (a + b) / 2.0, (b + c) / 2.0, (c + a) / 2.0
        finer = np.concatenate(
            [np.stack(s, axis=1) for s in ((a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca))], axis=0
        )
        tri = np.concatenate([tri[~split], finer], axis=0)
    keep = np.linalg.norm(tri - pad, axis=2).min(axis=1) >= pad_radius
    return tri[keep]


def triangle_pieces(joint: int, link: str, triangles: Array) -> list[Piece]:
    """One piece per triangle (t, 3, 3) given in the joint's frame: a coal Convex of its three corners.

    (Coal's TriangleP has no distance to a cylinder or a half-space; GJK on the three-point Convex is exact.)
    """
    eye = np.eye(4)
    out = []
    face = coal.StdVec_Triangle()
    face.append(coal.Triangle(0, 1, 2))
    for corners in triangles:
        centre, radius = _sphere_of(corners)
        out.append(Piece(joint, link, coal.Convex(_vec3s(corners), face), eye, centre, radius))
    return out


#: A link with more pieces than this groups them into clusters (cubes of CLUSTER_CELL) for the broad phase.
CLUSTER_MIN = 16
#: Edge (m) of the cubes that group a link's many pieces (the braced link's triangles) for the broad phase.
CLUSTER_CELL = 0.03


def clusters(centres: Array, radii: Array) -> list[NDArray[np.intp]]:
    """Groups of pieces (indices into `centres`) for a two-level broad phase: cubes of CLUSTER_CELL, or one each."""
    if len(centres) <= CLUSTER_MIN:
        return [np.array([i], dtype=np.intp) for i in range(len(centres))]
    cells = np.floor(centres / CLUSTER_CELL).astype(np.int64)
    _, label = np.unique(cells, axis=0, return_inverse=True)
    label = label.reshape(-1)
    return [np.flatnonzero(label == k) for k in range(int(label.max()) + 1)]


def enclosing(centres: Array, radii: Array) -> tuple[Array, float]:
    """A sphere (centre (3,), radius m) enclosing the spheres (centres (k, 3), radii (k,))."""
    centre = 0.5 * (np.min(centres - radii[:, None], axis=0) + np.max(centres + radii[:, None], axis=0))
    return centre, float(np.max(np.linalg.norm(centres - centre, axis=1) + radii))
