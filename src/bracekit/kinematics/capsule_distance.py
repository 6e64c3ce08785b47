"""The distance of one capsule from a bracing surface's solid obstacle, in the surface's plane coordinates.

The rule (the half-space without a radius; (a) penetration over the disk; (b) the Euclidean distance from the
solid, its least point t* by a bracketed Newton search) is :mod:`bracekit.kinematics.clearance`'s, whose
docstring gives the geometry; :class:`~bracekit.kinematics.clearance.Clearance` applies it to each capsule of a
configuration, and :mod:`bracekit.kinematics._clearance_path` compiles the same steps for a whole path.
"""

from __future__ import annotations

import math

__all__ = ["FLAT", "ITERATIONS", "ROUND", "capsule_distance", "least_t"]

#: |L (b − a)|² (m²) at or below which a segment has no lateral extent: it lies over the disk whole or not at all.
FLAT = 1e-28
#: Relative rounding within which a segment's line touches the cylinder (tangent to it or lying on it).
ROUND = 8.0 * 2.0**-52
#: Iteration cap of the bracketed Newton search for t* (bisection alone needs about 55 to reach rounding).
ITERATIONS = 200


def least_t(h0: float, slope: float, quad: float, half: float, gam: float, r_max: float) -> float:
    """t* ∈ [0, 1] minimising D² = max(ρ − r_max, 0)² + max(h, 0)² along a segment (Newton bracketed by bisection).

    h = h0 + slope·t and ρ² = quad·t² + 2·half·t + gam; ½ d(D²)/dt is continuous and nondecreasing (D² convex).
    """

    def slopes(t: float) -> tuple[float, float]:
        """(½ d(D²)/dt, ½ d²(D²)/dt²) at t."""
        g = gg = 0.0
        height = h0 + slope * t
        if height > 0.0:
            g, gg = height * slope, slope * slope
        rho = math.sqrt(max((quad * t + 2.0 * half) * t + gam, 0.0))
        if rho > r_max:
            drho = (quad * t + half) / rho
            g += (rho - r_max) * drho
            gg += drho * drho + (rho - r_max) * max(quad - drho * drho, 0.0) / rho
        return g, gg

    g0 = slopes(0.0)[0]
    if g0 >= 0.0:
        return 0.0
    g1 = slopes(1.0)[0]
    if g1 <= 0.0:
        return 1.0
    lo, hi = 0.0, 1.0
    t = g0 / (g0 - g1)  # the secant's root
    step = previous = 1.0
    for _ in range(ITERATIONS):
        g, gg = slopes(t)
        if g == 0.0:
            return t
        if g < 0.0:
            lo = t
        else:
            hi = t
        newton = t - g / gg if gg > 0.0 else math.nan
        if not lo < newton < hi or abs(2.0 * g) > abs(previous * gg):  # out of the bracket or slow: bisect
            previous, step = step, 0.5 * (hi - lo)
            nxt = lo + step
        else:
            previous, step = step, g / gg
            nxt = newton
        if nxt == t or abs(step) <= 1e-15:
            return nxt
        t = nxt
    return t


def capsule_distance(
    ends: list[list[float]], radius: float, r_max: float | None
) -> tuple[float, float, tuple[float, float, float], bool]:
    """(Clearance m, t*, unit direction u in plane coordinates, whether t* is a moving clip point) of a capsule.

    `ends` are its ends in plane coordinates ([[x_a, x_b], [y_a, y_b], [h_a, h_b]], m, as
    ``Clearance._screen`` gives them); `radius` m; `r_max` the obstacle's radius (m), None for the half-space.
    """
    (x0, x1), (y0, y1), (h0, h1) = ends
    dx, dy, slope = x1 - x0, y1 - y0, h1 - h0
    up = (0.0, 0.0, 1.0)
    if r_max is None:
        return (h1 - radius, 1.0, up, False) if slope < 0.0 else (h0 - radius, 0.0, up, False)
    quad, half, gam = dx * dx + dy * dy, x0 * dx + y0 * dy, x0 * x0 + y0 * y0
    # the part over the disk, ρ(t)² = quad t² + 2 half t + gam ≤ r_max²: [t0, t1] from the stable roots
    const = gam - r_max * r_max
    span: tuple[float, float] | None = None
    if quad <= FLAT:  # no lateral extent: over the disk whole (on the rim within rounding) or not at all
        span = (0.0, 1.0) if const <= ROUND * (gam + r_max * r_max) else None
    elif (disc := half * half - quad * const) >= -ROUND * (half * half + quad * (gam + r_max * r_max)):
        # a line tangent to the cylinder within rounding touches it: its tangent point is over the disk
        qq = -(half + math.copysign(math.sqrt(max(disc, 0.0)), half))
        lo, hi = (qq / quad, const / qq) if qq != 0.0 else (0.0, 0.0)
        lo, hi = max(min(lo, hi), 0.0), min(max(lo, hi), 1.0)
        span = (lo, hi) if lo <= hi else None
    if span is not None:
        t = span[1] if slope < 0.0 else span[0]
        height = h0 if t == 0.0 else h1 if t == 1.0 else h0 + t * slope
        if height < 0.0:  # (a): the least height over the disk, below the top
            return height - radius, t, up, 0.0 < t < 1.0 and slope != 0.0
    # (b): the distance from the solid
    t = least_t(h0, slope, quad, half, gam, r_max)
    x, y, h = (x1, y1, h1) if t == 1.0 else (x0 + t * dx, y0 + t * dy, h0 + t * slope)
    rho = math.hypot(x, y)
    side, top = max(rho - r_max, 0.0), max(h, 0.0)
    dist = math.hypot(side, top)
    if side == 0.0 or dist == 0.0:
        return dist - radius, t, up, False
    out = side / (rho * dist)
    return dist - radius, t, (out * x, out * y, top / dist), False
