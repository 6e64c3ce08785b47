"""Link clearance from the URDF's collision geometry: coal's signed distance of every link from every obstacle.

The clearance of a link is the least signed distance (m, negative = penetration depth) between its convex
pieces (:mod:`bracekit.geometry.pieces`) and the obstacles (:mod:`bracekit.geometry.obstacles`): coal's
``distance`` (GJK, and EPA in penetration) with a DistanceRequest. The braced link counts like any other link,
with the surface within ``Brace.pad_radius`` of its pad left out (the pad touches the surface by design).

Broad phase: each piece's bounding sphere gives a lower bound of its distance from each obstacle
(``Obstacle.bound(centre) − radius``); pieces are searched in the order of their bounds and only while the bound
is below the least distance found (of their link, or of all links for :meth:`MeshClearance.minimum`).

Gradient: coal gives the witness points p₁ (on the link) and p₂ (on the obstacle) and the unit normal ν from
the link toward the obstacle; with n = −ν (from the obstacle to the link)
∂d/∂q = nᵀ (J_p(p₁) − J_p(p₂)) = nᵀ J_p(p₁) (the obstacle is fixed), J_p(p₁) = J_v − [p₁ − o]× J_ω the linear
rows of the link joint's LOCAL_WORLD_ALIGNED Jacobian moved to p₁ (the witness is held fixed on the link: its
own motion along the surface does not change d to first order).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import coal
import numpy as np
import pinocchio as pin
from numpy.typing import NDArray

from bracekit.errors import InputError
from bracekit.geometry.collision import CollisionElement
from bracekit.geometry.obstacles import Obstacle, surface_obstacle
from bracekit.geometry.pieces import (
    Piece,
    clip_surface,
    clusters,
    convex_piece,
    enclosing,
    surface_triangles,
    triangle_pieces,
)
from bracekit.kinematics.braced import BracedRobot
from bracekit.model.chain import DATA_JOINT_LIMIT

Array = NDArray[np.float64]

#: Default radius (m) of the pad's neighbourhood that is exempt from the braced link's clearance.
DEFAULT_PAD_RADIUS = 0.02


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
            radius = getattr(brace, "pad_radius", DEFAULT_PAD_RADIUS) if pad_radius is None else pad_radius
            if not (isinstance(radius, int | float) and math.isfinite(radius) and radius >= 0):
                raise InputError(f"pad_radius must be a length ≥ 0 (m), got {radius!r}")
            pads.setdefault(int(frame.parentJoint), []).append((np.array(frame.placement.translation), float(radius)))
        pieces: list[Piece] = []
        for element in elements:
            if element.joint <= 0:
                continue
            if element.joint not in pads:
                pieces.append(convex_piece(element))
                continue
            tri = surface_triangles(element)
            for pad, radius in pads[element.joint]:
                tri = clip_surface(tri, pad, radius)
            pieces.extend(triangle_pieces(element.joint, element.link, tri))
        pieces.sort(key=lambda p: p.joint)
        self.pieces: tuple[Piece, ...] = tuple(pieces)
        joints = sorted({p.joint for p in pieces})
        self._joints = joints
        self._frames = [int(model.getFrameId(model.names[j], pin.FrameType.JOINT)) for j in joints]
        self._slot = np.array([joints.index(p.joint) for p in pieces], dtype=np.intp)
        self._centres = np.array([p.centre for p in pieces], dtype=float).reshape(-1, 3)
        self._radii = np.array([p.radius for p in pieces], dtype=float)
        # the broad phase's first level: clusters of each link's pieces, each link's clusters contiguous
        groups: list[NDArray[np.intp]] = []
        self._cluster_ranges: list[tuple[int, int]] = []
        for s in range(len(joints)):
            own = np.flatnonzero(self._slot == s)
            start = len(groups)
            groups.extend(own[g] for g in clusters(self._centres[own], self._radii[own]))
            self._cluster_ranges.append((start, len(groups)))
        spheres = [enclosing(self._centres[g], self._radii[g]) for g in groups]
        self._members = groups
        self._cluster_centres = np.array([c for c, _ in spheres], dtype=float).reshape(-1, 3)
        self._cluster_slot = np.array([self._slot[g[0]] for g in groups], dtype=np.intp)
        self._cluster_radii = np.array([r for _, r in spheres], dtype=float)
        self._shapes = [p.shape for p in pieces]
        self._local = [p.placement for p in pieces]
        self._identity = [bool(np.array_equal(p.placement, np.eye(4))) for p in pieces]
        self._obstacle_tf = [o.transform for o in self.obstacles]
        self._request = coal.DistanceRequest()
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

    def _cluster_bounds(self, placements: Array) -> Array:
        """Lower bounds (clusters, obstacles) of every cluster's signed distance from every obstacle, m."""
        place = placements[self._cluster_slot]
        centres = np.einsum("kij,kj->ki", place[:, :3, :3], self._cluster_centres) + place[:, :3, 3]
        return np.stack([o.bound(centres) for o in self.obstacles], axis=1) - self._cluster_radii[:, None]

    def _piece_bounds(self, placements: Array, pieces: NDArray[np.intp]) -> Array:
        """Lower bounds (len(pieces), obstacles) of the given pieces' signed distances, m."""
        place = placements[self._slot[pieces]]
        centres = np.einsum("kij,kj->ki", place[:, :3, :3], self._centres[pieces]) + place[:, :3, 3]
        return np.stack([o.bound(centres) for o in self.obstacles], axis=1) - self._radii[pieces, None]

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
        return float(value), np.array(result.getNearestPoint1()), -np.array(result.normal)

    def _search(
        self, placements: Array, cluster_bounds: Array, start: int, held: float
    ) -> tuple[float, int, Array, Array] | None:
        """The least (distance, piece, witness, normal) of the clusters start, start + 1, … (bounds (k, obstacles)).

        First the pair of least bound in the cluster of least bound (an upper bound of the answer); then every
        pair of the clusters whose bound is below the least distance found, in the order of their bounds, until
        the next bound passes it. None if no pair comes below `held`.
        """
        count = cluster_bounds.shape[1]
        least = cluster_bounds.min(axis=1)
        if least.size == 0 or float(least.min()) >= held:
            return None
        best: tuple[float, int, Array, Array] | None = None
        done: set[tuple[int, int]] = set()
        for phase in (0, 1):
            chosen = [int(np.argmin(least))] if phase == 0 else np.flatnonzero(least < held).tolist()
            pieces = np.concatenate([self._members[start + k] for k in chosen])
            flat = self._piece_bounds(placements, pieces).reshape(-1)
            order = np.argsort(flat)
            for k in order[:1] if phase == 0 else order:
                if flat[k] >= held:
                    break
                piece, obstacle = int(pieces[k // count]), int(k % count)
                if (piece, obstacle) in done:
                    continue
                done.add((piece, obstacle))
                value, witness, normal = self._pair(piece, obstacle, placements[self._slot[piece]])
                if value < held:
                    held, best = value, (value, piece, witness, normal)
        return best

    # --- the clearances -----------------------------------------------------------------------
    def links(self, q: Array, gradient: bool = True, below: float = math.inf) -> list[tuple[int, float, Array]]:
        """(Chain joint index (0-based), clearance m, ∂/∂q (n,) or empty) of each link below `below`, in chain order."""
        if not self.pieces or not self.obstacles:
            return []
        placements, jacs = self._placements(q, gradient)
        bounds = self._cluster_bounds(placements)
        out = []
        for s, (start, stop) in enumerate(self._cluster_ranges):
            found = self._search(placements, bounds[start:stop], start, below)
            if found is None:
                continue
            value, _, witness, normal = found
            grad = np.zeros(0)
            if jacs is not None:
                grad = _point_row(normal, witness - placements[s, :3, 3], jacs[s])
            out.append((self._joints[s] - 1, value, grad))
        return out

    def minimum(self, q: Array) -> tuple[float, int]:
        """(The least clearance over all links, m; its link's joint in chain order); (inf, −1) with no pieces."""
        if not self.pieces or not self.obstacles:
            return math.inf, -1
        placements, _ = self._placements(q, False)
        found = self._search(placements, self._cluster_bounds(placements), 0, math.inf)
        if found is None:
            return math.inf, -1
        return found[0], self._joints[self._slot[found[1]]] - 1


def _point_row(u: Array, arm: Array, jac: Array) -> Array:
    """uᵀ J_p = uᵀ(J_v − [arm]× J_ω) (n,) for the point at `arm` (m) from the joint's origin."""
    return np.concatenate([u, np.cross(arm, u)]) @ jac
