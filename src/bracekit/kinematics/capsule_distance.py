"""The distance of one capsule from a bracing surface's solid obstacle, in the surface's plane coordinates.

The rule (the half-space without a radius; (a) penetration over the disk; (b) the Euclidean distance from the
solid, its least point t* by a bracketed Newton search) is :mod:`bracekit.kinematics.clearance`'s, whose
docstring gives the geometry. It is written once, as the kernels :func:`capsule` (with :func:`least_t` and
:func:`slopes`): compiled with numba where it is installed (:mod:`bracekit._compiled`), else the same functions
run as Python. Both callers use it: the compiled path search (:mod:`bracekit.kinematics._clearance_path`)
inlines it, and :class:`~bracekit.kinematics.clearance.Clearance` calls it through :func:`capsule_distance`, one
capsule at a time from Python: there :func:`capsule` runs as Python (its ``py_func``) and the Newton search
:func:`least_t` it calls runs compiled. That is faster than the rule all in Python (about 2.7 → 1.4 µs a
capsule) and gives its values bit for bit (``math.hypot`` is Python's, not the C library's, which numba calls:
the whole compiled dispatch, 0.5 µs, moves the gradient barrier's steps by rounding).

This module imports numba: :mod:`bracekit.kinematics.clearance` imports it on first use, so that
``import bracekit`` does not.
"""

from __future__ import annotations

import math

from bracekit._compiled import inline as _inline
from bracekit.kinematics.clearance import FLAT, ITERATIONS, ROUND

__all__ = ["FLAT", "ITERATIONS", "ROUND", "capsule", "capsule_distance", "least_t", "slopes"]


@_inline
def slopes(
    t: float, h0: float, slope: float, quad: float, half: float, gam: float, r_max: float
) -> tuple[float, float]:
    """(½ d(D²)/dt, ½ d²(D²)/dt²) at t along the segment (:func:`least_t`'s D²)."""
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
def least_t(h0: float, slope: float, quad: float, half: float, gam: float, r_max: float) -> float:
    """t* ∈ [0, 1] minimising D² = max(ρ − r_max, 0)² + max(h, 0)² along a segment (Newton bracketed by bisection).

    h = h0 + slope·t and ρ² = quad·t² + 2·half·t + gam; ½ d(D²)/dt is continuous and nondecreasing (D² convex).
    """
    g0 = slopes(0.0, h0, slope, quad, half, gam, r_max)[0]
    if g0 >= 0.0:
        return 0.0
    g1 = slopes(1.0, h0, slope, quad, half, gam, r_max)[0]
    if g1 <= 0.0:
        return 1.0
    lo = 0.0
    hi = 1.0
    t = g0 / (g0 - g1)  # the secant's root
    step = 1.0
    previous = 1.0
    for _ in range(ITERATIONS):
        g, gg = slopes(t, h0, slope, quad, half, gam, r_max)
        if g == 0.0:
            return t
        if g < 0.0:
            lo = t
        else:
            hi = t
        newton = t - g / gg if gg > 0.0 else math.nan
        if not (lo < newton and newton < hi) or abs(2.0 * g) > abs(previous * gg):  # out of the bracket or slow
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
def capsule(
    x0: float, x1: float, y0: float, y1: float, h0: float, h1: float, radius: float, r_max: float
) -> tuple[float, float, float, float, float, bool]:
    """(Clearance m, t*, u_x, u_y, u_z, clip) of a capsule from its ends in plane coordinates (m).

    `radius` m; `r_max` the obstacle's radius (m), negative for the half-space. u is the unit direction of the
    clearance's growth at p(t*) in plane coordinates; clip: whether t* is a clip point on the cylinder that
    moves with q (case (a) inside the segment).
    """
    dx = x1 - x0
    dy = y1 - y0
    slope = h1 - h0
    if r_max < 0.0:
        if slope < 0.0:
            return h1 - radius, 1.0, 0.0, 0.0, 1.0, False
        return h0 - radius, 0.0, 0.0, 0.0, 1.0, False
    quad = dx * dx + dy * dy
    half = x0 * dx + y0 * dy
    gam = x0 * x0 + y0 * y0
    # the part over the disk, ρ(t)² = quad t² + 2 half t + gam ≤ r_max²: [lo, hi] from the stable roots
    const = gam - r_max * r_max
    over = False
    lo = 0.0
    hi = 1.0
    if quad <= FLAT:  # no lateral extent: over the disk whole (on the rim within rounding) or not at all
        over = const <= ROUND * (gam + r_max * r_max)
    else:
        disc = half * half - quad * const
        # a line tangent to the cylinder within rounding touches it: its tangent point is over the disk
        if disc >= -ROUND * (half * half + quad * (gam + r_max * r_max)):
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
        if height < 0.0:  # (a): the least height over the disk, below the top
            return height - radius, t, 0.0, 0.0, 1.0, (0.0 < t and t < 1.0) and slope != 0.0
    # (b): the distance from the solid
    t = least_t(h0, slope, quad, half, gam, r_max)
    if t == 1.0:
        x, y, h = x1, y1, h1
    else:
        x, y, h = x0 + t * dx, y0 + t * dy, h0 + t * slope
    rho = math.hypot(x, y)
    side = max(rho - r_max, 0.0)
    top = max(h, 0.0)
    dist = math.hypot(side, top)
    if side == 0.0 or dist == 0.0:
        return dist - radius, t, 0.0, 0.0, 1.0, False
    out = side / (rho * dist)
    return dist - radius, t, out * x, out * y, top / dist, False


def capsule_distance(
    ends: list[list[float]], radius: float, r_max: float | None
) -> tuple[float, float, tuple[float, float, float], bool]:
    """(Clearance m, t*, unit direction u in plane coordinates, whether t* is a moving clip point) of a capsule.

    `ends` are its ends in plane coordinates ([[x_a, x_b], [y_a, y_b], [h_a, h_b]], m, as
    ``Clearance._screen`` gives them); `radius` m; `r_max` the obstacle's radius (m), None for the half-space.
    :func:`capsule` with these arguments, run as Python (its compiled :func:`least_t` inside).
    """
    (x0, x1), (y0, y1), (h0, h1) = ends
    value, t, ux, uy, uz, clip = _capsule(x0, x1, y0, y1, h0, h1, radius, -1.0 if r_max is None else r_max)
    return value, t, (ux, uy, uz), clip


#: :func:`capsule` as Python where it is compiled (its ``py_func``; this module's docstring says why)
_capsule = getattr(capsule, "py_func", capsule)
