"""Link clearance from the URDF's collision geometry: coal's signed distance of every link from every obstacle.

The clearance of a link is the least signed distance (m, negative = penetration depth) between its convex
pieces (:mod:`bracekit.geometry.pieces`) and the obstacles (:mod:`bracekit.geometry.obstacles`): coal's
``distance`` (GJK, and EPA in penetration) with a DistanceRequest. The braced link counts like any other link,
with the surface within ``Brace.pad_radius`` of its pad left out (the pad touches the surface by design).

Broad phase (:mod:`bracekit.geometry._screen`, compiled, all pieces at once): each piece's bounding sphere gives
a lower and, for the surface's solid, an upper bound of its distance; a pair whose lower bound is not below the
least upper bound (or the least value found, or the asked `below`) is never computed. A polytope piece over the
surface's disk and above it (any piece for the half-space) is its extreme points' least height away (h is
linear), one reaching into the solid gets the signed distance of its deepest point (:mod:`bracekit.geometry._depth`,
the least over its hull, not only its extreme points), and one beside the disk whose nearest point a few
Frank–Wolfe steps reach is that point's distance: these are exact without coal. Coal runs on the pairs left, in
the order of their bounds, only while the bound is below the least value found (of their link, or of all links
for :meth:`MeshClearance.minimum`). Coal's answer is checked (outside, its witness must be at the distance it
reports; a polytope it finds inside the surface's solid is given its deepest point instead of EPA's penetration
depth); where GJK fails on a thin piece its triangles are sampled instead. Outside, the values are those of coal
over every pair; inside the surface's solid, minus the depth of the deepest point (tests/geometry compares both).
A polytope coal finds inside a further obstacle (box, cylinder, sphere, mesh) gets its deepest point there too
(:mod:`bracekit.geometry.inside`); a primitive piece inside a solid keeps coal's EPA penetration depth, which is
at least the deepest point's depth.

Gradient: coal gives the witness points p₁ (on the link) and p₂ (on the obstacle) and the unit normal ν from
the link toward the obstacle; with n = −ν (from the obstacle to the link)
∂d/∂q = nᵀ (J_p(p₁) − J_p(p₂)) = nᵀ J_p(p₁) (the obstacle is fixed), J_p(p₁) = J_v − [p₁ − o]× J_ω the linear
rows of the link joint's LOCAL_WORLD_ALIGNED Jacobian moved to p₁ (the witness is held fixed on the link: its
own motion along the surface does not change d to first order). For a piece settled at its deepest point the
row is gᵀ J_p(x*) with g from :mod:`bracekit.geometry._depth` (the height's and the side's directions weighted by
their multipliers where both count).
"""

from __future__ import annotations

import importlib
import itertools
import math
import weakref
from collections.abc import Sequence
from types import ModuleType
from typing import Any

import coal
import numpy as np
import pinocchio as pin
from numpy.typing import NDArray

from bracekit.errors import InputError, NumericalError
from bracekit.geometry.collision import CollisionElement
from bracekit.geometry.inside import deepest_inside
from bracekit.geometry.obstacles import Obstacle, surface_obstacle
from bracekit.geometry.pieces import (
    PATCH,
    Piece,
    clip_surface,
    convex_piece,
    patch_pieces,
    surface_triangles,
    triangle_pieces,
)
from bracekit.kinematics.braced import BracedRobot
from bracekit.model.chain import DATA_JOINT_LIMIT
from bracekit.model.geometry import Capsule
from bracekit.spatial import rotation_with_z

Array = NDArray[np.float64]
#: GJK's and EPA's tolerance (m): coal's default (1e-6) leaves d noisy at 1e-9 m (blurring ∂d/∂q); much below
#: 1e-9 GJK stops converging on thin pieces.
GJK_TOLERANCE = 1e-9
#: Divisions of a triangle's edges for the barycentric grid of :meth:`MeshClearance._sampled`.
SAMPLES = 16
_GRID = np.array([(i, j, SAMPLES - i - j) for i in range(SAMPLES + 1) for j in range(SAMPLES + 1 - i)]) / SAMPLES
#: (distance m, piece, witness point on the link (3,), unit normal from the obstacle to the link (3,) or None when
#: no gradient is asked)
Best = tuple[float, int, Array, Array | None]


def _depth(braced: BracedRobot) -> float:
    """Height (m) of a surface's body: well below anything the robot reaches (twice its reach and the surface's)."""
    model = braced.robot.model
    reach = sum(float(np.linalg.norm(model.jointPlacements[j].translation)) for j in range(1, model.njoints))
    reach += max((float(np.linalg.norm(f.placement.translation)) for f in model.frames), default=0.0)
    far = max(float(np.linalg.norm(b.surface.point)) for b in braced.braces)
    return 2.0 * (reach + far) + 1.0


class MeshClearance:
    """The link clearances of a braced robot from its collision elements (coal), obstacles fixed at construction.

    Args:
        braced: the braced robot (one brace or several); each brace's surface solid is an obstacle and each
            brace's pad neighbourhood is exempt on its link.
        elements: the robot's collision elements (``Robot.geometry``); those fixed to the base are left out.
        obstacles: further obstacles of the environment.
        pad_radius: radius (m) of each pad's exempt neighbourhood; None: each brace's ``pad_radius``.
        surfaces: whether the braces' surface solids are obstacles (False: `obstacles` only, for capsules whose
            surface clearance is the capsule rule's).
    """

    def __init__(
        self,
        braced: BracedRobot,
        elements: Sequence[CollisionElement],
        obstacles: Sequence[Obstacle] = (),
        pad_radius: float | None = None,
        surfaces: bool = True,
    ) -> None:
        robot = braced.robot
        model = robot.model
        self.braced = braced
        depth = _depth(braced)
        self.obstacles: tuple[Obstacle, ...] = (
            tuple(surface_obstacle(b.surface, b.obstacle_radius, depth) for b in braced.braces) if surfaces else ()
        ) + tuple(obstacles)
        pads: dict[int, list[tuple[Array, float]]] = {}
        for brace, fid in zip(braced.braces, braced.brace_ids, strict=True):
            frame = model.frames[fid]
            radius = brace.pad_radius if pad_radius is None else pad_radius
            if not (isinstance(radius, int | float) and math.isfinite(radius) and radius >= 0):
                raise InputError(f"pad_radius must be a length ≥ 0 (m), got {radius!r}")
            pads.setdefault(int(frame.parentJoint), []).append((np.array(frame.placement.translation), float(radius)))
        pieces: list[Piece] = []
        for element in elements:
            if element.joint <= 0:
                continue
            if element.joint not in pads:
                pieces.extend(_free_pieces(element))
                continue
            tri = surface_triangles(element)
            for pad, radius in pads[element.joint]:
                tri = clip_surface(tri, pad, radius)
            near = np.zeros(len(tri), dtype=bool)  # single triangles near a pad: a patch's hull could fill its hole
            for pad, radius in pads[element.joint]:
                near |= np.linalg.norm(tri - pad, axis=2).min(axis=1) < radius + PATCH * math.sqrt(3.0)
            pieces.extend(triangle_pieces(element.joint, element.link, tri[near]))
            pieces.extend(patch_pieces(element.joint, element.link, tri[~near]))
        pieces, groups = _grouped(pieces)
        self.pieces: tuple[Piece, ...] = tuple(pieces)
        #: groups of nearby pieces of one link, each piece range [groups[g], groups[g + 1]) with a bounding sphere
        self._groups = np.array(groups, dtype=np.intp)
        spheres = [
            _enclosing(np.array([p.centre for p in pieces[a:b]]), np.array([p.radius for p in pieces[a:b]]))
            for a, b in itertools.pairwise(groups)
        ]
        self._group_centres = np.array([c for c, _ in spheres], dtype=float).reshape(-1, 3)
        self._group_radii = np.array([r for _, r in spheres], dtype=float)
        joints = sorted({p.joint for p in pieces})
        self._joints = joints
        self._frames = [int(model.getFrameId(model.names[j], pin.FrameType.JOINT)) for j in joints]
        self._slot = np.array([joints.index(p.joint) for p in pieces], dtype=np.intp)
        self._centres = np.array([p.centre for p in pieces], dtype=float).reshape(-1, 3)
        self._radii = np.array([p.radius for p in pieces], dtype=float)
        # the polytopes' extreme points, flat, with each piece's range [offset[i], offset[i + 1])
        counts = np.array([0 if p.points is None else len(p.points) for p in pieces], dtype=np.intp)
        self._offsets = np.concatenate([[0], np.cumsum(counts)]).astype(np.intp)
        self._points = np.concatenate([p.points for p in pieces if p.points is not None] or [np.zeros((0, 3))])
        self._kinds, self._origins, self._axes, self._sizes = _screened(self.obstacles)
        self._shapes = [p.shape for p in pieces]
        self._local = [p.placement for p in pieces]
        self._identity = [bool(np.array_equal(p.placement, np.eye(4))) for p in pieces]
        self._obstacle_tf = [o.transform for o in self.obstacles]
        self._request = coal.DistanceRequest()
        self._request.gjk_tolerance = GJK_TOLERANCE
        self._request.epa_tolerance = GJK_TOLERANCE
        self._data = model.createData() if robot.n <= DATA_JOINT_LIMIT else None

    # --- configuration ------------------------------------------------------------------------
    def _placements(self, qa: Array, gradient: bool) -> tuple[Array, list[Array] | None]:
        """(⁰M of each link joint's frame (J, 4, 4); their LOCAL_WORLD_ALIGNED Jacobians (6×n) or None).

        With this object's own Pinocchio data (creating one costs as much as a pass) the Jacobians are read later,
        only for the links that need them (:meth:`_jacobian`): the list is then empty.
        """
        robot = self.braced.robot
        if self._data is None:
            kin = robot.frame_kinematics(qa, self._frames)
            return np.array([m for m, _ in kin]).reshape(-1, 4, 4), [j for _, j in kin] if gradient else None
        model, data = robot.model, self._data
        if gradient:
            pin.computeJointJacobians(model, data, qa)
        else:
            pin.forwardKinematics(model, data, qa)
        pin.updateFramePlacements(model, data)
        placements = np.array([data.oMf[f].homogeneous for f in self._frames]).reshape(-1, 4, 4)
        return placements, [] if gradient else None

    def _jacobian(self, jacs: list[Array], s: int) -> Array:
        """Link slot s's LOCAL_WORLD_ALIGNED joint Jacobian (6×n) after :meth:`_placements` with gradients."""
        if jacs:
            return jacs[s]
        lwa = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
        return np.asarray(pin.getFrameJacobian(self.braced.robot.model, self._data, self._frames[s], lwa))

    def _pair(self, piece: int, obstacle: int, placement: Array) -> tuple[float, Array, Array]:
        """(Signed distance m, witness point on the link (3,), unit normal from the obstacle to the link (3,))."""
        place = placement if self._identity[piece] else placement @ self._local[piece]
        result = coal.DistanceResult()
        value = coal.distance(
            self._shapes[piece],
            coal.Transform3s(place[:3, :3], place[:3, 3]),
            self.obstacles[obstacle].shape,
            self._obstacle_tf[obstacle],
            self._request,
            result,
        )
        witness = np.array(result.getNearestPoint1())
        solid = self.obstacles[obstacle]
        if solid.plane is not None and self.pieces[piece].faces is not None:
            if not abs(value) < 1e6 or value <= 0.0:  # into the solid: its deepest point (coal's is EPA's depth)
                inside = self._deepest(piece, obstacle, place)
                if inside[0] <= 0.0:
                    return inside
            # coal's answer checked: outside, its witness is `value` from the solid; EPA needs volume
            # (value ≤ 0 with the hull found outside: coal's penetration is not the distance either)
            if not abs(value) < 1e6 or value <= 0.0 or abs(solid.signed_at(witness) - value) > 1e-6:
                return self._sampled(piece, obstacle, place)
        elif self.pieces[piece].points is not None and (not abs(value) < 1e6 or value <= 0.0):
            points = self.pieces[piece].points
            assert points is not None
            found = deepest_inside(solid, points @ place[:3, :3].T + place[:3, 3])  # not EPA's depth
            if found is not None:
                return found
        if not abs(value) < 1e6:
            raise NumericalError(
                f"coal's distance between a piece of link {self.pieces[piece].link!r} and "
                f"{self.obstacles[obstacle].name} failed (got {value:g} m)"
            )
        return float(value), witness, -np.array(result.normal)

    def _deepest(self, piece: int, obstacle: int, place: Array) -> tuple[float, Array, Array]:
        """(Least signed distance, its point, ∂/∂(its motion)) over a polytope piece's hull, from the surface's solid.

        Where that is ≤ 0: minus the depth of the piece's deepest point (:mod:`bracekit.geometry._depth`, the
        half-space's at an extreme point); > 0 (the piece is outside after all) is not its distance.
        """
        c, n, r_max = self.obstacles[obstacle].plane or (np.zeros(3), np.zeros(3), None)
        points = self.pieces[piece].points
        assert points is not None
        world = points @ place[:3, :3].T + place[:3, 3]
        if r_max is None:
            heights = (world - c) @ n
            k = int(np.argmin(heights))
            return float(heights[k]), world[k], np.asarray(n, dtype=float)
        axes = self.obstacles[obstacle].placement[:3, :3]
        local = (world - c) @ axes
        upper = float(self.obstacles[obstacle].signed(world)[0].min())
        value, point, slope = _kernel().deepest_in(local, r_max, upper)
        return value, c + axes @ point, axes @ slope

    def _sampled(self, piece: int, obstacle: int, place: Array) -> tuple[float, Array, Array]:
        """(Least signed distance, its point, the gradient there) over barycentric grids of a piece's triangles.

        For the rare piece outside the surface's solid (one reaching into it is :meth:`_deepest`'s) where coal's
        answer is not finite or, on a sliver, GJK's witness is not at the distance it reports: the value to
        within a sixteenth of its triangles.
        """
        faces = self.pieces[piece].faces
        assert faces is not None
        corners = faces @ place[:3, :3].T + place[:3, 3]
        points = np.einsum("wc,tci->twi", _GRID, corners).reshape(-1, 3)
        value = self.obstacles[obstacle].signed(points)[0]
        k = int(np.argmin(value))
        return float(value[k]), points[k], self.obstacles[obstacle].gradient(points[k])

    def _screen(self, placements: Array, held: float, shared: bool) -> tuple[NDArray[Any], ...]:
        """:func:`~bracekit.geometry._screen.screen` of one configuration (every link below `held`, m)."""
        found: tuple[NDArray[Any], ...] = _kernel().screen(
            placements,
            self._slot,
            self._centres,
            self._radii,
            self._groups,
            self._group_centres,
            self._group_radii,
            self._offsets,
            self._points,
            self._kinds,
            self._origins,
            self._axes,
            self._sizes,
            np.full(1 if shared else len(placements), held),
            shared,
        )
        return found

    def _settled(self, found: tuple[Array, ...], s: int, gradient: bool) -> Best | None:
        """The pair the broad phase settled for slot `s` (distance, piece, witness, normal or None), or None."""
        best, piece, point = found[0], found[1], found[3]
        if not math.isfinite(best[s]):
            return None
        witness = point[s]
        normal = found[6][s] if gradient else None
        return float(best[s]), int(piece[s]), witness, normal

    # --- the clearances -----------------------------------------------------------------------
    def links(self, q: Array, gradient: bool = True, below: float = math.inf) -> list[tuple[int, float, Array]]:
        """(Chain joint index (0-based), clearance m, ∂/∂q (n,) or empty) of each link below `below`, in chain order.

        The broad phase settles what it can; coal runs on each link's remaining pairs in the order of their
        bounds while the bound is below the least value found.
        """
        if not self.pieces or not self.obstacles:
            return []
        placements, jacs = self._placements(q, gradient)
        found = self._screen(placements, below, False)
        pairs, bounds = found[4], found[5]
        remaining: list[list[int]] = [[] for _ in self._joints]
        for k in np.argsort(bounds, kind="stable").tolist():
            remaining[self._slot[pairs[k, 0]]].append(k)
        out = []
        for s, ks in enumerate(remaining):
            best = self._settled(found, s, gradient)
            held = below if best is None else min(best[0], below)
            for k in ks:
                if bounds[k] >= held:
                    break
                piece, obstacle = int(pairs[k, 0]), int(pairs[k, 1])
                value, witness, normal = self._pair(piece, obstacle, placements[s])
                if value < held:
                    held, best = value, (value, piece, witness, normal)
            if best is None or not best[0] < below:
                continue
            grad = np.zeros(0)
            if jacs is not None and best[3] is not None:
                grad = _point_row(best[3], best[2] - placements[s, :3, 3], self._jacobian(jacs, s))
            value = best[0]
            out.append((self._joints[s] - 1, value, grad))
        return out

    def minimum(self, q: Array) -> tuple[float, int]:
        """(The least clearance over all links, m; its link's joint in chain order); (inf, −1) with no pieces.

        The broad phase over all links at once, then coal on the remaining pairs in the order of their bounds.
        """
        if not self.pieces or not self.obstacles:
            return math.inf, -1
        placements, _ = self._placements(q, False)
        found = self._screen(placements, math.inf, True)
        low, link = math.inf, -1
        if math.isfinite(found[0][0]):
            low, link = float(found[0][0]), self._joints[self._slot[int(found[1][0])]] - 1
        pairs, bounds = found[4], found[5]
        for k in np.argsort(bounds, kind="stable").tolist():
            if bounds[k] > low:
                break
            piece, obstacle = int(pairs[k, 0]), int(pairs[k, 1])
            s = int(self._slot[piece])
            value = self._pair(piece, obstacle, placements[s])[0]
            if (value, self._joints[s] - 1) < (low, link):
                low, link = value, self._joints[s] - 1
        return low, link


#: Pieces per group of the broad phase (at most).
GROUP = 16


def _grouped(pieces: list[Piece]) -> tuple[list[Piece], list[int]]:
    """The pieces by link, each link's split in halves across its widest spread until at most GROUP a group.

    Returns the pieces in group order and the groups' starts (with the end).
    """
    out: list[Piece] = []
    starts = [0]

    def split(chunk: list[Piece]) -> None:
        centres = np.array([p.centre for p in chunk]).reshape(-1, 3)
        if len(chunk) <= GROUP:
            out.extend(chunk)
            starts.append(len(out))
            return
        axis = int(np.argmax(np.ptp(centres, axis=0)))
        order = np.argsort(centres[:, axis], kind="stable")
        half = len(chunk) // 2
        split([chunk[i] for i in order[:half]])
        split([chunk[i] for i in order[half:]])

    for joint in sorted({p.joint for p in pieces}):
        split([p for p in pieces if p.joint == joint])
    return out, starts


def _enclosing(centres: Array, radii: Array) -> tuple[Array, float]:
    """A sphere (centre (3,), radius m) holding the spheres (centres (k, 3), radii (k,))."""
    centre = 0.5 * (np.min(centres - radii[:, None], axis=0) + np.max(centres + radii[:, None], axis=0))
    return centre, float(np.max(np.linalg.norm(centres - centre, axis=1) + radii))


def _screened(obstacles: Sequence[Obstacle]) -> tuple[NDArray[np.int64], Array, Array, Array]:
    """The obstacles as the broad phase reads them: kinds (O,), origins (O, 3), axes (O, 3, 3), sizes (O,)."""
    kinds, origins, axes, sizes = [], [], [], []
    for o in obstacles:
        if o.plane is None:
            kinds.append(_kernel().SPHERE)
            origins.append(o.centre)
            axes.append(np.eye(3))
            sizes.append(o.radius)
            continue
        c, n, r_max = o.plane
        kinds.append(_kernel().HALFSPACE if r_max is None else _kernel().DISK)
        origins.append(c)
        axes.append(_plane_axes(n) if r_max is None else o.placement[:3, :3])
        sizes.append(0.0 if r_max is None else r_max)
    return (
        np.array(kinds, dtype=np.int64),
        np.array(origins, dtype=float).reshape(-1, 3),
        np.array(axes, dtype=float).reshape(-1, 3, 3),
        np.array(sizes, dtype=float),
    )


def _plane_axes(n: Array) -> Array:
    """Axes (columns x, y, n̂) of a plane with unit normal n̂."""
    e1 = np.cross(n, np.eye(3)[int(np.argmin(np.abs(n)))])
    e1 /= np.linalg.norm(e1)
    return np.column_stack([e1, np.cross(n, e1), n])


#: collision element → its pieces on a link that carries no pad (they do not depend on the brace): built once
_FREE: weakref.WeakKeyDictionary[CollisionElement, list[Piece]] = weakref.WeakKeyDictionary()


def capsule_elements(capsules: Sequence[Capsule]) -> list[CollisionElement]:
    """Capsules (segment [a, b] grown by a radius, joint frame) as collision elements (a sphere where a = b)."""
    out = []
    for c in capsules:
        axis = np.asarray(c.b, dtype=float) - np.asarray(c.a, dtype=float)
        length = float(np.linalg.norm(axis))
        place = np.eye(4)
        place[:3, 3] = 0.5 * (np.asarray(c.a, dtype=float) + np.asarray(c.b, dtype=float))
        if length <= 1e-12:
            out.append(CollisionElement(c.link, c.joint, place, "sphere", (float(c.radius),)))
            continue
        place[:3, :3] = rotation_with_z(axis / length, "a capsule's axis")
        out.append(CollisionElement(c.link, c.joint, place, "capsule", (float(c.radius), length)))
    return out


def _free_pieces(element: CollisionElement) -> list[Piece]:
    """The pieces of an element of a link without a pad: a primitive as itself, a mesh as patches (cached)."""
    if element not in _FREE:
        if element.kind == "mesh":
            _FREE[element] = patch_pieces(element.joint, element.link, surface_triangles(element))
        else:
            _FREE[element] = [convex_piece(element)]
    return _FREE[element]


def _point_row(u: Array, arm: Array, jac: Array) -> Array:
    """uᵀ J_p = uᵀ(J_v − [arm]× J_ω) = uᵀJ_v + (arm × u)ᵀ J_ω (n,) for the point at `arm` (m) from the joint."""
    ax, ay, az = arm.tolist()
    ux, uy, uz = u.tolist()
    return np.array([ux, uy, uz, ay * uz - az * uy, az * ux - ax * uz, ax * uy - ay * ux]) @ jac


def _kernel() -> ModuleType:
    """The broad phase (:mod:`bracekit.geometry._screen`), imported on first use: numba is an optional extra."""
    return importlib.import_module("bracekit.geometry._screen")
