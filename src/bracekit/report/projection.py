"""Orthographic projection of world geometry to 2-D drawing coordinates (m on the screen plane).

A parallel projection maps a plane affinely onto the screen, so a point of a disk is drawn inside the disk's
ellipse exactly when it lies inside the disk: the relation of a brace point to its bracing region reads the
same from any view. The outlines below are exact silhouettes: a capsule (a segment grown by a radius) projects
to the projected segment grown by the same radius, an ellipsoid to the ellipse of its projected shape matrix.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from bracekit._linalg import as_array
from bracekit.errors import InputError

Array = NDArray[np.float64]

_Z = np.array([0.0, 0.0, 1.0])


@dataclass(frozen=True)
class OrthoCamera:
    """An orthographic camera looking at the world from `azimuth` and `elevation` (degrees), world z up.

    The viewer sits in the direction (cos el cos az, cos el sin az, sin el) from the scene, as in
    matplotlib's ``view_init``: azimuth −90° looks along +y (x to the right), elevation 90° looks down.

    Attributes:
        azimuth: deg, the viewer's direction about world z from world x.
        elevation: deg, in [−90, 90], the viewer's height angle above the world x–y plane.
        basis: rows: the screen's right and up axes and the unit vector toward the viewer (3×3, world).
    """

    azimuth: float
    elevation: float
    basis: Array = field(init=False, repr=False)

    def __post_init__(self) -> None:
        for name in ("azimuth", "elevation"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value)):
                raise InputError(f"camera {name} must be a finite angle in degrees, got {value!r}")
        if not -90.0 <= self.elevation <= 90.0:
            raise InputError(f"camera elevation must lie in [-90, 90] degrees, got {self.elevation:g}")
        az, el = math.radians(self.azimuth), math.radians(self.elevation)
        toward = np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])
        right = np.array([-math.sin(az), math.cos(az), 0.0])  # z × toward, normalised (defined at el = ±90 too)
        up = np.cross(toward, right)
        object.__setattr__(self, "basis", np.array([right, up, toward]))

    @property
    def toward(self) -> Array:
        """Unit vector (3,) from the scene toward the viewer, world."""
        return cast(Array, self.basis[2])

    def project(self, points: ArrayLike) -> Array:
        """Screen coordinates (…, 2), m, of world points (…, 3), m."""
        return np.asarray(points, dtype=float) @ self.basis[:2].T

    def depth(self, points: ArrayLike) -> Array:
        """Distance toward the viewer (…,), m, of world points (…, 3): larger is nearer, drawn later."""
        return cast(Array, np.asarray(points, dtype=float) @ self.basis[2])


def capsule_outlines(a: ArrayLike, b: ArrayLike, radius: ArrayLike, k: int = 8) -> Array:
    """Outlines of 2-D capsules (stadiums): the segments [a_i, b_i] grown by radius_i.

    Args:
        a: first end points (m, 2), screen m.
        b: second end points (m, 2), screen m.
        radius: radii (m,), ≥ 0.
        k: points on each half circle (≥ 2).

    Returns:
        Closed polygons (m, 2k, 2): a half circle about b, then one about a.
    """
    pa, pb = np.asarray(a, dtype=float).reshape(-1, 2), np.asarray(b, dtype=float).reshape(-1, 2)
    r = np.asarray(radius, dtype=float).reshape(-1)
    d = pb - pa
    theta = np.arctan2(d[:, 1], d[:, 0])  # 0 for a point: any direction will do
    half = np.linspace(-0.5 * np.pi, 0.5 * np.pi, k)
    ang_b = theta[:, None] + half[None, :]
    ang_a = ang_b + np.pi
    ring_b = pb[:, None, :] + r[:, None, None] * np.stack([np.cos(ang_b), np.sin(ang_b)], axis=-1)
    ring_a = pa[:, None, :] + r[:, None, None] * np.stack([np.cos(ang_a), np.sin(ang_a)], axis=-1)
    return np.concatenate([ring_b, ring_a], axis=1)


def circle_points(centre: ArrayLike, normal: ArrayLike, radius: float, k: int = 72) -> Array:
    """K points (k, 3) of the circle of `radius` (m) about `centre` (3,) in the plane with `normal` (3,)."""
    c = as_array(centre, "circle centre (m)", (3,))
    n = as_array(normal, "circle normal", (3,))
    size = float(np.linalg.norm(n))
    if not size > 0.0:
        raise InputError("a circle needs a non-zero normal")
    n = n / size
    seed = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    u = seed - n * (n @ seed)
    u /= np.linalg.norm(u)
    w = np.cross(n, u)
    a = np.linspace(0.0, 2.0 * np.pi, k, endpoint=False)
    return cast(Array, c + radius * (np.outer(np.cos(a), u) + np.outer(np.sin(a), w)))


def ellipsoid_outline(camera: OrthoCamera, centre: ArrayLike, shape: ArrayLike, k: int = 48) -> Array:
    """Silhouette (k, 2) of the ellipsoid {centre + A s : |s| ≤ 1} seen by `camera` (exact for a parallel view).

    Args:
        camera: the view.
        centre: (3,), m, world.
        shape: A (3×3), m: its columns are the semi-axes (any matrix: A Aᵀ is what counts).
        k: points on the outline.
    """
    c = camera.project(as_array(centre, "ellipsoid centre (m)", (3,)))
    p = camera.basis[:2] @ as_array(shape, "ellipsoid shape (m)", (3, 3))
    w, v = np.linalg.eigh(p @ p.T)
    half = v * np.sqrt(np.maximum(w, 0.0))
    a = np.linspace(0.0, 2.0 * np.pi, k, endpoint=False)
    return cast(Array, c + np.column_stack([np.cos(a), np.sin(a)]) @ half.T)


def convex_hull(points: ArrayLike) -> Array:
    """The convex hull (h, 2) of 2-D points (m, 2), counter-clockwise (Andrew's monotone chain)."""
    pts = np.unique(np.asarray(points, dtype=float).reshape(-1, 2), axis=0)
    if len(pts) < 3:
        return pts

    def chain(seq: Array) -> list[Array]:
        out: list[Array] = []
        for p in seq:
            while len(out) >= 2 and _cross(out[-2], out[-1], p) <= 0.0:
                out.pop()
            out.append(p)
        return out

    lower, upper = chain(pts), chain(pts[::-1])
    return np.array(lower[:-1] + upper[:-1])


def _cross(o: Array, a: Array, b: Array) -> float:
    return float((a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]))
