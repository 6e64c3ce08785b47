"""Link clearance from the URDF's collision geometry: coal's signed distance of every link from every obstacle.

The clearance of a link is the least signed distance (m, negative = penetration depth) between its convex
pieces (:mod:`bracekit.geometry.pieces`) and the obstacles (:mod:`bracekit.geometry.obstacles`): coal's
``distance`` (GJK, and EPA in penetration) with a DistanceRequest. The braced link counts like any other link,
with the surface within ``Brace.pad_radius`` of its pad left out (the pad touches the surface by design).

Exact shortcut: a polytope piece over the surface's disk (its extreme points all over it; any piece for the
half-space) is its extreme points' least height away (h is linear), and one with an extreme point inside the
solid gets the deepest one's signed distance; these are computed for many pieces at once, coal for the others.
Coal's answer is checked (outside, its witness must be at the distance it reports); where GJK or EPA fail on a
thin piece its triangles are sampled instead.

Broad phase: each piece's bounding sphere gives a lower bound of its distance from each obstacle
(``Obstacle.bound(centre) − radius``, raised to the piece's least height where the shortcut does not apply);
pieces are searched in the order of their bounds and only while the bound is below the least distance found
(of their link, or of all links for :meth:`MeshClearance.minimum`).

Gradient: coal gives the witness points p₁ (on the link) and p₂ (on the obstacle) and the unit normal ν from
the link toward the obstacle; with n = −ν (from the obstacle to the link)
∂d/∂q = nᵀ (J_p(p₁) − J_p(p₂)) = nᵀ J_p(p₁) (the obstacle is fixed), J_p(p₁) = J_v − [p₁ − o]× J_ω the linear
rows of the link joint's LOCAL_WORLD_ALIGNED Jacobian moved to p₁ (the witness is held fixed on the link: its
own motion along the surface does not change d to first order).
"""

from __future__ import annotations

import math
import weakref
from collections.abc import Sequence
from typing import cast

import coal
import numpy as np
import pinocchio as pin
from numpy.typing import NDArray

from bracekit.errors import InputError, NumericalError
from bracekit.geometry.collision import CollisionElement
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

Array = NDArray[np.float64]
#: GJK's and EPA's tolerance (m): coal's default (1e-6) leaves d noisy at 1e-9 m (blurring ∂d/∂q); much below
#: 1e-9 GJK stops converging on thin pieces.
GJK_TOLERANCE = 1e-9
#: Divisions of a triangle's edges for the barycentric grid of :meth:`MeshClearance._sampled`.
SAMPLES = 16
_GRID = np.array([(i, j, SAMPLES - i - j) for i in range(SAMPLES + 1) for j in range(SAMPLES + 1 - i)]) / SAMPLES
#: (distance m, piece, witness point on the link (3,), unit normal from the obstacle to the link (3,))
Best = tuple[float, int, Array, Array]


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
    """

    def __init__(
        self,
        braced: BracedRobot,
        elements: Sequence[CollisionElement],
        obstacles: Sequence[Obstacle] = (),
        pad_radius: float | None = None,
    ) -> None:
        robot = braced.robot
        model = robot.model
        self.braced = braced
        depth = _depth(braced)
        self.obstacles: tuple[Obstacle, ...] = tuple(
            surface_obstacle(b.surface, b.obstacle_radius, depth) for b in braced.braces
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
        pieces.sort(key=lambda p: p.joint)
        self.pieces: tuple[Piece, ...] = tuple(pieces)
        joints = sorted({p.joint for p in pieces})
        self._joints = joints
        self._frames = [int(model.getFrameId(model.names[j], pin.FrameType.JOINT)) for j in joints]
        self._slot = np.array([joints.index(p.joint) for p in pieces], dtype=np.intp)
        #: each link's pieces are the contiguous range [start, stop) of self.pieces
        self._ranges = [
            (int(np.searchsorted(self._slot, k)), int(np.searchsorted(self._slot, k, "right")))
            for k in range(len(joints))
        ]
        self._centres = np.array([p.centre for p in pieces], dtype=float).reshape(-1, 3)
        self._radii = np.array([p.radius for p in pieces], dtype=float)
        #: each link's bounding sphere (joint frame): its pieces' bounds are computed only when it comes near
        self._link_spheres = [_enclosing(self._centres[a:b], self._radii[a:b]) for a, b in self._ranges]
        # the polytopes' extreme points, flat, with each piece's range [offset[i], offset[i + 1])
        counts = np.array([0 if p.points is None else len(p.points) for p in pieces], dtype=np.intp)
        self._offsets = np.concatenate([[0], np.cumsum(counts)]).astype(np.intp)
        self._has_points = counts > 0
        self._points = np.concatenate([p.points for p in pieces if p.points is not None] or [np.zeros((0, 3))])
        self._exact_obstacles = [k for k, o in enumerate(self.obstacles) if o.plane is not None]
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
        """(⁰M of each link joint's frame (J, 4, 4); their LOCAL_WORLD_ALIGNED Jacobians (6×n) or None)."""
        robot = self.braced.robot
        if gradient or self._data is None:
            kin = robot.frame_kinematics(qa, self._frames)
            return np.array([m for m, _ in kin]).reshape(-1, 4, 4), [j for _, j in kin] if gradient else None
        model, data = robot.model, self._data
        pin.forwardKinematics(model, data, qa)
        pin.updateFramePlacements(model, data)
        return np.array([data.oMf[f].homogeneous for f in self._frames]).reshape(-1, 4, 4), None

    def _bounds(self, placements: Array, link: int) -> Array:
        """Lower bounds (the link's pieces, obstacles) of its pieces' signed distances from the obstacles, m."""
        a, b = self._ranges[link]
        m = placements[link]
        centres = self._centres[a:b] @ m[:3, :3].T + m[:3, 3]
        return cast(Array, np.stack([o.bound(centres) for o in self.obstacles], axis=1) - self._radii[a:b, None])

    def _link_bounds(self, placements: Array) -> list[float]:
        """A lower bound (m) of each link's distance from the obstacles (its bounding sphere's)."""
        out = []
        for (centre, radius), m in zip(self._link_spheres, placements, strict=True):
            world = m[:3, :3] @ centre + m[:3, 3]
            out.append(min(o.bound_at(world) for o in self.obstacles) - radius)
        return out

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
            # coal's answer checked: outside, its witness is `value` from the solid; EPA needs volume
            if not abs(value) < 1e6 or (value > 0.0 and abs(solid.signed_at(witness) - value) > 1e-6):
                return self._sampled(piece, obstacle, place)
        if not abs(value) < 1e6:
            raise NumericalError(
                f"coal's distance between a piece of link {self.pieces[piece].link!r} and "
                f"{self.obstacles[obstacle].name} failed (got {value:g} m)"
            )
        return float(value), witness, -np.array(result.normal)

    def _sampled(self, piece: int, obstacle: int, place: Array) -> tuple[float, Array, Array]:
        """(Least signed distance, its point, the gradient there) over barycentric grids of a piece's triangles.

        For the rare flat piece (a triangle, a thin patch) whose corners are all outside the surface's solid but
        which crosses its rim, where coal's EPA fails (it needs volume), or a sliver where GJK's witness is not at
        the distance it reports: the value to within a sixteenth of its triangles.
        """
        faces = self.pieces[piece].faces
        assert faces is not None
        corners = faces @ place[:3, :3].T + place[:3, 3]
        points = np.einsum("wc,tci->twi", _GRID, corners).reshape(-1, 3)
        value = self.obstacles[obstacle].signed(points)[0]
        k = int(np.argmin(value))
        return float(value[k]), points[k], self.obstacles[obstacle].gradient(points[k])

    def _search(self, placements: Array, bounds: Array, start: int, held: float) -> Best | None:
        """The least (distance, piece, witness, normal) of one link's pieces (from `start`) below `held`.

        `bounds` are those pieces' sphere bounds (k, obstacles) (:meth:`_bounds`); searched pairs are set to inf.

        The pieces whose bound is at most an upper bound of the answer (the least sphere centre's distance plus
        its diameter): the polytopes whose distance from the surface's solid is exact from their extreme points
        all at once (:meth:`_exact`), the others by coal in the order of their bounds until the next bound passes
        the least distance found. None if nothing comes below `held`.
        """
        if bounds.size == 0 or float(bounds.min()) >= held:
            return None
        count = bounds.shape[1]
        flat = bounds.reshape(-1)
        cap = min(held, self._upper(placements, start, bounds))
        held, best = self._exact(placements, start, np.flatnonzero(bounds.min(axis=1) <= cap), bounds, held, None)
        for k in np.argsort(flat).tolist():
            if flat[k] >= held or flat[k] > cap:
                break
            piece, obstacle = divmod(k, count)
            value, witness, normal = self._pair(start + piece, obstacle, placements[self._slot[start]])
            if value < held:
                held, best = value, (value, start + piece, witness, normal)
        return best

    def _upper(self, placements: Array, start: int, bounds: Array) -> float:
        """An upper bound (m) of a link's clearance: its closest piece's, from that piece's points.

        The sphere's centre's bound plus its diameter (a point of the piece lies within its radius of the
        centre), or for a polytope its extreme points' least signed distance from the surface's solid (every
        value of the piece, exact, coal's or sampled, is at most that of any of its points).
        """
        upper = float((bounds + 2.0 * self._radii[start : start + len(bounds), None]).min())
        piece, obstacle = divmod(int(np.argmin(bounds)), bounds.shape[1])
        piece += start
        if self._has_points[piece] and self.obstacles[obstacle].plane is not None:
            m = placements[self._slot[piece]]
            points = self._points[self._offsets[piece] : self._offsets[piece + 1]] @ m[:3, :3].T + m[:3, 3]
            upper = min(upper, float(self.obstacles[obstacle].signed(points)[0].min()))
        return upper

    def _exact(
        self, placements: Array, start: int, chosen: NDArray[np.intp], bounds: Array, held: float, best: Best | None
    ) -> tuple[float, Best | None]:
        """The polytopes (of `chosen`, offsets from `start`) whose distance from the surface's solid is exact.

        A polytope over the disk (its extreme points all over it), or any for the half-space, is its extreme
        points' least signed distance away (h is linear); one with an extreme point inside the solid gets the
        deepest one's signed distance (as a brute-force look at the mesh vertices would). Coal is left for the
        others (across the rim), whose `bounds` are raised to their least height (the solid is below the plane)
        or their least distance beyond the side's tangent plane facing them (:meth:`Obstacle.beside`), whichever
        is more; the pairs done here are set to inf.
        """
        chosen = chosen[self._has_points[start + chosen]]
        if chosen.size == 0 or not self._exact_obstacles:
            return held, best
        ids = start + chosen
        lo, hi = self._offsets[ids], self._offsets[ids + 1]
        sizes = hi - lo
        index = np.repeat(lo - np.concatenate([[0], np.cumsum(sizes)[:-1]]), sizes) + np.arange(int(sizes.sum()))
        place = placements[self._slot[start]]
        world = self._points[index] @ place[:3, :3].T + place[:3, 3]
        heads = np.concatenate([[0], np.cumsum(sizes)[:-1]])
        for o in self._exact_obstacles:
            value, over, height = self.obstacles[o].signed(world)
            least = np.minimum.reduceat(value, heads)
            exact = (least <= 0.0) | np.logical_and.reduceat(over, heads)
            bounds[chosen[exact], o] = math.inf  # searched
            # the others are at least their least height away (the solid lies below the plane; h is linear) and at
            # least their least distance beyond the tangent plane of the body's side facing them
            rest = chosen[~exact]
            if rest.size:
                supporting = np.maximum(np.minimum.reduceat(height, heads), self.obstacles[o].beside(world, heads))
                bounds[rest, o] = np.maximum(bounds[rest, o], supporting[~exact])
            if not exact.any():
                continue
            k = int(np.flatnonzero(exact)[np.argmin(least[exact])])
            if least[k] < held:
                at = heads[k] + int(np.argmin(value[heads[k] : heads[k] + sizes[k]]))
                normal = self.obstacles[o].gradient(world[at])
                held, best = float(least[k]), (float(least[k]), int(ids[k]), world[at], normal)
        return held, best

    # --- the clearances -----------------------------------------------------------------------
    def links(self, q: Array, gradient: bool = True, below: float = math.inf) -> list[tuple[int, float, Array]]:
        """(Chain joint index (0-based), clearance m, ∂/∂q (n,) or empty) of each link below `below`, in chain order."""
        if not self.pieces or not self.obstacles:
            return []
        placements, jacs = self._placements(q, gradient)
        near = self._link_bounds(placements)
        out = []
        for s, (start, _) in enumerate(self._ranges):
            if near[s] >= below:
                continue
            found = self._search(placements, self._bounds(placements, s), start, below)
            if found is None:
                continue
            value, _, witness, normal = found
            grad = np.zeros(0)
            if jacs is not None:
                grad = _point_row(normal, witness - placements[s, :3, 3], jacs[s])
            out.append((self._joints[s] - 1, value, grad))
        return out

    def minimum(self, q: Array) -> tuple[float, int]:
        """(The least clearance over all links, m; its link's joint in chain order); (inf, −1) with no pieces.

        The links in the order of their least sphere bound, each searched below the least clearance found.
        """
        if not self.pieces or not self.obstacles:
            return math.inf, -1
        placements, _ = self._placements(q, False)
        near = self._link_bounds(placements)
        low, link = math.inf, -1
        for s in sorted(range(len(near)), key=near.__getitem__):
            if near[s] >= low:
                break
            found = self._search(placements, self._bounds(placements, s), self._ranges[s][0], low)
            if found is not None and (found[0], self._joints[s] - 1) < (low, link):
                low, link = found[0], self._joints[s] - 1
        return low, link


def _enclosing(centres: Array, radii: Array) -> tuple[Array, float]:
    """A sphere (centre (3,), radius m) holding the spheres (centres (k, 3), radii (k,))."""
    if len(centres) == 0:
        return np.zeros(3), 0.0
    centre = 0.5 * (np.min(centres - radii[:, None], axis=0) + np.max(centres + radii[:, None], axis=0))
    return centre, float(np.max(np.linalg.norm(centres - centre, axis=1) + radii))


#: collision element → its pieces on a link that carries no pad (they do not depend on the brace): built once
_FREE: weakref.WeakKeyDictionary[CollisionElement, list[Piece]] = weakref.WeakKeyDictionary()


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
