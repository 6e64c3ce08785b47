"""The deepest point of a polytope piece in the surface's solid (internal, compiled with numba where installed).

In plane coordinates (x, y in the surface's plane about its point c, h along its normal n̂; ρ = |(x, y)|) the
solid of radius r_max is {h ≤ 0, ρ ≤ r_max} and f(x) = max(h, ρ − r_max) is its signed distance wherever f ≤ 0
(the depth below the top or inside the side, whichever is less). A piece P (the hull of its extreme points
v_k) that reaches into the solid has clearance

    f* = min over x ∈ P of max(h(x), ρ(x) − r_max)        (minus the depth of P's deepest point).

f is convex, so f* need not be taken at an extreme point: a piece across the rim edge is deepest between them.
With φ(s) = min{ρ(x) : x ∈ P, h(x) ≤ s} (convex, non-increasing in s), f* = min_s max(s, φ(s) − r_max):
the least height h_min when φ(h_min) ≤ r_max + h_min, else the root s* of ψ(s) = φ(s) − r_max − s (strictly
decreasing). φ(s) is the distance of the plane's axis from the projection of P ∩ {h ≤ s}, the hull of the extreme
points below s and of the points where the segments between two extreme points cross height s: the projection's
convex hull (monotone chain) gives its nearest point and, by the same weights, a point of P. The root is
bracketed, ψ(lo) > 0 ≥ ψ(hi), and closed by regula falsi (Illinois) to DEPTH_TOLERANCE: f* ∈ [lo, hi], and the
point found at hi is a point of P whose f is at most hi. The value returned is that point's f, so it is never
above f* by more than DEPTH_TOLERANCE and never below it.

The derivative of f* with respect to a motion of the piece is gᵀ v(x*), v the velocity of the deepest point x*
and g = α n̂ + (1 − α) ŵ, ŵ the horizontal direction of x* from the axis and α ∈ [0, 1] the multiplier that
maximises the dual bound L(α) = min_k [α h_k + (1 − α)(ŵᵀv_k − r_max)] ≤ f* (equal at the optimum): α = 1 where
only the height is active, 0 where only the side is.
"""

from __future__ import annotations

import math

import numpy as np

from bracekit._compiled import F64, I64
from bracekit._compiled import inline as _inline
from bracekit._compiled import jit as _jit

__all__ = ["DEPTH_TOLERANCE", "deepest", "deepest_in", "workspace"]

#: The bracket of the deepest point's value is closed to this (m).
DEPTH_TOLERANCE = 1e-12


@_inline
def _cross(ax: float, ay: float, bx: float, by: float, cx: float, cy: float) -> float:  # pragma: no cover
    """(b − a) × (c − a), the z component (positive: c left of a→b)."""
    return (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)


@_jit
def _cut(local: F64, count: int, s: float, out: F64) -> int:  # pragma: no cover - compiled
    """Points spanning P ∩ {h ≤ s} into out[:m] (plane coordinates); m (0: P lies above s)."""
    m = 0
    for i in range(count):
        if local[i, 2] <= s:
            for c in range(3):
                out[m, c] = local[i, c]
            m += 1
    for i in range(count):
        if local[i, 2] <= s:
            continue
        for j in range(count):
            if local[j, 2] < s:  # the segment from v_j (below) to v_i (above) crosses height s
                t = (s - local[j, 2]) / (local[i, 2] - local[j, 2])
                out[m, 0] = local[j, 0] + t * (local[i, 0] - local[j, 0])
                out[m, 1] = local[j, 1] + t * (local[i, 1] - local[j, 1])
                out[m, 2] = s
                m += 1
    return m


@_inline
def _turn(points: F64, a: int, b: int, c: int) -> float:  # pragma: no cover - compiled
    """:func:`_cross` of the points a, b, c of points (their x, y)."""
    return _cross(points[a, 0], points[a, 1], points[b, 0], points[b, 1], points[c, 0], points[c, 1])


@_jit
def _hull(points: F64, m: int, hull: I64) -> int:  # pragma: no cover - compiled
    """The convex hull of points[:m]'s (x, y), counter-clockwise, as indices into hull[:k]; k."""
    if m == 1:
        hull[0] = 0
        return 1
    by_y = np.argsort(points[:m, 1], kind="mergesort")
    order = by_y[np.argsort(points[by_y, 0], kind="mergesort")]  # by x, then y
    k = 0
    for a in order:  # the lower chain
        while k >= 2 and _turn(points, hull[k - 2], hull[k - 1], a) <= 0.0:
            k -= 1
        hull[k] = a
        k += 1
    low = k + 1
    for r in range(m - 2, -1, -1):  # the upper chain
        a = order[r]
        while k >= low and _turn(points, hull[k - 2], hull[k - 1], a) <= 0.0:
            k -= 1
        hull[k] = a
        k += 1
    return k - 1  # the last is the first again


@_jit
def _axis_nearest(points: F64, m: int, hull: I64) -> tuple[float, float, float, float]:  # pragma: no cover
    """(ρ, x, y, h): the point of hull(points[:m])'s projection nearest the axis, ρ its distance.

    (x, y, h) is a point of the hull (3D) projecting there, by the same weights.
    """
    k = _hull(points, m, hull)
    best, bx, by, bh = math.inf, 0.0, 0.0, 0.0
    inside = k >= 3
    for e in range(max(k, 1)):
        a, b = hull[e], hull[(e + 1) % k]
        ax, ay = points[a, 0], points[a, 1]
        dx, dy = points[b, 0] - ax, points[b, 1] - ay
        length = dx * dx + dy * dy
        t = 0.0 if length == 0.0 else min(max(-(ax * dx + ay * dy) / length, 0.0), 1.0)
        x, y = ax + t * dx, ay + t * dy
        rho = math.sqrt(x * x + y * y)
        if rho < best:
            best, bx, by = rho, x, y
            bh = points[a, 2] + t * (points[b, 2] - points[a, 2])
        if _cross(ax, ay, ax + dx, ay + dy, 0.0, 0.0) < 0.0:
            inside = False
    if not inside:
        return best, bx, by, bh
    o = hull[0]
    for e in range(1, k - 1):  # the axis inside: the fan triangle (o, a, b) holding it, by barycentric weights
        a, b = hull[e], hull[e + 1]
        det = _cross(points[o, 0], points[o, 1], points[a, 0], points[a, 1], points[b, 0], points[b, 1])
        if det <= 0.0:
            continue
        u = _cross(points[o, 0], points[o, 1], 0.0, 0.0, points[b, 0], points[b, 1]) / det
        v = _cross(points[o, 0], points[o, 1], points[a, 0], points[a, 1], 0.0, 0.0) / det
        if u >= 0.0 and v >= 0.0 and u + v <= 1.0:
            w = 1.0 - u - v
            return 0.0, 0.0, 0.0, w * points[o, 2] + u * points[a, 2] + v * points[b, 2]
    return best, bx, by, bh  # (rounding: the axis on an edge)


@_jit
def _phi(local: F64, count: int, s: float, work: F64, hull: I64) -> tuple[float, float, float, float]:
    """(φ(s), x, y, h): the least ρ over P ∩ {h ≤ s} and a point of P there (ρ = inf: P lies above s)."""
    m = _cut(local, count, s, work)
    if m == 0:  # pragma: no cover - the callers cut at or above the least height
        return math.inf, 0.0, 0.0, 0.0
    return _axis_nearest(work, m, hull)


@_inline
def _dual(local: F64, count: int, r_max: float, wx: float, wy: float, alpha: float) -> float:  # pragma: no cover
    """L(α) = min_k [α h_k + (1 − α)(ŵᵀv_k − r_max)], a lower bound of f* for any α ∈ [0, 1] and unit ŵ."""
    least = math.inf
    for k in range(count):
        least = min(least, alpha * local[k, 2] + (1.0 - alpha) * (wx * local[k, 0] + wy * local[k, 1] - r_max))
    return least


@_jit
def _multiplier(local: F64, count: int, r_max: float, wx: float, wy: float) -> float:  # pragma: no cover
    """α ∈ [0, 1] maximising :func:`_dual` (concave in α: golden section)."""
    g = 0.5 * (math.sqrt(5.0) - 1.0)
    lo, hi = 0.0, 1.0
    for _ in range(80):
        t1, t2 = hi - g * (hi - lo), lo + g * (hi - lo)
        if _dual(local, count, r_max, wx, wy, t1) >= _dual(local, count, r_max, wx, wy, t2):
            hi = t2
        else:
            lo = t1
        if hi - lo < 1e-12:
            break
    return 0.5 * (lo + hi)


@_jit
def deepest(
    local: F64, count: int, r_max: float, upper: float, stop: float, work: F64, hull: I64
) -> tuple[bool, float, float, float, float, float, float, float]:  # pragma: no cover - compiled
    """(found, f*, x, y, h, g_x, g_y, g_h): the deepest point of a piece in the disk's solid (module docstring).

    Args:
        local: (≥ count, 3) the piece's extreme points in plane coordinates, m.
        count: how many.
        r_max: the disk's radius, m.
        upper: f at a point of the piece, ≤ 0 (an extreme point's signed distance, or a point found inside), m.
        stop: f* is not needed once it is known to be at least this (m; what the link already holds).
        work: scratch of (count + count² / 4 + 1, 3) floats (:func:`workspace`).
        hull: scratch of twice as many + 1 indices.

    Returns:
        found False when f* ≥ stop (then nothing else is meant); else f* (m, ≤ upper), its point (x, y, h), m,
        and g (plane coordinates): ∂f*/∂(the piece's motion at that point), |g| ≤ 1.
    """
    h_min, h_max = math.inf, -math.inf
    for k in range(count):
        h_min = min(h_min, local[k, 2])
        h_max = max(h_max, local[k, 2])
    lo = max(h_min, -r_max)  # f ≥ h and f ≥ −r_max
    if lo >= stop:
        return False, lo, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0
    rho, x, y, h = _phi(local, count, h_min, work, hull)
    if rho - r_max <= h_min:  # the lowest point is within the side: only the height counts
        return True, max(h, rho - r_max), x, y, h, 0.0, 0.0, 1.0
    f_lo = rho - r_max - h_min
    hi = min(upper, h_max)
    rho, x, y, h = _phi(local, count, hi, work, hull)
    f_hi = rho - r_max - hi
    if f_hi < 0.0:
        if lo > h_min:  # lo = −r_max: the axis itself
            rho_lo, x_lo, y_lo, h_lo = _phi(local, count, lo, work, hull)
            f_lo = rho_lo - r_max - lo
            if f_lo <= 0.0:  # the axis crosses P below the top by r_max or more: f* = −r_max, flat under any motion
                return True, max(h_lo, rho_lo - r_max), x_lo, y_lo, h_lo, 0.0, 0.0, 0.0
        side = 0
        for step in range(200):
            if hi - lo <= DEPTH_TOLERANCE:
                break
            s = (lo * f_hi - hi * f_lo) / (f_hi - f_lo) if step < 60 else 0.5 * (lo + hi)
            if not lo < s < hi:
                s = 0.5 * (lo + hi)
            r_s, x_s, y_s, h_s = _phi(local, count, s, work, hull)
            f_s = r_s - r_max - s
            if f_s > 0.0:
                lo, f_lo = s, f_s
                if side == 1:
                    f_hi *= 0.5
                side = 1
                if lo >= stop:
                    return False, lo, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0
            else:
                hi, f_hi = s, f_s
                rho, x, y, h = r_s, x_s, y_s, h_s
                if side == -1:
                    f_lo *= 0.5
                side = -1
    value = max(h, rho - r_max)  # (f_hi ≥ 0: hi = h_max, the point of P nearest the axis is below the side)
    if value >= stop:
        return False, value, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0
    if rho <= 0.0:  # on the axis: no horizontal direction; below −r_max the value is −r_max, flat
        return True, value, x, y, h, 0.0, 0.0, 1.0 if h >= -r_max else 0.0
    wx, wy = x / rho, y / rho
    alpha = 0.0 if h < rho - r_max - 1e-12 else _multiplier(local, count, r_max, wx, wy)
    return True, value, x, y, h, (1.0 - alpha) * wx, (1.0 - alpha) * wy, alpha


@_jit
def workspace(count: int) -> tuple[F64, I64]:  # pragma: no cover - compiled
    """Scratch for :func:`deepest` on pieces of up to `count` extreme points."""
    size = count + (count * count) // 4 + 1
    return np.empty((size, 3)), np.empty(2 * size + 1, dtype=np.int64)


def deepest_in(local: F64, r_max: float, upper: float) -> tuple[float, F64, F64]:
    """(f* m, its point (3,) and g (3,), plane coordinates) of the piece with extreme points `local` (k, 3).

    :func:`deepest` for one piece (no stop), for callers outside the broad phase; `upper` is f at a point of it.
    """
    points = np.ascontiguousarray(local, dtype=float).reshape(-1, 3)
    work, hull = workspace(len(points))
    found = deepest(points, len(points), float(r_max), float(upper), math.inf, work, hull)
    return float(found[1]), np.array(found[2:5]), np.array(found[5:8])
