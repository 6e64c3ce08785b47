"""The pad's place on a link's collision surface (primitives or meshes, as triangles), θ = (fraction, angle).

The rule of :func:`bracekit.geometry.pad.pad_on_surface` (``surface = {fraction, angle}`` of a ``[brace]``): the
link's axis is parallel to o' − o (its joint origin and the next, link frame) through the centroid g of the
link's collision surface; from the axis point c(s) = o + s (o' − o) + P(g − o), P = I − ẑẑᵀ, a ray goes out
along u(φ) = cos φ x̂ + sin φ ŷ, and the pad is the surface's outermost point on that ray:

    p(s, φ) = c(s) + t u(φ),     t = N·(a − c(s)) / (N·u(φ))

with N, a the normal and a vertex of the triangle hit (the largest t). On that triangle, p is smooth in θ and

    ∂p/∂s = (o' − o) + (∂t/∂s) u,      ∂t/∂s = −N·(o' − o) / (N·u)
    ∂p/∂φ = t u'(φ) + (∂t/∂φ) u,      ∂t/∂φ = −t N·u' / (N·u),      u' = −sin φ x̂ + cos φ ŷ

(m, link frame); p is continuous, its derivative jumps where the ray crosses from one triangle to the next (a
tessellated capsule's facets, a mesh's triangles). The pad axis is the inward unit normal interpolated over the
triangle from its corners' normals (each the area-weighted mean of the outward normals of the triangles sharing
that corner; Phong's rule), n = −m/|m|, m = (1 − β₁ − β₂) m_a + β₁ m_b + β₂ m_c with (β₁, β₂) the hit's
barycentric coordinates: continuous over the surface (a facet's normal would jump, and its zero derivative
would leave the pad's tilt to the posture alone), with

    ∂n/∂θ = −(I − n nᵀ) [(m_b − m_a) ∂β₁/∂θ + (m_c − m_a) ∂β₂/∂θ] / |m|,     [e₁ e₂] ∂β/∂θ = ∂p/∂θ.

On a tessellated capsule it is within the tessellation's angle of the capsule's own normal; edges sharper than
:data:`CREASE_DEG` (a cylinder's rim) stay sharp. The ray cast is this module's own (Möller–Trumbore
on every triangle at once, as in :mod:`bracekit.geometry.pad`, whose cast is private).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from bracekit.errors import ContactError
from bracekit.geometry.pad import link_frame, link_triangles, ray_hits
from bracekit.model.robot import Robot

Array = NDArray[np.float64]

#: Triangles meeting at a corner at more than this angle (degrees) keep their own normals there (a sharp edge).
CREASE_DEG = 45.0

#: The part of the geometry's span along the axis left out at each end of the fraction's bounds.
END_INSET = 0.2


class _Hit:
    """One ray's hit: the ray's parameter t, the triangle k, its normal N (unnormalised), the barycentric (β₁, β₂)."""

    __slots__ = ("bary", "k", "normal", "t")

    def __init__(self, t: float, k: int, normal: Array, bary: tuple[float, float]) -> None:
        self.t, self.k, self.normal, self.bary = t, k, normal, bary


def corner_normals(tri: Array) -> Array:
    """Each triangle corner's outward unit normal (t, 3, 3).

    The area-weighted mean over the triangles sharing the corner whose normals lie within :data:`CREASE_DEG`
    of the triangle's own (a cylinder's rim stays sharp). A triangle's outward side is the one away from the
    surface's centroid (the links' surfaces are convex).
    """
    normals = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])  # |N| = twice the area
    centroid = tri.reshape(-1, 3).mean(axis=0)
    normals *= np.where(np.einsum("ij,ij->i", tri.mean(axis=1) - centroid, normals) < 0.0, -1.0, 1.0)[:, None]
    units = normals / np.maximum(np.linalg.norm(normals, axis=1), 1e-300)[:, None]
    _, index = np.unique(np.round(tri.reshape(-1, 3), 9), axis=0, return_inverse=True)
    index = index.reshape(tri.shape[:2])
    sharing: dict[int, list[int]] = {}
    for k, corners in enumerate(index):
        for v in corners:
            sharing.setdefault(int(v), []).append(k)
    cos = math.cos(math.radians(CREASE_DEG))
    out = np.empty(tri.shape)
    for k, corners in enumerate(index):
        for j, v in enumerate(corners):
            near = [i for i in sharing[int(v)] if units[i] @ units[k] > cos]
            m = normals[near].sum(axis=0)
            out[k, j] = m / np.linalg.norm(m)
    return out


@dataclass(frozen=True, eq=False)
class SnappedSurface:
    """A link's collision surface as triangles (t, 3, 3), link frame (m), with the ray rule of the module."""

    link: str
    triangles: Array
    origin: Array
    axis: Array
    x: Array
    y: Array
    offset: Array
    corners: Array
    _cache: dict[tuple[float, float], _Hit] = field(default_factory=dict, repr=False)

    def fraction_bounds(self, bounds: tuple[float, float]) -> tuple[float, float]:
        """`bounds` narrowed to the fractions the geometry spans along the axis.

        Less :data:`END_INSET` of that span at each end (a ray near an end meets a cap, or misses where the
        geometry is not parallel to the axis); `bounds` when they do not overlap.
        """
        length2 = float(self.axis @ self.axis)
        span = (self.triangles.reshape(-1, 3) - self.origin) @ self.axis / length2
        lo, hi = float(span.min()), float(span.max())
        inset = END_INSET * (hi - lo)
        out = (max(bounds[0], lo + inset), min(bounds[1], hi - inset))
        return out if out[0] < out[1] else bounds

    def direction(self, angle: float) -> Array:
        """u(φ) (3,), the ray's direction at `angle` (rad)."""
        return math.cos(angle) * self.x + math.sin(angle) * self.y

    def centre(self, fraction: float) -> Array:
        """c(s) (3,), m: the ray's origin on the axis through the centroid."""
        return self.origin + fraction * self.axis + self.offset

    def _hit(self, fraction: float, angle: float) -> _Hit:
        key = (float(fraction), float(angle))
        found = self._cache.get(key)
        if found is None:
            found = self._cast(self.centre(fraction), self.direction(angle), fraction, angle)
            if len(self._cache) > 64:
                self._cache.clear()
            self._cache[key] = found
        return found

    def _cast(self, origin: Array, u: Array, fraction: float, angle: float) -> _Hit:
        tri = self.triangles
        hit, t, bu, bv = ray_hits(tri, origin, u)
        if not hit.any() or float(t[hit].max()) < 0.0:
            raise ContactError(
                f"no surface of link {self.link!r} on the ray at fraction {fraction:g}, angle "
                f"{math.degrees(angle):g}°: the placement left the link's collision geometry"
            )
        k = int(np.flatnonzero(hit)[np.argmax(t[hit])])
        normal = np.cross(tri[k, 1] - tri[k, 0], tri[k, 2] - tri[k, 0])
        return _Hit(float(t[k]), k, normal, (float(bu[k]), float(bv[k])))

    def _smooth(self, h: _Hit) -> Array:
        """The hit's interpolated outward normal m (3,), not normalised."""
        c = self.corners[h.k]
        return np.asarray((1.0 - h.bary[0] - h.bary[1]) * c[0] + h.bary[0] * c[1] + h.bary[1] * c[2], dtype=float)

    def point(self, fraction: float, angle: float) -> Array:
        """p(s, φ) (3,), m, link frame."""
        return self.centre(fraction) + self._hit(fraction, angle).t * self.direction(angle)

    def normal(self, fraction: float, angle: float) -> Array:
        """The inward unit normal n = −m/|m| (3,) at the hit (the module's interpolation), link frame."""
        m = self._smooth(self._hit(fraction, angle))
        return -m / np.linalg.norm(m)

    def point_derivative(self, fraction: float, angle: float) -> Array:
        """∂p/∂(s, φ) (3×2) on the triangle hit (see the module), m and m/rad."""
        h = self._hit(fraction, angle)
        u = self.direction(angle)
        du = -math.sin(angle) * self.x + math.cos(angle) * self.y
        nu = float(h.normal @ u)
        dt_ds = -float(h.normal @ self.axis) / nu
        dt_dphi = -h.t * float(h.normal @ du) / nu
        return np.column_stack([self.axis + dt_ds * u, h.t * du + dt_dphi * u])

    def normal_derivative(self, fraction: float, angle: float) -> Array:
        """∂n/∂(s, φ) (3×2) through the barycentric coordinates (the module's formula), 1 and 1/rad."""
        h = self._hit(fraction, angle)
        tri, c = self.triangles[h.k], self.corners[h.k]
        edges = np.column_stack([tri[1] - tri[0], tri[2] - tri[0]])
        dbary = np.linalg.lstsq(edges, self.point_derivative(fraction, angle), rcond=None)[0]  # (2, 2)
        dm = np.column_stack([c[1] - c[0], c[2] - c[0]]) @ dbary
        m = self._smooth(h)
        size = float(np.linalg.norm(m))
        n = -m / size
        return np.asarray(-(np.eye(3) - np.outer(n, n)) @ dm / size, dtype=float)


def snapped_surface(robot: Robot, link: str) -> SnappedSurface:
    """The collision surface of `link` (its primitives and meshes, tessellated); ContactError without length."""
    tri, _ = link_triangles(robot, link)
    o, axis, _, z, x = link_frame(robot, link, "it carries no placement")
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    g = (area @ tri.mean(axis=1)) / max(float(area.sum()), 1e-300)
    offset = (g - o) - z * float(z @ (g - o))
    return SnappedSurface(link, tri, o, axis, x, np.cross(z, x), offset, corner_normals(tri))
