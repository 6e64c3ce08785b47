"""Convex pieces of the links for coal's narrow phase, each with a bounding sphere for the broad phase.

A primitive (box, cylinder, capsule, sphere) is one piece, coal's own shape. A mesh is cut into patches: its
triangles grouped by the cube of edge PATCH (m) their centre falls in, each patch's convex hull one piece (coal's
Convex with its neighbour graph, so GJK/EPA walk it exactly). The hull of a patch departs from the mesh only by
the patch's own concavity (sub-millimetre for the meshes of arms; the tests compare with the mesh vertices); a
hull of the whole link would fill its concave sides and, on the braced link, the pad's hole.

The braced link: its pad touches the surface by design, so its surface within the pad radius of the pad is left
out (:func:`clip_surface`): its elements as triangles (meshes as they are, primitives tessellated), the
triangles near the pad subdivided to half the pad radius and those touching the pad ball dropped. Triangles
within two pad radii plus a patch of the pad stay single triangles (a patch's hull could reach into the hole);
the rest are patched.

Each piece keeps its extreme points (the hull's vertices, a triangle's corners): a linear height takes its least
value over the piece at one of them (:mod:`bracekit.geometry.distance` uses that).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, cast

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
REFINE = 0.5


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
        points: a polytope's extreme points (k, 3) in the joint's frame, m (a patch's hull vertices, a
            triangle's corners); None for a primitive.
        faces: the mesh triangles (t, 3, 3) the polytope was made of, joint frame, m; None for a primitive.
    """

    joint: int
    link: str
    shape: Any
    placement: Array
    centre: Array
    radius: float
    points: Array | None = None
    faces: Array | None = None


def _vec3s(points: Array) -> Any:
    out = coal.StdVec_Vec3s()
    for p in points:
        out.append(np.asarray(p, dtype=float))
    return out


def hull(points: Array, link: str) -> Any:
    """Coal's Convex of the convex hull of points (k, 3), m (flat sets too: qhull joggles them).

    Built from SciPy's qhull facets (coal's own qhull call does not take flat sets); ModelError for fewer than
    three distinct points.
    """
    unique = np.unique(np.asarray(points, dtype=float).reshape(-1, 3), axis=0)
    if len(unique) < 3:
        raise ModelError(f"{link}: a collision mesh has fewer than three distinct vertices")
    if len(unique) == 3:
        return coal.Convex(_vec3s(unique), _face())
    try:
        found = ConvexHull(unique, qhull_options="QJ")
    except (QhullError, ValueError) as exc:
        raise ModelError(f"{link}: cannot take the convex hull of a collision mesh ({exc})") from exc
    used = np.unique(found.simplices)
    remap = np.full(len(unique), -1, dtype=np.int64)
    remap[used] = np.arange(len(used))
    faces = coal.StdVec_Triangle()
    for a, b, c in remap[found.simplices]:
        faces.append(coal.Triangle(int(a), int(b), int(c)))
    return coal.Convex(_vec3s(unique[used]), faces)


def _sphere_of(points: Array) -> tuple[Array, float]:
    centre = 0.5 * (points.min(axis=0) + points.max(axis=0))
    return centre, float(np.sqrt(np.max(np.sum((points - centre) ** 2, axis=1))))


def convex_piece(element: CollisionElement) -> Piece:
    """The one convex piece of a primitive element: coal's own shape."""
    place = element.placement
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


def _grid_sphere(r: float, n: int, half: float = 0.0) -> tuple[Array, NDArray[np.int64]]:
    """A UV sphere of radius r (n segments about z), its halves moved apart by ±half along z (a capsule)."""
    quarter = n // 4
    theta = np.concatenate([np.linspace(0.0, np.pi / 2, quarter + 1), np.linspace(np.pi / 2, np.pi, quarter + 1)])
    phi = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    tt, pp = np.meshgrid(theta, phi, indexing="ij")
    verts = r * np.stack([np.sin(tt) * np.cos(pp), np.sin(tt) * np.sin(pp), np.cos(tt)], axis=-1)
    verts[: quarter + 1, :, 2] += half  # the upper half (the equator row twice: the side between them)
    verts[quarter + 1 :, :, 2] -= half
    return verts.reshape(-1, 3), _grid_triangles(theta.size, n)


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
            verts, tris = _grid_sphere(r, n, half)
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
    return cast(Array, tri[keep])


#: Edge (m) of the cubes that cut a mesh into patches.
PATCH = 0.02
#: A patch whose points' least spread (singular value) is below this fraction of the largest is flat: its
#: triangles are pieces of their own (EPA fails on a hull without volume).
FLAT = 1e-3


def _face() -> Any:
    face = coal.StdVec_Triangle()
    face.append(coal.Triangle(0, 1, 2))
    return face


def triangle_pieces(joint: int, link: str, triangles: Array) -> list[Piece]:
    """One piece per triangle (t, 3, 3) given in the joint's frame: a coal Convex of its three corners.

    (Coal's TriangleP has no distance to a cylinder or a half-space; GJK on the three-point Convex is exact.)
    """
    eye = np.eye(4)
    face = _face()
    out = []
    for corners in triangles:
        centre, radius = _sphere_of(corners)
        shape = coal.Convex(_vec3s(corners), face)
        out.append(Piece(joint, link, shape, eye, centre, radius, corners.copy(), corners[None].copy()))
    return out


def patch_pieces(joint: int, link: str, triangles: Array) -> list[Piece]:
    """The triangles (t, 3, 3) (joint frame) as patches: one convex hull per cube of edge PATCH."""
    if len(triangles) == 0:
        return []
    cells = np.floor(triangles.mean(axis=1) / PATCH).astype(np.int64)
    _, label = np.unique(cells, axis=0, return_inverse=True)
    label = label.reshape(-1)
    order = np.argsort(label, kind="stable")
    bounds = np.flatnonzero(np.diff(label[order])) + 1
    eye = np.eye(4)
    out = []
    for group in np.split(order, bounds):
        points = extreme_points(triangles[group].reshape(-1, 3))
        spread = np.linalg.svd(points - points.mean(axis=0), compute_uv=False)
        if len(points) < 4 or spread[-1] <= FLAT * max(float(spread[0]), 1e-12):
            out.extend(triangle_pieces(joint, link, triangles[group]))  # a flat patch: GJK/EPA need volume
            continue
        centre, radius = _sphere_of(points)
        out.append(Piece(joint, link, hull(points, link), eye, centre, radius, points, triangles[group]))
    return out


def extreme_points(points: Array) -> Array:
    """The points (k, 3) that are vertices of their convex hull (all of them if they span no volume), m."""
    unique = np.unique(points, axis=0)
    if len(unique) <= 4:
        return np.asarray(unique)
    try:
        return np.asarray(unique[np.unique(ConvexHull(unique, qhull_options="QJ").vertices)])
    except (QhullError, ValueError):
        return np.asarray(unique)
