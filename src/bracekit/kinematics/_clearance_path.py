"""The least capsule clearance of every configuration of a path, compiled (internal, numba).

:func:`screened_least` is :meth:`bracekit.kinematics.clearance.Clearance.minimum`'s search over the capsules of one
bracing surface, for the configurations of a whole path at once: each configuration's capsules in the order of
their lower bounds, each searched exactly (case (a) over the disk, else the bracketed Newton search for t* of
D² along the segment) until a bound passes the least value found. The rules, tolerances and the order of the
floating-point operations are those of :mod:`bracekit.kinematics.clearance` (whose docstring gives the
geometry), so the values are the same to rounding (tested per sample against the Python search).

Without numba the same loops run as Python; the clearance then keeps its own Python search
(:data:`COMPILED` is False) and the run's geometry line says so.
"""

from __future__ import annotations

import math

import numpy as np

from bracekit._compiled import COMPILED, F64, I64
from bracekit._compiled import inline as _inline
from bracekit._compiled import jit as _jit
from bracekit.kinematics.capsule_distance import FLAT as _FLAT
from bracekit.kinematics.capsule_distance import ITERATIONS as _ITERATIONS
from bracekit.kinematics.capsule_distance import ROUND as _ROUND
from bracekit.kinematics.clearance import _SLACK

__all__ = ["COMPILED", "screened_least"]


@_inline
def _slopes(  # pragma: no cover - compiled
    t: float, h0: float, slope: float, quad: float, half: float, gam: float, r_max: float
) -> tuple[float, float]:
    """(½ d(D²)/dt, ½ d²(D²)/dt²) at t along the segment (clearance._least_t's slopes)."""
    g = 0.0
    gg = 0.0
    height = h0 + slope * t
    if height > 0.0:
        g = height * slope
        gg = slope * slope
    rho = math.sqrt(max((quad * t + 2.0 * half) * t + gam, 0.0))
    if rho > r_max:
        drho = (quad * t + half) / rho
        g += (rho - r_max) * drho
        gg += drho * drho + (rho - r_max) * max(quad - drho * drho, 0.0) / rho
    return g, gg


@_inline
def _least_t(  # pragma: no cover - compiled
    h0: float, slope: float, quad: float, half: float, gam: float, r_max: float
) -> float:
    """t* ∈ [0, 1] minimising D² along a segment (clearance._least_t: Newton bracketed by bisection)."""
    g0 = _slopes(0.0, h0, slope, quad, half, gam, r_max)[0]
    if g0 >= 0.0:
        return 0.0
    g1 = _slopes(1.0, h0, slope, quad, half, gam, r_max)[0]
    if g1 <= 0.0:
        return 1.0
    lo = 0.0
    hi = 1.0
    t = g0 / (g0 - g1)
    step = 1.0
    previous = 1.0
    for _ in range(_ITERATIONS):
        g, gg = _slopes(t, h0, slope, quad, half, gam, r_max)
        if g == 0.0:
            return t
        if g < 0.0:
            lo = t
        else:
            hi = t
        newton = t - g / gg if gg > 0.0 else math.nan
        if not (lo < newton and newton < hi) or abs(2.0 * g) > abs(previous * gg):
            previous = step
            step = 0.5 * (hi - lo)
            nxt = lo + step
        else:
            previous = step
            step = g / gg
            nxt = newton
        if nxt == t or abs(step) <= 1e-15:
            return nxt
        t = nxt
    return t


@_inline
def _capsule(  # pragma: no cover - compiled
    x0: float, x1: float, y0: float, y1: float, h0: float, h1: float, radius: float, r_max: float
) -> float:
    """Clearance (m) of a capsule from its ends in plane coordinates (clearance.Clearance._capsule's value).

    r_max < 0: the half-space below the plane (no radius).
    """
    dx = x1 - x0
    dy = y1 - y0
    slope = h1 - h0
    if r_max < 0.0:
        return h1 - radius if slope < 0.0 else h0 - radius
    quad = dx * dx + dy * dy
    half = x0 * dx + y0 * dy
    gam = x0 * x0 + y0 * y0
    const = gam - r_max * r_max
    over = False
    lo = 0.0
    hi = 1.0
    if quad <= _FLAT:
        over = const <= _ROUND * (gam + r_max * r_max)
    else:
        disc = half * half - quad * const
        if disc >= -_ROUND * (half * half + quad * (gam + r_max * r_max)):
            qq = -(half + math.copysign(math.sqrt(max(disc, 0.0)), half))
            if qq != 0.0:
                lo = qq / quad
                hi = const / qq
            else:
                lo = 0.0
                hi = 0.0
            lo, hi = max(min(lo, hi), 0.0), min(max(lo, hi), 1.0)
            over = lo <= hi
    if over:
        t = hi if slope < 0.0 else lo
        height = h0 if t == 0.0 else h1 if t == 1.0 else h0 + t * slope
        if height < 0.0:
            return height - radius
    t = _least_t(h0, slope, quad, half, gam, r_max)
    if t == 1.0:
        x, y, h = x1, y1, h1
    else:
        x, y, h = x0 + t * dx, y0 + t * dy, h0 + t * slope
    rho = math.hypot(x, y)
    return math.hypot(max(rho - r_max, 0.0), max(h, 0.0)) - radius


@_inline
def _search(  # pragma: no cover - compiled
    ends: F64, bounds: F64, radii: F64, joints: I64, r_max: float, order: I64
) -> tuple[float, int]:
    """(Least clearance, its joint) of one configuration: ends (k, 3, 2), bounds (k,); order: scratch (k,)."""
    k = bounds.shape[0]
    for i in range(k):  # insertion sort of the bounds: stable, as sorted()
        j = i
        while j > 0 and bounds[order[j - 1]] > bounds[i]:
            order[j] = order[j - 1]
            j -= 1
        order[j] = i
    low = math.inf
    link = -1
    for m in range(k):
        i = order[m]
        if bounds[i] - _SLACK > low:
            break
        e = ends[i]
        value = _capsule(e[0, 0], e[0, 1], e[1, 0], e[1, 1], e[2, 0], e[2, 1], radii[i], r_max)
        joint = joints[i]
        if value < low or (value == low and joint < link):
            low = value
            link = joint
    return low, link


@_jit
def screened_least(  # pragma: no cover - compiled
    placements: F64,
    basis: F64,
    point: F64,
    slot: I64,
    local: F64,
    radii: F64,
    joints: I64,
    r_max: float,
    values: F64,
    links: I64,
) -> None:
    """(Least clearance, its joint) of each configuration into values (N,), links (N,), from its placements.

    placements (N, J, 4, 4): ⁰M of the capsule frames; each capsule is placed and bounded, then searched in the
    order of the bounds (stable) until a bound passes the least.

    basis (3, 3): rows the plane's x, y axes and normal; point (3,) the surface's point c (m); slot (k,) each
    capsule's frame in placements; local (k, 3, 2) its ends a, b as columns in that frame (m); radii (k,) m;
    joints (k,) each capsule's joint in chain order; r_max < 0 for the half-space. The ends in plane coordinates
    are basis (⁰R a + ⁰p − c), the lower bounds Clearance._screen_arrays's (m).
    """
    k = slot.shape[0]
    ends = np.empty((k, 3, 2))
    bounds = np.empty(k)
    order = np.empty(k, dtype=np.int64)
    rot = np.empty((3, 3))
    origin = np.empty(3)
    for s in range(placements.shape[0]):
        for i in range(k):
            m = placements[s, slot[i]]
            for a in range(3):
                for b in range(3):
                    rot[a, b] = basis[a, 0] * m[0, b] + basis[a, 1] * m[1, b] + basis[a, 2] * m[2, b]
                origin[a] = (
                    (m[0, 3] - point[0]) * basis[a, 0]
                    + (m[1, 3] - point[1]) * basis[a, 1]
                    + (m[2, 3] - point[2]) * basis[a, 2]
                )
            for a in range(3):
                for c in range(2):
                    ends[i, a, c] = (
                        rot[a, 0] * local[i, 0, c] + rot[a, 1] * local[i, 1, c] + rot[a, 2] * local[i, 2, c] + origin[a]
                    )
            low = min(ends[i, 2, 0], ends[i, 2, 1])
            if r_max < 0.0:
                bounds[i] = low - radii[i]
                continue
            xa, ya = ends[i, 0, 0], ends[i, 1, 0]
            dx, dy = ends[i, 0, 1] - xa, ends[i, 1, 1] - ya
            quad = dx * dx + dy * dy
            half = xa * dx + ya * dy
            tm = min(max(-half / quad, 0.0), 1.0) if quad > _FLAT else 0.0
            rho = math.sqrt(max((quad * tm + 2.0 * half) * tm + xa * xa + ya * ya, 0.0))
            side = rho - r_max
            if low < 0.0 and side <= _SLACK:
                bounds[i] = low - radii[i]
            else:
                bounds[i] = math.hypot(max(side, 0.0), max(low, 0.0)) - radii[i]
        values[s], links[s] = _search(ends, bounds, radii, joints, r_max, order)
