"""Clearance of the links from the bracing surface: signed distances of the link capsules and their ∂/∂q.

The obstacle. With a radius r_max = ``Brace.obstacle_radius`` (``Brace.surface_radius``, e.g. a table top or a
post, else the bracing region's radius) it is the solid S = {p : h(p) ≤ 0, ρ(p) ≤ r_max}: the plane's disk of
radius r_max about the surface's point c and the infinite cylinder below it (the table's or post's body). Here
h(p) = n̂ᵀ(p − c) is the height over the plane (positive on the robot's side), ρ(p) = |L (p − c)| the lateral
distance from c and L = I − n̂n̂ᵀ. Without a radius the obstacle is the half-space below the whole plane.

A capsule is a segment p(t) = a + t (b − a), t ∈ [0, 1], of radius r. Its clearance is, minus r:

- half-space (no radius): the least height of the segment, min(h(a), h(b)) (h is linear in t).
- (a) penetration: if part of the segment lies over the disk (ρ ≤ r_max: the interval [t0, t1] between the
  roots of the quadratic ρ(p(t))² = r_max²) below the plane, the least height over that part, at t0 or t1: minus
  the depth below the top (also for a segment that entered the body from the side).
- (b) otherwise: the Euclidean distance D from the segment to S (0 when it touches), with
  D(p) = |(max(ρ − r_max, 0), max(h, 0))|: from the top over the disk, from the rim circle beside and above
  it, from the side below it. D is convex along the segment (S is convex); its least point t* solves
  d(D²)/dt = 0 by a Newton iteration bracketed in [0, 1] (to the rounding of t).

A link's clearance is the least over its capsules; negative is penetration. With a disk every link counts (its
clearance is finite); only the link carrying {b} (every capsule of the brace frame's joint) is left out: its
pad touches the plane by design.

The gradient at the least point p(t*) is uᵀ∂p/∂q with ∂p/∂q = (1 − t*) J_a + t* J_b, the linear rows of the
point Jacobian (LOCAL_WORLD_ALIGNED) at p(t*): the joint's Jacobian shifted to the point,
J_p = J_v − [p − o]× J_ω. u = n̂ for the half-space, in case (a) and in case (b) over the disk; beside the disk
u = ∇D, the unit vector from the nearest point of S to p(t*). In case (b) t*'s own motion does not count
(envelope theorem: t* minimises D along the segment and D is C¹ outside S). In case (a) a clip point
t* ∈ (0, 1) on the cylinder moves with q: from g(t, q) = ρ(p(t))² − r_max² = 0,
dt*/dq = −wᵀ(∂p/∂q) / (wᵀ(b − a)) with w = L (p(t*) − c), which adds n̂ᵀ(b − a) dt*/dq. Where the segment
only grazes the cylinder (wᵀ(b − a) ≈ 0) the clip point is held fixed (dt*/dq = 0).
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
#: Slack (m) on the lower bound of a capsule's distance below which it is computed exactly (rounding guard).
_SLACK = 1e-9
#: Iteration cap of the bracketed Newton search for t* (bisection alone needs about 55 to reach rounding).
_ITERATIONS = 200


@dataclass(frozen=True)
class LinkDistance:
    """One link's clearance at a configuration.

    Attributes:
        joint: the link's joint in chain order (0-based).
        clearance: m, negative = penetration.
        gradient: ∂clearance/∂q (n,); empty when not asked for.
    """

    joint: int
    clearance: float
    gradient: Array


@dataclass(frozen=True)
class _Screen:
    """Every capsule's end points and what is known of its clearance before the exact search (world frame, m).

    Attributes:
        pa, pb: end points (k, 3).
        value: the clearance where it is known exactly (half-space, case (a)), else the lower bound
            |(max(ρ_min − r_max, 0), max(min(h(a), h(b)), 0))| − r of case (b) (k,).
        t: the least point's segment parameter where known (k,).
        exact: whether `value` is exact (k,).
    """

    pa: Array
    pb: Array
    value: Array
    t: Array
    exact: NDArray[np.bool_]


def _least_t(h0: float, slope: float, quad: float, half: float, gam: float, r_max: float) -> float:
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
    for _ in range(_ITERATIONS):
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


class Clearance:
    """The link clearances of a braced robot (its capsules, plane and obstacle fixed at construction).

    Args:
        braced: the braced robot; its brace gives the plane, the obstacle's radius and the excepted link.
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
        self._slot = np.array([joints.index(c.joint) for c in self.capsules], dtype=np.intp)
        self._a = np.array([c.a for c in self.capsules], dtype=float).reshape(-1, 3, 1)
        self._b = np.array([c.b for c in self.capsules], dtype=float).reshape(-1, 3, 1)
        self._radius = np.array([c.radius for c in self.capsules], dtype=float)
        surface = braced.brace.surface
        self._normal, self._point = surface.normal, surface.point
        self._r_max = braced.brace.obstacle_radius
        self._data = model.createData() if robot.n <= DATA_JOINT_LIMIT else None

    def _placements(self, qa: Array, gradient: bool) -> tuple[Array, list[Array] | None]:
        """(⁰M of each capsule joint's frame (J, 4, 4); their LOCAL_WORLD_ALIGNED Jacobians (6×n) or None)."""
        robot = self.braced.robot
        if gradient or self._data is None:
            kin = robot.frame_kinematics(qa, self._frames)
            return np.array([m for m, _ in kin]), [j for _, j in kin] if gradient else None
        model, data = robot.model, self._data  # placements only: this object's own data, no Jacobians
        pin.forwardKinematics(model, data, qa)
        pin.updateFramePlacements(model, data)
        return np.array([data.oMf[f].homogeneous for f in self._frames]), None

    def _screen(self, placements: Array) -> _Screen:
        """The capsules' end points and their exact clearance or case-(b) lower bound, vectorised over capsules."""
        m = placements[self._slot]
        rot, origin = m[:, :3, :3], m[:, :3, 3]
        pa = (rot @ self._a)[:, :, 0] + origin
        pb = (rot @ self._b)[:, :, 0] + origin
        n, c, radius = self._normal, self._point, self._radius
        ha, hb = (pa - c) @ n, (pb - c) @ n
        d = pb - pa
        slope = d @ n
        low_b = slope < 0.0  # the least height of the segment (or of its part over the disk) is at its b side
        r_max = self._r_max
        if r_max is None:
            value = np.where(low_b, hb, ha) - radius
            return _Screen(pa, pb, value, low_b.astype(float), np.ones(len(radius), bool))
        u = pa - c
        u -= np.outer(u @ n, n)  # L (a − c)
        v = d - np.outer(slope, n)  # L d
        quad = np.einsum("ij,ij->i", v, v)
        half = np.einsum("ij,ij->i", u, v)
        gam = np.einsum("ij,ij->i", u, u)
        const = gam - r_max * r_max
        flat = quad <= _FLAT
        with np.errstate(invalid="ignore", divide="ignore"):
            disc = half * half - quad * const
            qq = -(half + np.copysign(np.sqrt(np.maximum(disc, 0.0)), half))
            r1 = np.where(qq != 0.0, qq / quad, 0.0)
            r2 = np.where(qq != 0.0, const / qq, 0.0)
            t0 = np.where(flat, 0.0, np.maximum(np.minimum(r1, r2), 0.0))
            t1 = np.where(flat, 1.0, np.minimum(np.maximum(r1, r2), 1.0))
            over = np.where(flat, const <= 0.0, (disc >= 0.0) & (t0 <= t1))
            t = np.where(low_b, t1, t0)
            height = np.where(t == 0.0, ha, np.where(t == 1.0, hb, ha + t * slope))
            inside = over & (height < 0.0)  # case (a)
            tm = np.where(flat, 0.0, np.clip(-half / quad, 0.0, 1.0))  # the segment's least lateral distance
        rho = np.sqrt(np.maximum((quad * tm + 2.0 * half) * tm + gam, 0.0))
        bound = np.hypot(np.maximum(rho - r_max, 0.0), np.maximum(np.minimum(ha, hb), 0.0))
        value = np.where(inside, height, bound) - radius
        return _Screen(pa, pb, value, t, inside)

    def _exact(self, screen: _Screen, i: int) -> tuple[float, float, Array]:
        """(clearance m, t*, unit direction u) of capsule i, case (b) (the distance to the solid minus r)."""
        n, c = self._normal, self._point
        r_max = float(self._r_max)  # type: ignore[arg-type]
        pa, d = screen.pa[i], screen.pb[i] - screen.pa[i]
        rel = pa - c
        h0, slope = float(rel @ n), float(d @ n)
        u, v = rel - n * h0, d - n * slope
        t = _least_t(h0, slope, float(v @ v), float(u @ v), float(u @ u), r_max)
        p = screen.pb[i] if t == 1.0 else pa + t * d
        rel = p - c
        h = float(rel @ n)
        w = rel - n * h
        rho = math.sqrt(float(w @ w))
        side, top = max(rho - r_max, 0.0), max(h, 0.0)
        dist = math.hypot(side, top)
        direction = n if side == 0.0 or dist == 0.0 else (side / rho * w + top * n) / dist
        return dist - float(self._radius[i]), t, direction

    def _gradient(self, screen: _Screen, i: int, t: float, direction: Array, jac: Array, origin: Array) -> Array:
        """uᵀ∂p/∂q (n,) at capsule i's least point t (with a clip point's motion in case (a))."""
        n = self._normal
        pa, pb = screen.pa[i], screen.pb[i]
        d = pb - pa
        p = pa if t == 0.0 else pb if t == 1.0 else pa + t * d
        arm = p - origin
        # uᵀ∂p/∂q = uᵀ(J_v − [arm]× J_ω) = uᵀJ_v + (arm × u)ᵀ J_ω
        grad: Array = direction @ jac[:3] + np.cross(arm, direction) @ jac[3:]
        slope = float(n @ d)
        if screen.exact[i] and self._r_max is not None and 0.0 < t < 1.0 and slope != 0.0:  # (a): t* moves
            rel = p - self._point
            w = rel - n * float(n @ rel)  # L (p − c), |w| = r_max
            rate = float(w @ d)  # ½ ∂g/∂t
            if abs(rate) > _GRAZE * float(np.linalg.norm(w)) * float(np.linalg.norm(d)):
                dw = w @ jac[:3] + np.cross(arm, w) @ jac[3:]  # wᵀ∂p/∂q = ½ ∂g/∂q
                grad = grad - (slope / rate) * dw
        return grad

    def links(self, q: ArrayLike, gradient: bool = True, below: float = math.inf) -> list[LinkDistance]:
        """Each link's clearance (m) and, if `gradient`, its ∂/∂q (n,), in chain order.

        With a radius every link with a capsule is listed (the brace's link excepted); without capsules the
        list is empty. Only links whose clearance is below `below` (m) are listed (the rest are not computed).
        """
        qa = self.braced.robot.check_q(q)
        if not self.capsules:
            return []
        placements, jacs = self._placements(qa, gradient)
        screen = self._screen(placements)
        best: dict[int, tuple[float, int, float, Array]] = {}
        n = self._normal
        order = sorted(range(len(self.capsules)), key=lambda k: (self._slot[k], screen.value[k]))
        for i in order:
            slot = int(self._slot[i])
            bound = float(screen.value[i])
            held = best[slot][0] if slot in best else below
            if bound - (0.0 if screen.exact[i] else _SLACK) >= held:
                continue
            if screen.exact[i]:
                value, t, direction = bound, float(screen.t[i]), n
            else:
                value, t, direction = self._exact(screen, i)
            if value < held:
                best[slot] = (value, i, t, direction)
        out = []
        for slot, (value, i, t, direction) in sorted(best.items()):
            grad = np.zeros(0)
            if jacs is not None:
                grad = self._gradient(screen, i, t, direction, jacs[slot], placements[slot, :3, 3])
            out.append(LinkDistance(self._joints[slot] - 1, value, grad))
        return out

    def minimum(self, q: ArrayLike) -> tuple[float, int]:
        """(The least clearance, m; its link's joint in chain order); (inf, −1) only when there are no capsules.

        Exact: capsules are searched in the order of their lower bounds, until the bound passes the least found.
        """
        qa = self.braced.robot.check_q(q)
        if not self.capsules:
            return math.inf, -1
        placements, _ = self._placements(qa, False)
        screen = self._screen(placements)
        low, link = math.inf, -1
        for i in np.lexsort((self._slot, screen.value)):
            bound, joint = float(screen.value[i]), self._joints[self._slot[i]] - 1
            if screen.exact[i]:
                value = bound
            elif bound - _SLACK > low:
                break
            else:
                value = self._exact(screen, int(i))[0]
            if (value, joint) < (low, link):
                low, link = value, joint
        return low, link


def link_clearance(state: BracedState, link_radius: float = DEFAULT_LINK_RADIUS) -> tuple[float, int]:
    """(Minimum link clearance from the bracing surface, m; the index of that link's joint in chain order).

    Negative is penetration; (inf, −1) only when the robot has no capsule besides the brace's link. The rule is
    in this module's docstring.
    """
    return _clearance(state.braced, link_radius).minimum(state.q)


def link_clearance_gradient(state: BracedState, link_radius: float = DEFAULT_LINK_RADIUS) -> Array:
    """∂/∂q (n,) of the minimum link clearance (of the link :func:`link_clearance` names); zeros without capsules."""
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
