"""Clearance of the links from the bracing plane: signed distances of the link capsules and their ∂/∂q.

The rule: a capsule's clearance is the least signed distance from the plane (n̂ᵀ(p − point), positive on the
robot's side) over the part of its segment p(t) = a + t (b − a), t ∈ [0, 1], that lies over the obstacle,
minus the capsule's radius; a link's clearance is the least over its capsules. The obstacle is the plane's disk
of radius r_max = ``Brace.obstacle_radius`` about the surface's point c (``Brace.surface_radius``, e.g. a table
top, else the bracing region's radius); without either the whole plane is the obstacle and the part is the whole
segment. With a disk the segment is clipped to the infinite
cylinder over the disk, |L (p(t) − c)| ≤ r_max with L = I − n̂n̂ᵀ, a quadratic in t whose roots bound the
interval [t0, t1] (empty: the capsule does not count). The distance is linear in t, so its least value over
[t0, t1] is at t0 or t1. The link carrying {b} (every capsule of the brace frame's joint) is left out: its pad
touches the plane by design. Negative clearance is penetration.

The gradient at the least point p(t*) is n̂ᵀ(∂p/∂q) + n̂ᵀ(b − a) dt*/dq. ∂p/∂q = (1 − t*) J_a + t* J_b, the
linear rows of the point Jacobian (LOCAL_WORLD_ALIGNED) at p(t*), the joint's Jacobian shifted to the point:
J_p = J_v − [p − o]× J_ω. dt*/dq is 0 where t* is an end of the segment (0 or 1) and, where t* is a clip
point on the cylinder, follows from g(t, q) = |L (p(t) − c)|² − r_max² = 0: dt*/dq = −(∂g/∂q)/(∂g/∂t) =
−wᵀ(∂p/∂q) / (wᵀ(b − a)) with w = L (p(t*) − c). Where the segment only grazes the cylinder (wᵀ(b − a) ≈ 0)
the clip point is held fixed (dt*/dq = 0).
"""

from __future__ import annotations

import math
import weakref
from dataclasses import dataclass

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike, NDArray

from bracekit.kinematics.braced import BracedRobot, BracedState
from bracekit.model.chain import DATA_JOINT_LIMIT
from bracekit.model.geometry import DEFAULT_LINK_RADIUS, Capsule

Array = NDArray[np.float64]

#: |L (b − a)|² (m²) at or below which a segment has no lateral extent: it lies over the disk whole or not at all.
_FLAT = 1e-28
#: cos of the angle between the segment and the cylinder's outward normal below which a clip point only grazes
#: the cylinder: its t* is held fixed (∂t*/∂q would grow without bound).
_GRAZE = 1e-9
#: Tolerance on the segment parameter t of the golden-section search for the point nearest the solid.
_T_TOL = 1e-9


@dataclass(frozen=True)
class LinkDistance:
    """One link's clearance at a configuration.

    Attributes:
        joint: the link's joint in chain order (0-based).
        clearance: m, negative = penetration.
        gradient: ∂clearance/∂q (n,).
    """

    joint: int
    clearance: float
    gradient: Array


class Clearance:
    """The link clearances of a braced robot (its capsules, plane and region fixed at construction).

    Args:
        braced: the braced robot; its brace gives the plane, the region and the excepted link.
        link_radius: radius of the default capsules, m (:data:`~bracekit.model.geometry.DEFAULT_LINK_RADIUS`).
    """

    def __init__(self, braced: BracedRobot, link_radius: float = DEFAULT_LINK_RADIUS) -> None:
        robot = braced.robot
        model = robot.model
        skip = int(model.frames[braced.brace_id].parentJoint)
        self.braced = braced
        self.capsules: tuple[Capsule, ...] = tuple(c for c in robot.link_capsules(link_radius) if c.joint != skip)
        joints = sorted({c.joint for c in self.capsules})
        self._joints = joints
        self._frames = [int(model.getFrameId(model.names[j], pin.FrameType.JOINT)) for j in joints]
        surface = braced.brace.surface
        self._normal, self._point = surface.normal, surface.point
        self._r_max = braced.brace.obstacle_radius
        self._data = model.createData() if robot.n <= DATA_JOINT_LIMIT else None

    def _interval(self, pa: Array, d: Array, slope: float) -> tuple[float, float] | None:
        """[t0, t1] ⊆ [0, 1] of the segment pa + t d (world, m) over the region's disk; None if no part is.

        `slope` is n̂ᵀd. Without a region it is [0, 1]. The roots of |L (pa + t d − c)|² = r_max² come from
        the quadratic's stable form; a segment with no lateral extent (|L d|² ≤ 1e-28 m²) counts whole or not
        at all.
        """
        r_max = self._r_max
        if r_max is None:
            return 0.0, 1.0
        n = self._normal
        u = pa - self._point
        u = u - n * float(n @ u)  # L (a − c), L = I − n̂n̂ᵀ the lateral projection
        v = d - n * slope  # L d, projected (not |d|² − slope²: exact for near-normal segments)
        quad = float(v @ v)
        half = float(u @ v)
        const = float(u @ u) - r_max * r_max
        if quad <= _FLAT:
            return (0.0, 1.0) if const <= 0.0 else None
        disc = half * half - quad * const
        if disc < 0.0:
            return None
        qq = -(half + math.copysign(math.sqrt(disc), half))
        lo, hi = (qq / quad, const / qq) if qq != 0.0 else (0.0, 0.0)
        if lo > hi:
            lo, hi = hi, lo
        t0, t1 = max(lo, 0.0), min(hi, 1.0)
        return (t0, t1) if t0 <= t1 else None

    def _point_distance(self, p: Array) -> tuple[float, Array]:
        """Distance (m) of p (3,) from the solid (the disk and the cylinder below it) and its unit ∂/∂p (3,).

        Inside the solid or on its top the distance is max(h, 0) with direction n̂ (h the height over the plane).
        """
        n, r_max = self._normal, float(self._r_max)  # type: ignore[arg-type]
        rel = p - self._point
        h = float(n @ rel)
        w = rel - n * h
        rho = float(np.linalg.norm(w))
        if rho <= r_max:
            return max(h, 0.0), n
        out = w / rho
        if h <= 0.0:
            return rho - r_max, out
        dist = math.hypot(rho - r_max, h)
        return dist, ((rho - r_max) * out + h * n) / dist

    def _solid_distance(self, pa: Array, d: Array) -> tuple[float, float, Array]:
        """(t*, distance, unit direction) of the point of the segment pa + t d nearest the solid (t ∈ [0, 1]).

        The distance from a convex solid is convex along a segment: golden-section search to 1e-9 of t.
        """
        lo, hi = 0.0, 1.0
        ratio = 0.5 * (math.sqrt(5.0) - 1.0)
        x1, x2 = hi - ratio * (hi - lo), lo + ratio * (hi - lo)
        f1, f2 = self._point_distance(pa + x1 * d)[0], self._point_distance(pa + x2 * d)[0]
        while hi - lo > _T_TOL:
            if f1 <= f2:
                hi, x2, f2 = x2, x1, f1
                x1 = hi - ratio * (hi - lo)
                f1 = self._point_distance(pa + x1 * d)[0]
            else:
                lo, x1, f1 = x1, x2, f2
                x2 = lo + ratio * (hi - lo)
                f2 = self._point_distance(pa + x2 * d)[0]
        best = min((0.0, 0.5 * (lo + hi), 1.0), key=lambda t: self._point_distance(pa + t * d)[0])
        dist, direction = self._point_distance(pa + best * d)
        return best, dist, direction

    def links(self, q: ArrayLike, gradient: bool = True) -> list[LinkDistance]:
        """Each link with a capsule segment over the region's disk: its clearance (m) and, if `gradient`, ∂/∂q (n,).

        Links none of whose capsule segments passes over the region's disk are left out.
        """
        robot = self.braced.robot
        qa = robot.check_q(q)
        kin: dict[int, tuple[Array, Array | None]]
        if gradient or self._data is None:
            kin = dict(zip(self._joints, robot.frame_kinematics(qa, self._frames), strict=True))
        else:  # placements only: forward kinematics with this object's own data, no Jacobians
            model, data = robot.model, self._data
            pin.forwardKinematics(model, data, qa)
            pin.updateFramePlacements(model, data)
            kin = {j: (data.oMf[f].homogeneous, None) for j, f in zip(self._joints, self._frames, strict=True)}
        best: dict[int, tuple[float, Array | None]] = {}
        n = self._normal
        for cap in self.capsules:
            m, jac = kin[cap.joint]
            rot, origin = m[:3, :3], m[:3, 3]
            pa, pb = origin + rot @ cap.a, origin + rot @ cap.b
            d = pb - pa
            slope = float(n @ d)  # n̂ᵀ(b − a): the distance's rate along the segment
            span = self._interval(pa, d, slope)
            t, value, direction = -1.0, math.inf, n
            if span is not None:  # the part over the disk: its least height
                t = span[1] if slope < 0.0 else span[0]
                p = pa if t == 0.0 else pb if t == 1.0 else pa + t * d
                value = float(n @ (p - self._point)) - cap.radius
            if self._r_max is not None and (span is None or value + cap.radius >= 0.0):
                # the segment keeps out of the solid: its distance from it (from the side, the rim or the top)
                t, dist, direction = self._solid_distance(pa, d)
                p = pa + t * d
                value = dist - cap.radius
            if cap.joint in best and best[cap.joint][0] <= value:
                continue
            grad = None
            if gradient and jac is not None:
                arm = p - origin
                # uᵀ∂p/∂q = uᵀ(J_v − [arm]× J_ω) = uᵀJ_v + (arm × u)ᵀ J_ω, u = n̂ or the distance's direction
                grad = direction @ jac[:3] + np.cross(arm, direction) @ jac[3:]
                if direction is n and 0.0 < t < 1.0 and slope != 0.0:  # a clip point on the cylinder: t* moves
                    rel = p - self._point
                    w = rel - n * float(n @ rel)  # L (p − c), |w| = r_max
                    rate = float(w @ d)  # ½ ∂g/∂t
                    if abs(rate) > _GRAZE * float(np.linalg.norm(w)) * float(np.linalg.norm(d)):
                        dw = w @ jac[:3] + np.cross(arm, w) @ jac[3:]  # wᵀ∂p/∂q = ½ ∂g/∂q
                        grad = grad - (slope / rate) * dw
            best[cap.joint] = (value, grad)
        return [LinkDistance(j - 1, v, g if g is not None else np.zeros(0)) for j, (v, g) in sorted(best.items())]

    def minimum(self, q: ArrayLike) -> tuple[float, int]:
        """(The least clearance, m; its link's joint in chain order); (inf, −1) if no link counts."""
        found = self.links(q, gradient=False)
        if not found:
            return math.inf, -1
        low = min(found, key=lambda d: d.clearance)
        return low.clearance, low.joint


def link_clearance(state: BracedState, link_radius: float = DEFAULT_LINK_RADIUS) -> tuple[float, int]:
    """(Minimum link clearance from the bracing plane, m; the index of that link's joint in chain order).

    Negative is penetration; (inf, −1) when no link is over the bracing region. The rule is in this module's
    docstring.
    """
    return _clearance(state.braced, link_radius).minimum(state.q)


def link_clearance_gradient(state: BracedState, link_radius: float = DEFAULT_LINK_RADIUS) -> Array:
    """∂/∂q (n,) of the minimum link clearance (of the link :func:`link_clearance` names); zeros if none counts."""
    found = _clearance(state.braced, link_radius).links(state.q)
    if not found:
        return np.zeros(state.q.size)
    return min(found, key=lambda d: d.clearance).gradient


#: braced robot → {link radius: its Clearance}: built once per model (capsules, frames, data), not per sample.
_CACHE: weakref.WeakKeyDictionary[BracedRobot, dict[float, Clearance]] = weakref.WeakKeyDictionary()


def _clearance(braced: BracedRobot, link_radius: float) -> Clearance:
    if isinstance(link_radius, bool) or not isinstance(link_radius, int | float):
        return Clearance(braced, link_radius)  # validates (and refuses) it
    per = _CACHE.setdefault(braced, {})
    if link_radius not in per:
        per[link_radius] = Clearance(braced, link_radius)
    return per[link_radius]
