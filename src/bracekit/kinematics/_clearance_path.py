"""The least capsule clearance of every configuration of a path, compiled (internal, numba).

:func:`screened_least` is :meth:`bracekit.kinematics.clearance.Clearance.minimum`'s search over the capsules of one
bracing surface, for the configurations of a whole path at once: each configuration's capsules in the order of
their lower bounds, each searched exactly by the capsule rule (:func:`bracekit.kinematics.capsule_distance.capsule`,
inlined) until a bound passes the least value found. The screen, tolerances and the order of the
floating-point operations are those of :mod:`bracekit.kinematics.clearance` (whose docstring gives the
geometry), so the values are the same to rounding (tested per sample against the search of one configuration).

Without numba the same loops run as Python; the clearance then keeps its own Python search
(:data:`COMPILED` is False) and the run's geometry line says so.
"""

from __future__ import annotations

import math

import numpy as np

from bracekit._compiled import COMPILED, F64, I64
from bracekit._compiled import inline as _inline
from bracekit._compiled import jit as _jit
from bracekit.kinematics.capsule_distance import capsule as _capsule
from bracekit.kinematics.clearance import _SLACK
from bracekit.kinematics.clearance import FLAT as _FLAT

__all__ = ["COMPILED", "screened_least"]


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
        value = _capsule(e[0, 0], e[0, 1], e[1, 0], e[1, 1], e[2, 0], e[2, 1], radii[i], r_max)[0]
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
