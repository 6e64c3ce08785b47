"""The broad phase of the mesh clearance, compiled (internal, numba).

:func:`screen` bounds every (piece, obstacle) pair of one configuration and settles those it can exactly, so that
coal's narrow phase runs only on the pairs whose lower bound is below the least value found
(:mod:`bracekit.geometry.distance` gives the rules; this kernel is their loop over all pieces at once).

Obstacle kinds: 0 the surface's solid with a radius (the disk of radius r_max about c and the body below it),
1 the half-space below the surface's plane, 2 any other convex solid, bounded by its bounding sphere.

For a piece with bounding sphere (centre p, radius r): its distance from the surface's solid is at least
s(p) − r and at most s(p) + r (s the solid's signed distance, 1-Lipschitz; a point of the piece lies within r
of p), and at least |p − o| − R − r from another obstacle's sphere (o, R). A polytope with all its extreme points
over the disk and above it (or any polytope and the half-space) is settled exactly: its value is its extreme
points' least height (h is linear). A polytope reaching into the disk's solid (an extreme point inside, or a point
the steps below find inside) is settled at its deepest point (:func:`bracekit.geometry._depth.deepest`: the least
of max(h, ρ − r_max) over its hull, which may lie between its extreme points), unless its least height or −r_max
already bounds it below what the link holds. A polytope beside the disk (every extreme point
outside the solid, some not over the disk) starts from its nearest extreme point: Frank–Wolfe steps on the convex
distance D = |(max(ρ − r_max, 0), max(h, 0))| over its hull move to a nearer point x, and the separating axis
u = ∇D(x) bounds the piece below (the solid reaches r_max |u_xy| along u; the piece is at least
min_k uᵀv_k − r_max |u_xy| away). When the bound meets D(x) (within SETTLED) x is the nearest point and the piece
is settled there; else it is left to coal with the bound raised to its least height and that axis's bound.
"""

from __future__ import annotations

import math

import numpy as np

from bracekit._compiled import COMPILED, F64, I64
from bracekit._compiled import inline as _inline
from bracekit._compiled import jit as _jit
from bracekit.geometry._depth import deepest, deepest_in, workspace

__all__ = ["COMPILED", "DISK", "HALFSPACE", "SPHERE", "deepest_in", "screen"]

#: obstacle kinds
DISK, HALFSPACE, SPHERE = 0, 1, 2
#: A piece whose lower bound is within this (m) of the distance of a point of it is settled at that point (a tenth
#: of coal's GJK tolerance, bracekit.geometry.distance.GJK_TOLERANCE).
SETTLED = 1e-10
#: Frank–Wolfe steps toward a piece's nearest point before coal is left to find it.
ITERATIONS = 8


@_inline
def _signed(x: float, y: float, h: float, r_max: float) -> float:  # pragma: no cover - compiled
    """Signed distance (m) of a point at plane coordinates (x, y, h) from the disk's solid of radius r_max."""
    side = math.sqrt(x * x + y * y) - r_max
    if h <= 0.0 and side <= 0.0:
        return max(h, side)
    a = max(side, 0.0)
    b = max(h, 0.0)
    return math.sqrt(a * a + b * b)


#: Within this (m) of −r_max a point's signed distance from the disk's solid is at its floor (on the axis, deep).
FLOOR = 1e-12


@_jit
def _outward(  # pragma: no cover - compiled
    point: F64, o: int, kinds: I64, origins: F64, axes: F64, r_max: F64, out: F64
) -> None:
    """∇ of the surface solid o's signed distance (unit, world; 0 on its floor −r_max) at a point (3,) into out (3,)."""
    if kinds[o] == HALFSPACE:
        for i in range(3):
            out[i] = axes[o, i, 2]
        return
    dx, dy, dz = point[0] - origins[o, 0], point[1] - origins[o, 1], point[2] - origins[o, 2]
    x = dx * axes[o, 0, 0] + dy * axes[o, 1, 0] + dz * axes[o, 2, 0]
    y = dx * axes[o, 0, 1] + dy * axes[o, 1, 1] + dz * axes[o, 2, 1]
    h = dx * axes[o, 0, 2] + dy * axes[o, 1, 2] + dz * axes[o, 2, 2]
    rho = math.sqrt(x * x + y * y)
    rx, ry = (x / rho, y / rho) if rho > 0.0 else (0.0, 0.0)
    side = rho - r_max[o]
    if max(h, side) <= FLOOR - r_max[o]:  # on the axis at least r_max under the top: f = −r_max, flat
        gx, gy, gz = 0.0, 0.0, 0.0
    elif h <= 0.0 and side <= 0.0:
        gx, gy, gz = (0.0, 0.0, 1.0) if h >= side else (rx, ry, 0.0)
    else:
        a, b = max(side, 0.0), max(h, 0.0)
        d = math.sqrt(a * a + b * b)
        gx, gy, gz = (a * rx / d, a * ry / d, b / d) if d > 0.0 else (0.0, 0.0, 1.0)
    for i in range(3):
        out[i] = axes[o, i, 0] * gx + axes[o, i, 1] * gy + axes[o, i, 2] * gz


@_inline
def _away(  # pragma: no cover - compiled
    x: float, y: float, h: float, r_max: float
) -> tuple[float, float, float, float]:
    """(D, ∇D (3,)) of a point at plane coordinates (x, y, h) outside the disk's solid: its distance and direction."""
    rho = math.sqrt(x * x + y * y)
    a, b = max(rho - r_max, 0.0), max(h, 0.0)
    d = math.sqrt(a * a + b * b)
    if d == 0.0:
        return 0.0, 0.0, 0.0, 1.0
    if a == 0.0:
        return d, 0.0, 0.0, 1.0
    return d, a * x / (rho * d), a * y / (rho * d), b / d


@_jit
def _nearest(
    local: F64, count: int, start: int, r_max: float, stop: float
) -> tuple[float, float, float, float, float]:  # pragma: no cover - compiled
    """(D, x, y, h, bound): a point of a polytope near the disk's solid and a lower bound of its distance.

    The polytope is the hull of local[:count] (plane coordinates, all outside the solid); the search stops once
    the bound reaches `stop` (m, what the link holds: the piece cannot count). Frank–Wolfe on the
    convex D = |(max(ρ − r_max, 0), max(h, 0))| from the vertex `start`, each step's length by golden section;
    its gap closes on the separating axis u = ∇D(x): the solid reaches r_max |u_xy| along u (u_h ≥ 0), so the
    polytope is at least min_k uᵀv_k − r_max |u_xy| away, which equals D(x) when x is the nearest point.
    """
    x, y, h = local[start, 0], local[start, 1], local[start, 2]
    value, ux, uy, uh = _away(x, y, h, r_max)
    bound = -math.inf
    for _ in range(ITERATIONS):
        if value <= 0.0:
            break
        along, k = math.inf, 0
        for i in range(count):
            v = ux * local[i, 0] + uy * local[i, 1] + uh * local[i, 2]
            if v < along:
                along, k = v, i
        bound = max(bound, along - r_max * math.sqrt(ux * ux + uy * uy))
        if bound >= value - SETTLED or bound >= stop:  # settled, or no nearer than what is held
            break
        dx, dy, dh = local[k, 0] - x, local[k, 1] - y, local[k, 2] - h
        lo, hi = 0.0, 1.0  # golden section for the least D on [x, v_k]
        g = 0.5 * (math.sqrt(5.0) - 1.0)
        t1, t2 = hi - g * (hi - lo), lo + g * (hi - lo)
        f1 = _away(x + t1 * dx, y + t1 * dy, h + t1 * dh, r_max)[0]
        f2 = _away(x + t2 * dx, y + t2 * dy, h + t2 * dh, r_max)[0]
        for _ in range(60):
            if f1 <= f2:
                hi, t2, f2 = t2, t1, f1
                t1 = hi - g * (hi - lo)
                f1 = _away(x + t1 * dx, y + t1 * dy, h + t1 * dh, r_max)[0]
            else:
                lo, t1, f1 = t1, t2, f2
                t2 = lo + g * (hi - lo)
                f2 = _away(x + t2 * dx, y + t2 * dy, h + t2 * dh, r_max)[0]
            if hi - lo < 1e-12:
                break
        t = t1 if f1 <= f2 else t2
        step = _away(x + t * dx, y + t * dy, h + t * dh, r_max)
        if not step[0] < value:
            break
        x, y, h = x + t * dx, y + t * dy, h + t * dh
        value, ux, uy, uh = step
    return value, x, y, h, bound


@_jit
def _keep(
    best: F64, piece: I64, obstacle: I64, point: F64, s: int, value: float, p: int, o: int, m: F64, local: F64
) -> None:  # pragma: no cover - compiled
    """Record `value` of piece p and obstacle o at the extreme point `local` (joint frame) as link s's best."""
    best[s] = value
    piece[s], obstacle[s] = p, o
    for i in range(3):
        point[s, i] = m[i, 0] * local[0] + m[i, 1] * local[1] + m[i, 2] * local[2] + m[i, 3]


@_inline
def _found(
    best: F64,
    piece: I64,
    obstacle: I64,
    point: F64,
    s: int,
    value: float,
    p: int,
    o: int,
    x: float,
    y: float,
    h: float,
    origins: F64,
    axes: F64,
) -> None:  # pragma: no cover - compiled
    """Record `value` of piece p and obstacle o at the point (x, y, h) of o's plane coordinates as link s's best."""
    best[s] = value
    piece[s], obstacle[s] = p, o
    for i in range(3):
        point[s, i] = origins[o, i] + axes[o, i, 0] * x + axes[o, i, 1] * y + axes[o, i, 2] * h


@_inline
def _sphere(
    place: F64,
    j: int,
    cx: float,
    cy: float,
    cz: float,
    radius: float,
    o: int,
    kinds: I64,
    origins: F64,
    axes: F64,
    r_max: F64,
) -> tuple[float, float]:  # pragma: no cover - compiled
    """(Lower, upper bound) of the distance (m) of a ball (centre (cx, cy, cz) in link j's frame) from obstacle o.

    The upper bound is inf for an obstacle known only by its bounding sphere.
    """
    dx = place[j, 0, 0] * cx + place[j, 0, 1] * cy + place[j, 0, 2] * cz + place[j, 0, 3] - origins[o, 0]
    dy = place[j, 1, 0] * cx + place[j, 1, 1] * cy + place[j, 1, 2] * cz + place[j, 1, 3] - origins[o, 1]
    dz = place[j, 2, 0] * cx + place[j, 2, 1] * cy + place[j, 2, 2] * cz + place[j, 2, 3] - origins[o, 2]
    if kinds[o] == SPHERE:
        return math.sqrt(dx * dx + dy * dy + dz * dz) - r_max[o] - radius, math.inf
    h = dx * axes[o, 0, 2] + dy * axes[o, 1, 2] + dz * axes[o, 2, 2]
    if kinds[o] == HALFSPACE:
        return h - radius, h + radius
    x = dx * axes[o, 0, 0] + dy * axes[o, 1, 0] + dz * axes[o, 2, 0]
    y = dx * axes[o, 0, 1] + dy * axes[o, 1, 1] + dz * axes[o, 2, 1]
    d = _signed(x, y, h, r_max[o])
    return d - radius, d + radius


@_jit
def screen(
    place: F64,
    slot: I64,
    centres: F64,
    radii: F64,
    groups: I64,
    group_centres: F64,
    group_radii: F64,
    offsets: I64,
    points: F64,
    kinds: I64,
    origins: F64,
    axes: F64,
    r_max: F64,
    held: F64,
    shared: bool,
) -> tuple[F64, I64, I64, F64, I64, F64, F64]:  # pragma: no cover - compiled
    """Bound and settle the pairs of one configuration.

    Args:
        place: (J, 4, 4) placements of the link joints' frames.
        slot: (P,) each piece's link (0 … J − 1).
        centres: (P, 3) the pieces' bounding spheres' centres in their joints' frames, m.
        radii: (P,) their radii, m.
        groups: (G + 1,) group g holds the pieces groups[g]:groups[g + 1] (of one link).
        group_centres: (G, 3) the groups' bounding spheres' centres (joint frames), m.
        group_radii: (G,) their radii, m.
        offsets: (P + 1,) piece i's extreme points are points[offsets[i]:offsets[i + 1]] (none for a primitive).
        points: (N, 3) the extreme points in their joints' frames, m.
        kinds: (O,) obstacle kinds.
        origins: (O, 3) the surface's point c or the sphere's centre, m.
        axes: (O, 3, 3) the plane's axes as columns (x, y, n̂).
        r_max: (O,) the disk's radius or the sphere's radius, m (0 for the half-space).
        held: (J,) the value each link must come below to count (m); with `shared`, held[0] for all links.
        shared: one value held for all links (the least clearance), else one per link.

    Returns:
        (best (J,), its piece (J,), its obstacle (J,), its point (J, 3) world, m: the least settled value of each
        link (inf: none below held); candidates (M, 2) int (piece, obstacle) and their bounds (M,) for coal; the
        unit normal of the solid at each best point (J, 3), world, from the obstacle toward the link.)
    """
    npieces = centres.shape[0]
    ngroups = group_radii.shape[0]
    nobs = kinds.shape[0]
    nlinks = place.shape[0]
    cap = held.copy()
    world = np.empty(3)
    near = np.empty((ngroups, nobs))
    for g in range(ngroups):  # the groups' bounds, and the least upper bound
        k = slot[groups[g]]
        s = 0 if shared else k
        for o in range(nobs):
            c = group_centres
            low, up = _sphere(place, k, c[g, 0], c[g, 1], c[g, 2], group_radii[g], o, kinds, origins, axes, r_max)
            near[g, o] = low
            cap[s] = min(cap[s], up)
    best = np.full(nlinks, math.inf)
    best_piece = np.full(nlinks, -1, dtype=np.int64)
    best_obstacle = np.full(nlinks, -1, dtype=np.int64)
    best_point = np.zeros((nlinks, 3))
    pairs = np.empty((npieces * nobs, 2), dtype=np.int64)
    bounds = np.empty(npieces * nobs)
    count = 0
    widest = 0
    for p in range(npieces):
        widest = max(widest, offsets[p + 1] - offsets[p])
    local = np.empty((widest, 3))  # one piece's points in plane coordinates
    work, hull = workspace(widest)
    deep = np.zeros(nlinks, dtype=np.bool_)  # each link's best from :func:`deepest`, with its slope (plane axes)
    slope = np.zeros((nlinks, 3))
    first = np.empty(ngroups)
    for g in range(ngroups):
        first[g] = math.inf
        for o in range(nobs):
            first[g] = min(first[g], near[g, o])
    for g in np.argsort(first):  # the nearest groups first: the least value found prunes the others
        j = slot[groups[g]]
        s = 0 if shared else j
        m = place[j]
        for o in range(nobs):
            if near[g, o] >= min(cap[s], best[s]):
                continue
            for p in range(groups[g], groups[g + 1]):
                c = centres
                lower, up = _sphere(place, j, c[p, 0], c[p, 1], c[p, 2], radii[p], o, kinds, origins, axes, r_max)
                cap[s] = min(cap[s], up)
                if lower >= min(cap[s], best[s]):
                    continue
                lo, hi = offsets[p], offsets[p + 1]
                if kinds[o] == SPHERE or hi == lo:
                    pairs[count, 0], pairs[count, 1] = p, o
                    bounds[count] = lower
                    count += 1
                    continue
                least, at, low, over, mx, my = math.inf, lo, math.inf, True, 0.0, 0.0
                for k in range(lo, hi):
                    for i in range(3):
                        world[i] = (
                            m[i, 0] * points[k, 0] + m[i, 1] * points[k, 1] + m[i, 2] * points[k, 2] + m[i, 3]
                        ) - origins[o, i]
                    x = world[0] * axes[o, 0, 0] + world[1] * axes[o, 1, 0] + world[2] * axes[o, 2, 0]
                    y = world[0] * axes[o, 0, 1] + world[1] * axes[o, 1, 1] + world[2] * axes[o, 2, 1]
                    h = world[0] * axes[o, 0, 2] + world[1] * axes[o, 1, 2] + world[2] * axes[o, 2, 2]
                    local[k - lo, 0], local[k - lo, 1], local[k - lo, 2] = x, y, h
                    mx += x
                    my += y
                    if kinds[o] == HALFSPACE:
                        value = h
                    else:
                        value = _signed(x, y, h, r_max[o])
                        if math.sqrt(x * x + y * y) > r_max[o]:
                            over = False
                    if value < least:
                        least, at = value, k
                    low = min(low, h)
                if kinds[o] == HALFSPACE or (over and least > 0.0):  # settled: the least height (linear)
                    if least < best[s]:
                        _keep(best, best_piece, best_obstacle, best_point, s, least, p, o, m, points[at])
                        deep[s] = False
                    continue
                if least > 0.0:  # beside the disk: Frank–Wolfe from the nearest extreme point, closed by an axis
                    value, x, y, h, axis = _nearest(local, hi - lo, at - lo, r_max[o], min(cap[s], best[s]))
                    bound = max(lower, low, axis)
                    cap[s] = min(cap[s], value)  # a point of the piece: its distance is at most this
                    if bound >= value - SETTLED:  # the nearest point found: settled
                        if value < best[s]:
                            _found(best, best_piece, best_obstacle, best_point, s, value, p, o, x, y, h, origins, axes)
                            deep[s] = False
                        continue
                    if value > 0.0:  # left to coal
                        if bound < min(cap[s], best[s]):
                            pairs[count, 0], pairs[count, 1] = p, o
                            bounds[count] = bound
                            count += 1
                        continue
                    least = value  # a point of the piece inside the solid
                if max(low, -r_max[o]) >= min(cap[s], best[s]):  # f ≥ h and ≥ −r_max: no deeper than held
                    continue
                # into the solid: its deepest point
                found = deepest(local, hi - lo, r_max[o], least, min(cap[s], best[s]), work, hull)
                if found[0]:
                    cap[s] = min(cap[s], found[1])
                    x, y, h = found[2], found[3], found[4]
                    _found(best, best_piece, best_obstacle, best_point, s, found[1], p, o, x, y, h, origins, axes)
                    deep[s] = True
                    slope[s, 0], slope[s, 1], slope[s, 2] = found[5], found[6], found[7]
    best_normal = np.zeros((nlinks, 3))
    for s in range(nlinks):
        o = best_obstacle[s]
        if o >= 0 and deep[s]:  # ∂f*/∂(motion of the deepest point), from plane coordinates
            for i in range(3):
                best_normal[s, i] = (
                    axes[o, i, 0] * slope[s, 0] + axes[o, i, 1] * slope[s, 1] + axes[o, i, 2] * slope[s, 2]
                )
        elif o >= 0:
            _outward(best_point[s], o, kinds, origins, axes, r_max, best_normal[s])
    return best, best_piece, best_obstacle, best_point, pairs[:count], bounds[:count], best_normal
