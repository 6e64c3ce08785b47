"""The deepest point of a polytope piece inside a further obstacle (box, cylinder, sphere, convex mesh).

A link inside an obstacle has clearance f* = min over x ∈ P of s(x), s the obstacle's signed distance and P the
piece (the hull of its extreme points v_k): minus the depth of P's deepest point, as for the surface's solid
(:mod:`bracekit.geometry._depth`), rather than coal's EPA penetration depth (how far P must move to come out,
which is at least that). In the obstacle's frame:

- box and convex mesh, the polytope {A x ≤ b} (unit rows): inside, s(x) = max_f (A_f x − b_f), so f* is the
  linear program min t : A (Σ λ_k v_k) − b ≤ t, λ ≥ 0, Σ λ_k = 1 (SciPy's HiGHS); the multipliers μ_f of its
  rows (Σ μ_f = 1) give ∂f*/∂(the piece's motion) = Σ μ_f A_f;
- cylinder of radius r and length L along z: s = max(|z| − L/2, ρ − r), on each side of z = 0 the surface's
  solid of :mod:`bracekit.geometry._depth` with its top at ±L/2: P is cut at z = 0 and each part solved there;
- sphere of radius R: s = |x| − R, so f* = dist(0, P) − R (coal's GJK from the centre, a point), −R with the
  centre in P.

:func:`deepest_inside` returns None when the least value is positive (P is outside: its distance is coal's).
"""

from __future__ import annotations

import importlib
import weakref
from typing import Any

import coal
import numpy as np
from numpy.typing import NDArray
from scipy.optimize import linprog
from scipy.spatial import ConvexHull

from bracekit.errors import NumericalError
from bracekit.geometry.obstacles import Obstacle

__all__ = ["deepest_inside"]

Array = NDArray[np.float64]
#: (value m, the deepest point (3,) world, ∂value/∂(the piece's motion) (3,) world)
Deepest = tuple[float, Array, Array]

#: Each polyhedral obstacle's rows (A (F, 3) unit, b (F,)) in its own frame, built once.
_FACES: weakref.WeakKeyDictionary[Obstacle, tuple[Array, Array]] = weakref.WeakKeyDictionary()


def deepest_inside(obstacle: Obstacle, points: Array) -> Deepest | None:
    """The deepest point of the hull of `points` (k, 3), world, m, inside a further obstacle (module docstring)."""
    place = obstacle.placement
    local = (np.asarray(points, dtype=float).reshape(-1, 3) - place[:3, 3]) @ place[:3, :3]
    kind = type(obstacle.shape).__name__
    found: Deepest | None
    if kind == "Sphere":
        found = _sphere(local, float(obstacle.shape.radius))
    elif kind == "Cylinder":
        found = _cylinder(local, float(obstacle.shape.radius), float(obstacle.shape.halfLength))
    else:
        found = _polytope(local, *_faces(obstacle))
    if found is None or not found[0] <= 0.0:
        return None
    value, point, slope = found
    return value, place[:3, :3] @ point + place[:3, 3], place[:3, :3] @ slope


def _faces(obstacle: Obstacle) -> tuple[Array, Array]:
    """The obstacle's polytope {A x ≤ b} in its frame: a box's six faces, a mesh's hull facets."""
    if obstacle not in _FACES:
        shape = obstacle.shape
        if type(shape).__name__ == "Box":
            half = np.asarray(shape.halfSide, dtype=float)
            rows, offsets = np.vstack([np.eye(3), -np.eye(3)]), np.concatenate([half, half])
        else:
            vertices = np.asarray(shape.points(), dtype=float).reshape(-1, 3)
            planes = ConvexHull(vertices).equations  # n·x + d ≤ 0 inside, |n| = 1
            rows, offsets = planes[:, :3], -planes[:, 3]
        _FACES[obstacle] = (np.asarray(rows, dtype=float), np.asarray(offsets, dtype=float))
    return _FACES[obstacle]


def _polytope(local: Array, rows: Array, offsets: Array) -> Deepest:
    """The least of max_f (A_f x − b_f) over the hull of `local`: the linear program and its multipliers."""
    k = len(local)
    cost = np.zeros(k + 1)
    cost[k] = 1.0
    upper = np.hstack([rows @ local.T, -np.ones((len(rows), 1))])
    result = linprog(
        cost, A_ub=upper, b_ub=offsets, A_eq=np.append(np.ones(k), 0.0)[None], b_eq=[1.0],
        bounds=[(0.0, None)] * k + [(None, None)], method="highs",
    )  # fmt: skip
    if result.status != 0:
        raise NumericalError(f"the deepest point of a link piece in an obstacle: no linear program ({result.message})")
    weights = np.clip(result.x[:k], 0.0, None)
    point = (weights / weights.sum()) @ local
    multipliers = np.clip(-np.asarray(result.ineqlin.marginals, dtype=float), 0.0, None)
    slope = multipliers @ rows / max(float(multipliers.sum()), 1e-300)
    return float(np.max(rows @ point - offsets)), point, slope


def _sphere(local: Array, radius: float) -> Deepest:
    """dist(0, hull(local)) − R by coal's GJK from the centre (−R, no direction, with the centre inside)."""
    request, result = coal.DistanceRequest(), coal.DistanceResult()
    request.gjk_tolerance = 1e-9
    vertices = coal.StdVec_Vec3s()
    for p in local:
        vertices.append(np.asarray(p, dtype=float))
    piece: Any = coal.Convex(vertices, _triangles(local))
    identity = coal.Transform3s()
    distance = coal.distance(piece, identity, coal.Sphere(0.0), identity, request, result)
    if distance <= 0.0:
        return -radius, np.zeros(3), np.zeros(3)
    point = np.array(result.getNearestPoint1(), dtype=float)
    return float(np.linalg.norm(point)) - radius, point, point / np.linalg.norm(point)


def _triangles(local: Array) -> Any:
    """The hull's facets of the points (k, 3) for coal's Convex (one triangle for three points)."""
    out = coal.StdVec_Triangle()
    if len(local) <= 3:
        out.append(coal.Triangle(0, min(1, len(local) - 1), min(2, len(local) - 1)))
        return out
    for a, b, c in ConvexHull(local, qhull_options="QJ").simplices:
        out.append(coal.Triangle(int(a), int(b), int(c)))
    return out


def _cylinder(local: Array, radius: float, half: float) -> Deepest | None:
    """max(|z| − L/2, ρ − r) over the hull: each side of z = 0 as the surface's solid with its top at ±L/2."""
    best: Deepest | None = None
    for sign in (1.0, -1.0):
        part = _side(local * np.array([1.0, 1.0, sign]))  # mirrored: the side's cap on top
        if part is None:
            continue
        plane = part - np.array([0.0, 0.0, half])
        at = np.hypot(plane[:, 0], plane[:, 1]) - radius
        upper = float(np.min(np.maximum(plane[:, 2], at)))
        value, point, slope = importlib.import_module("bracekit.geometry._depth").deepest_in(plane, radius, upper)
        if best is None or value < best[0]:
            flip = np.array([1.0, 1.0, sign])
            best = value, (point + np.array([0.0, 0.0, half])) * flip, slope * flip
    return best


def _side(local: Array) -> Array | None:
    """Points spanning the part of the hull of `local` (k, 3) with z ≥ 0 (None: none of it)."""
    above = local[:, 2] >= 0.0
    if not above.any():
        return None
    crossings = [a + (b - a) * (a[2] / (a[2] - b[2])) for a in local[above] for b in local[~above] if a[2] - b[2] > 0.0]
    return np.vstack([local[above], *crossings]) if crossings else local[above]
