"""Clearance of the links from the bracing surface: signed distances of the link capsules and their ∂/∂q.

A robot whose URDF has collision meshes gets coal's clearance instead (:mod:`bracekit.geometry.distance`: every
mesh and primitive, the braced link included but for its pad's neighbourhood); :class:`Clearance` gives either
through the same methods, and :func:`geometry_of` says which. The rest of this docstring is the capsule rule.

The obstacle. With a radius r_max = ``Brace.obstacle_radius`` (``Brace.surface_radius``, e.g. a table top or a
post, else the bracing region's radius) it is the solid S = {p : h(p) ≤ 0, ρ(p) ≤ r_max}: the plane's disk of
radius r_max about the surface's point c and the infinite cylinder below it (the table's or post's body). Here
h(p) = n̂ᵀ(p − c) is the height over the plane (positive on the robot's side), ρ(p) = |L (p − c)| the lateral
distance from c and L = I − n̂n̂ᵀ. Without a radius the obstacle is the half-space below the whole plane.

A capsule is a segment p(t) = a + t (b − a), t ∈ [0, 1], of radius r. Its clearance is, minus r:

- half-space (no radius): the least height of the segment, min(h(a), h(b)) (h is linear in t).
- (a) penetration: if part of the segment lies over the disk (ρ ≤ r_max: the interval [t0, t1] between the
  roots of the quadratic ρ(p(t))² = r_max²; a line tangent to the cylinder within rounding touches it) below
  the plane, the least height over that part, at t0 or t1: minus the depth below the top. Also for a segment
  that entered the body from the side: there the clearance jumps from −r to minus the depth, minus r.
- (b) otherwise: the Euclidean distance D from the segment to S (0 when it touches), with
  D(p) = |(max(ρ − r_max, 0), max(h, 0))|: from the top over the disk, from the rim circle beside and above
  it, from the side below it. D is convex along the segment (S is convex); its least point t* solves
  d(D²)/dt = 0 by a Newton iteration bracketed in [0, 1] (to the rounding of t).

Several braces: each surface is an obstacle with its own rule (its braced link left out of it, and a capsule
that holds its pad at every configuration, e.g. the link before a pad at a joint's origin), and a link's
clearance is the least over the surfaces. A link's clearance is the least over its capsules; negative is
penetration. With a disk every link counts (its
clearance is finite); only the link carrying {b} (every capsule of the brace frame's joint) is left out: its
pad touches the plane by design. The ends of all capsules are placed at once, in plane coordinates, with a
lower bound each (min(h(a), h(b)) where the segment may dip below the top over the disk, else
|(max(ρ_min − r_max, 0), max(min(h(a), h(b)), 0))|, ρ_min the segment's least lateral distance); a capsule is
searched exactly only while its bound is below the least clearance found (of its link, or of all links for
:meth:`Clearance.minimum`).

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
from collections import OrderedDict
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import cache

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike, NDArray

from bracekit.geometry.collision import geometry_description, has_meshes
from bracekit.geometry.distance import MeshClearance, capsule_elements
from bracekit.kinematics.braced import BracedRobot, BracedState
from bracekit.kinematics.path_clearance import compiled_path, path_placements, path_search
from bracekit.model.chain import DATA_JOINT_LIMIT
from bracekit.model.geometry import DEFAULT_LINK_RADIUS, Capsule

Array = NDArray[np.float64]

#: cos of the angle between the segment and the cylinder's outward normal below which a clip point only grazes
#: the cylinder: its t* is held fixed (∂t*/∂q would grow without bound).
_GRAZE = 1e-9
#: |L (b − a)|² (m²) at or below which a segment has no lateral extent: it lies over the disk whole or not at all.
FLAT = 1e-28
#: Relative rounding within which a segment's line touches the cylinder (tangent to it or lying on it).
ROUND = 8.0 * 2.0**-52
#: Iteration cap of the bracketed Newton search for t* (bisection alone needs about 55 to reach rounding).
ITERATIONS = 200
#: Slack (m) on the lower bound of a capsule's distance below which it is computed exactly (rounding guard).
_SLACK = 1e-9


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


class Clearance:
    """The link clearances of a braced robot (its capsules, plane and obstacle fixed at construction).

    Args:
        braced: the braced robot; its brace gives the plane, the obstacle's radius and the excepted link.
        link_radius: radius of the default capsules, m (:data:`~bracekit.model.geometry.DEFAULT_LINK_RADIUS`).
    """

    def __init__(self, braced: BracedRobot, link_radius: float = DEFAULT_LINK_RADIUS) -> None:
        robot = braced.robot
        model = robot.model
        self.braced = braced
        #: coal's clearance of the URDF's meshes and primitives, or None: the capsules below
        self.mesh: MeshClearance | None = None
        self.capsules: tuple[Capsule, ...] = ()
        #: several braces with capsules: one Clearance per surface (its own braced link left out), least over them
        self.surfaces: tuple[Clearance, ...] = ()
        #: the capsules' clearance from the environment's further obstacles (coal), or None
        self.extra: MeshClearance | None = None
        if has_meshes(robot.geometry):  # one brace or several: MeshClearance takes each brace's surface and pad
            robot.link_capsules(link_radius)  # validates link_radius as for capsules
            self.mesh = MeshClearance(braced, robot.geometry, braced.obstacles)
            return
        if braced.obstacles:  # every capsule (the braced link's but for its pad) from each further obstacle
            elements = capsule_elements(robot.link_capsules(link_radius))
            self.extra = MeshClearance(braced, elements, braced.obstacles, surfaces=False)
        if len(braced.braces) > 1:
            self.surfaces = tuple(Clearance(BracedRobot(robot, b), link_radius)._leave_pad() for b in braced.braces)
            self.capsules = self.surfaces[0].capsules
            return
        skip = int(model.frames[braced.brace_id].parentJoint)
        self._set_capsules(tuple(c for c in robot.link_capsules(link_radius) if c.joint != skip))
        surface = braced.brace.surface
        self._normal, self._point = surface.normal, surface.point
        n = self._normal
        e1 = np.cross(n, np.eye(3)[int(np.argmin(np.abs(n)))])
        e1 /= np.linalg.norm(e1)
        #: rows: the plane's axes x, y and its normal n̂; plane coordinates are basis (p − c)
        self._basis = np.array([e1, np.cross(n, e1), n])
        r_max = braced.brace.obstacle_radius
        self._r_max = None if r_max is None else float(r_max)
        self._data = model.createData() if robot.n <= DATA_JOINT_LIMIT else None

    def _set_capsules(self, capsules: tuple[Capsule, ...]) -> None:
        """The capsules searched, with their joints, frames and ends as arrays."""
        model = self.braced.robot.model
        self.capsules = capsules
        joints = sorted({c.joint for c in self.capsules})
        self._joints = joints
        self._frames = [int(model.getFrameId(model.names[j], pin.FrameType.JOINT)) for j in joints]
        self._slot = np.array([joints.index(c.joint) for c in self.capsules], dtype=np.intp)
        self._slots = [int(k) for k in self._slot]
        #: each capsule's ends a, b as the columns of a 3×2 matrix in its joint's frame (k, 3, 2)
        self._ends = np.array([np.column_stack([c.a, c.b]) for c in self.capsules], dtype=float).reshape(-1, 3, 2)
        self._radius = np.array([c.radius for c in self.capsules], dtype=float)
        self._radii = [float(c.radius) for c in self.capsules]
        #: each capsule's joint in chain order (the link :meth:`minimum` names)
        self._capsule_joints = np.array([joints[k] - 1 for k in self._slots], dtype=np.int64)

    def _leave_pad(self) -> Clearance:
        """Itself without the capsules that hold its brace's pad {b} at every configuration (several braces).

        With several braces a pad may sit at the end of another link's capsule (a link-point brace at a joint's
        origin): that capsule touches the surface at the pad by design, as the braced link does. A capsule is
        left out when {b} lies within its radius at two configurations (the neutral one and a fixed other).
        """
        robot = self.braced.robot
        inside = np.ones(len(self.capsules), dtype=bool)
        other = np.where(
            np.isfinite(robot.lower) & np.isfinite(robot.upper), 0.3 * robot.lower + 0.7 * robot.upper, 0.7
        )
        for q in (robot.neutral(), other):
            placements, _ = self._placements(robot.check_q(q), False)
            b = self.braced.state(q).contacts[0].b
            ends = placements[self._slot, :3, :3] @ self._ends + placements[self._slot, :3, 3][:, :, None]
            a, d = ends[:, :, 0], ends[:, :, 1] - ends[:, :, 0]
            t = np.clip(np.einsum("ij,ij->i", b - a, d) / np.maximum(np.einsum("ij,ij->i", d, d), 1e-300), 0.0, 1.0)
            inside &= np.linalg.norm(a + t[:, None] * d - b, axis=1) <= self._radius + 1e-9
        if inside.any():
            self._set_capsules(tuple(c for c, drop in zip(self.capsules, inside, strict=True) if not drop))
        return self

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

    def _screen(self, placements: Array) -> tuple[list[list[list[float]]], list[float]]:
        """(Each capsule's ends in plane coordinates, [[x_a, x_b], [y_a, y_b], [h_a, h_b]] (m); lower bounds (m)).

        The lower bound of a capsule's clearance, vectorised over capsules: min(h_a, h_b) − r without a radius
        (exact) or where the segment may pass below the top over the disk (h_min < 0 and ρ_min ≤ r_max); else
        |(max(ρ_min − r_max, 0), max(h_min, 0))| − r (D ≥ it along the whole segment).
        """
        pts, bound = self._screen_arrays(placements)
        return pts.tolist(), bound.tolist()

    def _screen_arrays(self, placements: Array) -> tuple[Array, Array]:
        """:meth:`_screen` as arrays, over any leading axes of `placements` (…, J, 4, 4): ends (…, k, 3, 2), (…, k)."""
        basis = self._basis
        rot = basis @ placements[..., :3, :3]
        origin = (placements[..., :3, 3] - self._point) @ basis.T
        pts = rot[..., self._slot, :, :] @ self._ends + origin[..., self._slot, :][..., None]
        low = pts[..., 2, :].min(axis=-1)
        r_max = self._r_max
        if r_max is None:
            return pts, low - self._radius
        xa, ya = pts[..., 0, 0], pts[..., 1, 0]
        dx, dy = pts[..., 0, 1] - xa, pts[..., 1, 1] - ya
        quad = dx * dx + dy * dy
        half = xa * dx + ya * dy
        with np.errstate(invalid="ignore", divide="ignore"):
            tm = np.where(quad > FLAT, np.clip(-half / quad, 0.0, 1.0), 0.0)  # the least lateral distance's t
        rho = np.sqrt(np.maximum((quad * tm + 2.0 * half) * tm + xa * xa + ya * ya, 0.0))
        side = rho - r_max
        bound = np.where((low < 0.0) & (side <= _SLACK), low, np.hypot(np.maximum(side, 0.0), np.maximum(low, 0.0)))
        return pts, bound - self._radius

    def _gradient(
        self,
        ends: list[list[float]],
        t: float,
        direction: tuple[float, float, float],
        clip: bool,
        jac: Array,
        origin: Array,
    ) -> Array:
        """uᵀ∂p/∂q (n,) at the least point t of a capsule (plane coordinates), with a clip point's motion."""
        (x0, x1), (y0, y1), (h0, h1) = ends
        at = (x1, y1, h1) if t == 1.0 else (x0 + t * (x1 - x0), y0 + t * (y1 - y0), h0 + t * (h1 - h0))
        basis = self._basis
        arm = self._point + np.array(at) @ basis - origin
        grad = _point_row(np.array(direction) @ basis, arm, jac)
        if clip:  # (a) at a clip point on the cylinder: t* moves with q
            dx, dy, slope = x1 - x0, y1 - y0, h1 - h0
            w = (at[0], at[1])  # L (p − c), |w| = r_max
            rate = w[0] * dx + w[1] * dy  # ½ ∂g/∂t
            if abs(rate) > _GRAZE * math.hypot(*w) * math.sqrt(dx * dx + dy * dy + slope * slope):
                dw = _point_row(w[0] * basis[0] + w[1] * basis[1], arm, jac)  # wᵀ∂p/∂q = ½ ∂g/∂q
                grad = grad - (slope / rate) * dw
        return grad

    def links(self, q: ArrayLike, gradient: bool = True, below: float = math.inf) -> list[LinkDistance]:
        """Each link's clearance (m) and, if `gradient`, its ∂/∂q (n,), in chain order.

        Every link with a capsule is listed (the brace's link excepted; its clearance is finite), or only those
        whose clearance is below `below` (m; the others are not searched exactly). Without capsules: empty.
        """
        qa = self.braced.robot.check_q(q)
        if self.mesh is not None:
            return [LinkDistance(j, v, g) for j, v, g in self.mesh.links(qa, gradient, below)]
        if self.extra is not None:  # the least of the surface's rule and the further obstacles', per link
            least = {d.joint: d for d in self._links(qa, gradient, below)}
            for j, v, g in self.extra.links(qa, gradient, below):
                if j not in least or v < least[j].clearance:
                    least[j] = LinkDistance(j, v, g)
            return [least[j] for j in sorted(least)]
        return self._links(qa, gradient, below)

    def _links(self, qa: Array, gradient: bool, below: float) -> list[LinkDistance]:
        """:meth:`links` from the bracing surfaces alone (capsules)."""
        if self.surfaces:
            least: dict[int, LinkDistance] = {}
            for each in self.surfaces:
                for d in each.links(qa, gradient, below):
                    if d.joint not in least or d.clearance < least[d.joint].clearance:
                        least[d.joint] = d
            return [least[j] for j in sorted(least)]
        if not self.capsules:
            return []
        placements, jacs = self._placements(qa, gradient)
        ends, bounds = self._screen(placements)
        slots, radii = self._slots, self._radii
        best: dict[int, tuple[float, int, float, tuple[float, float, float], bool]] = {}
        for i in sorted(range(len(slots)), key=lambda k: (slots[k], bounds[k])):
            slot = slots[i]
            held = best[slot][0] if slot in best else below
            if bounds[i] - _SLACK >= held:
                continue
            value, t, direction, clip = _rule()(ends[i], radii[i], self._r_max)
            if value < held:
                best[slot] = (value, i, t, direction, clip)
        out = []
        for slot, (value, i, t, direction, clip) in sorted(best.items()):
            grad = np.zeros(0)
            if jacs is not None:
                grad = self._gradient(ends[i], t, direction, clip, jacs[slot], placements[slot, :3, 3])
            out.append(LinkDistance(self._joints[slot] - 1, value, grad))
        return out

    def minimum(self, q: ArrayLike) -> tuple[float, int]:
        """(The least clearance, m; its link's joint in chain order); (inf, −1) only when there are no capsules.

        Exact: capsules are evaluated in the order of their lower bounds until the bound passes the least found.
        """
        qa = self.braced.robot.check_q(q)
        if self.mesh is not None:
            return self.mesh.minimum(qa)
        if self.extra is not None:
            return min(self._minimum(qa), self.extra.minimum(qa))
        return self._minimum(qa)

    def _minimum(self, qa: Array) -> tuple[float, int]:
        """:meth:`minimum` from the bracing surfaces alone (capsules)."""
        if self.surfaces:
            return min((each.minimum(qa) for each in self.surfaces), default=(math.inf, -1))
        if not self.capsules:
            return math.inf, -1
        placements, _ = self._placements(qa, False)
        ends, bounds = self._screen(placements)
        return self._least(ends, bounds)

    def minima(self, qs: Sequence[Array]) -> tuple[Array, NDArray[np.intp]]:
        """:meth:`minimum` of each configuration of a path (N arrays (n,)): the clearances (N,) m and joints (N,).

        The capsules of every configuration are placed and bounded at once; each is then searched as by
        :meth:`minimum` (compiled over the path where numba is installed, :func:`path_search`), so the values
        are the same to rounding. Coal's further obstacles and meshes are taken one configuration at a time.
        """
        if self.mesh is not None or not len(qs):
            found = [self.minimum(q) for q in qs]
            return np.array([v for v, _ in found], dtype=float), np.array([j for _, j in found], dtype=np.intp)
        values, joints = self._minima(qs)
        if self.extra is not None:  # the least (clearance, joint) with the further obstacles', as minimum
            check = self.braced.robot.check_q
            for i, q in enumerate(qs):
                v, j = self.extra.minimum(check(q))
                if (v, j) < (values[i], joints[i]):
                    values[i], joints[i] = v, j
        return values, joints

    def _minima(self, qs: Sequence[Array]) -> tuple[Array, NDArray[np.intp]]:
        """:meth:`minima` from the bracing surfaces alone (capsules)."""
        searched = [self] if not self.surfaces else list(self.surfaces)
        if any(not each.capsules or each._data is None for each in searched):
            found = [self._minimum(self.braced.robot.check_q(q)) for q in qs]
            return np.array([v for v, _ in found], dtype=float), np.array([j for _, j in found], dtype=np.intp)
        frames = sorted({f for each in searched for f in each._frames})
        # every surface's capsule frames, one kinematics pass per configuration
        placed = path_placements(self.braced.robot, searched[0]._data, qs, frames)
        values, joints = searched[0]._search(placed[:, [frames.index(f) for f in searched[0]._frames]])
        for each in searched[1:]:  # the least (clearance, joint) over the surfaces, as minimum
            v, j = each._search(placed[:, [frames.index(f) for f in each._frames]])
            better = (v < values) | ((v == values) & (j < joints))
            values, joints = np.where(better, v, values), np.where(better, j, joints)
        return values, joints

    def _search(self, placements: Array) -> tuple[Array, NDArray[np.intp]]:
        """(Least clearance, its joint) of each configuration from its capsule frames' placements (N, J, 4, 4)."""
        kernel = compiled_path()
        if kernel is not None:  # the same screen and search, compiled over the path
            values, links = np.empty(len(placements)), np.empty(len(placements), dtype=np.int64)
            r_max = -1.0 if self._r_max is None else self._r_max
            local, slot, joints = self._ends, self._slot.astype(np.int64), self._capsule_joints
            kernel.screened_least(
                placements, self._basis, self._point, slot, local, self._radius, joints, r_max, values, links
            )
            return values, links.astype(np.intp)
        ends, bounds = self._screen_arrays(placements)
        found = [self._least(e, b) for e, b in zip(ends.tolist(), bounds.tolist(), strict=True)]
        return np.array([v for v, _ in found], dtype=float), np.array([j for _, j in found], dtype=np.intp)

    def _least(self, ends: list[list[list[float]]], bounds: list[float]) -> tuple[float, int]:
        """(Least clearance, its joint) from the capsules' ends and bounds of one configuration (:meth:`_screen`)."""
        low, link = math.inf, -1
        for i in sorted(range(len(bounds)), key=bounds.__getitem__):
            if bounds[i] - _SLACK > low:
                break
            value = _rule()(ends[i], self._radii[i], self._r_max)[0]
            joint = self._joints[self._slots[i]] - 1
            if (value, joint) < (low, link):
                low, link = value, joint
        return low, link


@cache
def _rule() -> Callable[..., tuple[float, float, tuple[float, float, float], bool]]:
    """:func:`~bracekit.kinematics.capsule_distance.capsule_distance`, imported on first use (it imports numba)."""
    from bracekit.kinematics.capsule_distance import capsule_distance

    return capsule_distance


def _point_row(u: Array, arm: Array, jac: Array) -> Array:
    """uᵀ∂p/∂q = uᵀ(J_v − [arm]× J_ω) = uᵀJ_v + (arm × u)ᵀ J_ω (n,) for the point at `arm` from the joint (m)."""
    ax, ay, az = arm.tolist()
    ux, uy, uz = u.tolist()
    return np.array([ux, uy, uz, ay * uz - az * uy, az * ux - ax * uz, ax * uy - ay * ux]) @ jac


def geometry_of(braced: BracedRobot) -> str:
    """What the clearance of `braced` is computed from, for a run's summary.

    E.g. "capsules (no collision geometry in the URDF)" or "meshes and primitives from the URDF (7 elements, coal)".
    """
    robot = braced.robot
    text = geometry_description(robot.geometry, len({c.link for c in robot.collisions}))
    search = "" if has_meshes(robot.geometry) or path_search() == "compiled" else f"; path searched in {path_search()}"
    return text + search


def link_clearance(state: BracedState, link_radius: float = DEFAULT_LINK_RADIUS) -> tuple[float, int]:
    """(Minimum link clearance from the bracing surface, m; the index of that link's joint in chain order).

    Negative is penetration; (inf, −1) only when the robot has no capsule besides the brace's link. The rule is
    in this module's docstring.
    """
    return _clearance(state.braced, link_radius).minimum(state.q)


def link_clearances(
    braced: BracedRobot, qs: Sequence[Array], link_radius: float = DEFAULT_LINK_RADIUS
) -> tuple[Array, NDArray[np.intp]]:
    """:func:`link_clearance` at each configuration of a path (N arrays (n,)), at once: clearances (N,) m, joints."""
    return _clearance(braced, link_radius).minima(qs)


def link_clearance_gradient(state: BracedState, link_radius: float = DEFAULT_LINK_RADIUS) -> Array:
    """∂/∂q (n,) of the minimum link clearance (of the link :func:`link_clearance` names); zeros without capsules."""
    found = _clearance(state.braced, link_radius).links(state.q)
    if not found:
        return np.zeros(state.q.size)
    return min(found, key=lambda d: d.clearance).gradient


#: (braced robot, link radius) → its Clearance, the CACHE_SIZE used last: built once per model (capsules or
#: coal's pieces, frames, data), not per sample. Bounded, since a Clearance holds its braced robot (a weak-keyed
#: cache would keep every robot it saw alive through its value).
_CACHE: OrderedDict[tuple[BracedRobot, float], Clearance] = OrderedDict()
CACHE_SIZE = 8


def _clearance(braced: BracedRobot, link_radius: float) -> Clearance:
    if isinstance(link_radius, bool) or not isinstance(link_radius, int | float):
        return Clearance(braced, link_radius)  # validates (and refuses) it
    key = (braced, float(link_radius))
    if key in _CACHE:
        _CACHE.move_to_end(key)
        return _CACHE[key]
    found = _CACHE[key] = Clearance(braced, link_radius)
    while len(_CACHE) > CACHE_SIZE:
        _CACHE.popitem(last=False)
    return found
