"""The environment's solids as coal objects: the bracing surface with its body, and further obstacles.

The surface solid is the one of :mod:`bracekit.kinematics.clearance`: with a radius r_max
(``Brace.obstacle_radius``, a table top or a post) the disk of radius r_max about the surface's point c and the
body below it, a coal Cylinder of radius r_max whose top face is the disk and whose height reaches far below
anything the robot can touch; without a radius the half-space below the plane (coal's Halfspace). Further
obstacles are boxes, cylinders, spheres and meshes (a mesh as its convex hull) at a pose in the base frame
(a scenario's ``[[obstacle]]`` tables, :mod:`bracekit.geometry.obstacle_tables`).

Each obstacle gives a lower bound of the signed distance of a point (1-Lipschitz, ≤ the signed distance), so a
ball of radius r about a point p is at least bound(p) − r away: the broad phase of :mod:`bracekit.geometry.distance`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import coal
import numpy as np
from numpy.typing import NDArray
from scipy.spatial import ConvexHull

from bracekit.contact.surface import Surface
from bracekit.errors import InputError
from bracekit.geometry.pieces import hull

Array = NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class Obstacle:
    """A fixed solid of the environment: a coal shape at a pose of the base frame.

    Attributes:
        name: what messages call it ("surface", "box 1", …).
        shape: the coal shape (convex).
        placement: 4×4 pose of the shape in the base frame (m).
        centre, radius: its bounding sphere (m, base frame); radius inf for an unbounded solid.
        plane: for the surface: (c, n̂, r_max or None), the solid's exact description used by :meth:`bound`.
    """

    name: str
    shape: Any
    placement: Array
    centre: Array
    radius: float
    plane: tuple[Array, Array, float | None] | None = None

    @property
    def transform(self) -> Any:
        """Coal's Transform3s of the placement."""
        return coal.Transform3s(self.placement[:3, :3], self.placement[:3, 3])

    def bound(self, points: Array) -> Array:
        """A lower bound (k,) of the signed distance (m) of points (k, 3) from the solid (exact for the surface)."""
        if self.plane is None:
            return np.asarray(np.linalg.norm(points - self.centre, axis=1) - self.radius)
        return self.signed(points)[0]

    def bound_at(self, point: Array) -> float:
        """:meth:`bound` of one point (3,), m."""
        if self.plane is None:
            return float(np.linalg.norm(np.asarray(point) - self.centre)) - self.radius
        return self.signed_at(point)

    def signed(self, points: Array) -> tuple[Array, NDArray[np.bool_], Array]:
        """(Signed distance (k,), m; whether each is over the disk (k,); height h over the plane (k,), m).

        Of points (k, 3) from the surface's solid.

        Outside: |(max(ρ − r_max, 0), max(h, 0))|; inside (h ≤ 0, ρ ≤ r_max): max(h, ρ − r_max), minus the
        depth below the top or inside the side, whichever is less (the body's bottom is far below). Over the
        disk: ρ ≤ r_max (always for the half-space). Only for the surface (``plane``).
        """
        if self.plane is None:
            raise ValueError("only the surface's solid has an exact signed distance here")
        c, n, r_max = self.plane
        if r_max is None:
            h = np.asarray((points - c) @ n)
            return h, np.ones(len(points), dtype=bool), h
        local = (points - c) @ self.placement[:3, :3]  # plane coordinates (the placement's columns)
        h = local[:, 2]
        side = np.sqrt(local[:, 0] ** 2 + local[:, 1] ** 2) - r_max
        over = side <= 0.0
        outside = np.sqrt(np.maximum(side, 0.0) ** 2 + np.maximum(h, 0.0) ** 2)
        return np.where(over & (h <= 0.0), np.maximum(h, side), outside), over, h

    def signed_at(self, point: Array) -> float:
        """The signed distance (m) of one point (3,) from the surface's solid (:meth:`signed` for one point)."""
        if self.plane is None:
            raise ValueError("only the surface's solid has an exact signed distance here")
        c, n, r_max = self.plane
        x, y, h = ((np.asarray(point) - c) @ self.placement[:3, :3]).tolist()
        if r_max is None:
            return float((np.asarray(point) - c) @ n)
        side = math.hypot(x, y) - r_max
        if h <= 0.0 and side <= 0.0:
            return float(max(h, side))
        return math.hypot(max(side, 0.0), max(h, 0.0))

    def beside(self, points: Array, heads: NDArray[np.intp]) -> Array:
        """Lower bounds (m) of the distance of convex sets from the surface's solid, from their points beside it.

        `points` (k, 3) are the sets' extreme points, set i being points[heads[i]:heads[i + 1]]. The solid lies
        in the half-space {x : ûᵀ L (x − c) ≤ r_max} for any horizontal unit û; with û toward a set's mean, the
        set is at least min ûᵀ L (v − c) − r_max away over its points v (linear, so least at a point). −inf for the
        half-space below the whole plane.
        """
        if self.plane is None or self.plane[2] is None:
            return np.full(len(heads), -np.inf)
        c, _, r_max = self.plane
        local = (points - c) @ self.placement[:3, :2]  # x, y in the plane
        sizes = np.diff(np.append(heads, len(points)))
        mean = np.add.reduceat(local, heads, axis=0) / sizes[:, None]
        norm = np.linalg.norm(mean, axis=1)
        unit = np.where(norm[:, None] > 0.0, mean / np.where(norm > 0.0, norm, 1.0)[:, None], 0.0)
        along = np.einsum("ij,ij->i", local, np.repeat(unit, sizes, axis=0))
        return np.where(norm > 0.0, np.minimum.reduceat(along, heads) - r_max, -np.inf)

    def gradient(self, point: Array) -> Array:
        """∇ of the signed distance (3,), unit, at a point (3,) of the surface's solid (its outward direction)."""
        if self.plane is None:
            raise ValueError("only the surface's solid has an exact signed distance here")
        c, n, r_max = self.plane
        if r_max is None:
            return np.asarray(n, dtype=float)
        axes = self.placement[:3, :3]
        x, y, h = ((np.asarray(point) - c) @ axes).tolist()
        rho = math.hypot(x, y)
        rx, ry = (x / rho, y / rho) if rho > 0.0 else (0.0, 0.0)
        side = rho - r_max
        if h <= 0.0 and side <= 0.0:
            gx, gy, gz = (0.0, 0.0, 1.0) if h >= side else (rx, ry, 0.0)
        else:
            out_side, out_top = max(side, 0.0), max(h, 0.0)
            dist = math.hypot(out_side, out_top)
            gx, gy, gz = (out_side * rx / dist, out_side * ry / dist, out_top / dist) if dist > 0.0 else (0.0, 0.0, 1.0)
        return np.asarray(axes[:, 0] * gx + axes[:, 1] * gy + axes[:, 2] * gz)


def surface_obstacle(surface: Surface, r_max: float | None, depth: float) -> Obstacle:
    """The surface's solid: a cylinder of radius r_max and height `depth` (m) below the disk, or the half-space."""
    n, c = np.asarray(surface.normal, dtype=float), np.asarray(surface.point, dtype=float)
    if r_max is None:
        shape = coal.Halfspace(n, float(n @ c))
        return Obstacle("the surface", shape, np.eye(4), c, np.inf, (c, n, None))
    if not (np.isfinite(depth) and depth > 0.0):
        raise InputError(f"the surface body's depth must be a positive length (m), got {depth!r}")
    place = np.eye(4)
    place[:3, :3] = np.asarray(surface.frame, dtype=float)  # columns x̂_t, ŷ_t, n̂
    place[:3, 3] = c - 0.5 * depth * n
    shape = coal.Cylinder(float(r_max), float(depth))
    return Obstacle("the surface", shape, place, place[:3, 3].copy(), float(np.hypot(r_max, depth / 2)), (c, n, r_max))


def _posed(pose: Array | None) -> Array:
    place = np.eye(4) if pose is None else np.asarray(pose, dtype=float).reshape(4, 4)
    rot = place[:3, :3]
    if not (np.all(np.isfinite(place)) and np.allclose(rot.T @ rot, np.eye(3), atol=1e-9) and np.linalg.det(rot) > 0):
        raise InputError("an obstacle's pose must be a 4×4 rigid transform (rotation and translation, m)")
    return place


def box_obstacle(name: str, size: Array, pose: Array | None = None) -> Obstacle:
    """A box of edge lengths `size` (3,), m, centred at `pose` (4×4, base frame)."""
    edges = np.asarray(size, dtype=float).reshape(3)
    if not np.all(np.isfinite(edges) & (edges > 0)):
        raise InputError(f"{name}: a box needs three positive edge lengths (m), got {edges.tolist()}")
    place = _posed(pose)
    return Obstacle(name, coal.Box(*edges), place, place[:3, 3].copy(), 0.5 * float(np.linalg.norm(edges)))


def cylinder_obstacle(name: str, radius: float, length: float, pose: Array | None = None) -> Obstacle:
    """A cylinder of `radius` and `length` (m) along the z axis of `pose` (4×4, base frame), centred there."""
    if not (np.isfinite(radius) and radius > 0 and np.isfinite(length) and length > 0):
        raise InputError(f"{name}: a cylinder needs a positive radius and length (m), got {radius!r}, {length!r}")
    place = _posed(pose)
    bound = float(np.hypot(radius, length / 2.0))
    return Obstacle(name, coal.Cylinder(float(radius), float(length)), place, place[:3, 3].copy(), bound)


def sphere_obstacle(name: str, radius: float, pose: Array | None = None) -> Obstacle:
    """A sphere of `radius` (m) centred at `pose`'s origin (4×4, base frame)."""
    if not (np.isfinite(radius) and radius > 0):
        raise InputError(f"{name}: a sphere needs a positive radius (m), got {radius!r}")
    place = _posed(pose)
    return Obstacle(name, coal.Sphere(float(radius)), place, place[:3, 3].copy(), float(radius))


def mesh_obstacle(name: str, vertices: Array, pose: Array | None = None) -> Obstacle:
    """A mesh obstacle as the convex hull of its vertices (k, 3), m, in the frame `pose` (4×4, base frame)."""
    verts = np.asarray(vertices, dtype=float).reshape(-1, 3)
    place = _posed(pose)
    centre = 0.5 * (verts.min(axis=0) + verts.max(axis=0))
    radius = float(np.sqrt(np.max(np.sum((verts - centre) ** 2, axis=1))))
    return Obstacle(name, hull(verts, name), place, place[:3, :3] @ centre + place[:3, 3], radius)


def obstacle_mesh(obstacle: Obstacle) -> tuple[Array, NDArray[np.int64]]:
    """A further obstacle's surface as triangles for drawing: vertices (k, 3), m, base frame, and faces (t, 3).

    Boxes, cylinders and spheres tessellated as the braced link's primitives are (48 segments), a mesh as its
    convex hull (what the clearance counts). The bracing surface's solid is drawn by the viewer and figures
    themselves (:mod:`bracekit.viewer.bodies`).
    """
    from bracekit.geometry.collision import CollisionElement
    from bracekit.geometry.pieces import surface_triangles

    shape = obstacle.shape
    name = type(shape).__name__
    if name == "Box":
        element = CollisionElement(obstacle.name, 0, obstacle.placement, "box", tuple(2.0 * h for h in shape.halfSide))
    elif name == "Cylinder":
        size = (float(shape.radius), float(2.0 * shape.halfLength))
        element = CollisionElement(obstacle.name, 0, obstacle.placement, "cylinder", size)
    elif name == "Sphere":
        element = CollisionElement(obstacle.name, 0, obstacle.placement, "sphere", (float(shape.radius),))
    else:  # a mesh's hull: coal's Convex
        points = np.array([shape.points(i) for i in range(shape.num_points)], dtype=float).reshape(-1, 3)
        world = points @ obstacle.placement[:3, :3].T + obstacle.placement[:3, 3]
        return world, np.asarray(ConvexHull(world).simplices, dtype=np.int64)
    triangles = surface_triangles(element).reshape(-1, 3)
    vertices, faces = np.unique(np.round(triangles, 12), axis=0, return_inverse=True)
    return vertices, faces.reshape(-1, 3).astype(np.int64)
