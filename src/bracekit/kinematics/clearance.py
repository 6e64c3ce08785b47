"""Clearance of the links from the bracing plane: signed distances of the link capsules and their ∂/∂q.

The rule: a link's clearance is the signed distance from the plane (n̂ᵀ(p − point), positive on the robot's
side) of the lower end point of each of its capsule segments, minus the capsule's radius, the least over its
capsules. With a bracing region (``Brace.region_radius``) only the plane inside the region's disk is an
obstacle: an end point counts only where its projection onto the plane lies within r_max of the region centre
(the surface's point). The link carrying {b} (every capsule of the brace frame's joint) is left out: its pad
touches the plane by design. Negative clearance is penetration.

The gradient of an end point's distance is n̂ᵀ of the linear rows of its point Jacobian (LOCAL_WORLD_ALIGNED),
the joint's Jacobian shifted to the point: J_p = J_v − [p − o]× J_ω.
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
        self._r_max = braced.brace.region_radius
        self._data = model.createData() if robot.n <= DATA_JOINT_LIMIT else None

    def _counts(self, p: Array) -> bool:
        """Whether the plane under end point p (3,) is an obstacle (inside the region's disk, or no region)."""
        if self._r_max is None:
            return True
        rel = p - self._point
        lateral = rel - self._normal * float(self._normal @ rel)
        return float(np.linalg.norm(lateral)) <= self._r_max

    def links(self, q: ArrayLike, gradient: bool = True) -> list[LinkDistance]:
        """Each link with a counted end point: its clearance (m) and, if `gradient`, ∂/∂q (n,).

        Links none of whose end points lies over the region's disk are left out.
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
            for end in (cap.a, cap.b):
                p = origin + rot @ end
                if not self._counts(p):
                    continue
                value = float(n @ (p - self._point)) - cap.radius
                if cap.joint in best and best[cap.joint][0] <= value:
                    continue
                grad = None
                if gradient and jac is not None:
                    arm = p - origin
                    # nᵀ(J_v − [arm]× J_ω) = nᵀJ_v + (arm × n)ᵀ J_ω
                    grad = n @ jac[:3] + np.cross(arm, n) @ jac[3:]
                best[cap.joint] = (value, grad)
        return [
            LinkDistance(j - 1, v, g if g is not None else np.zeros(0)) for j, (v, g) in sorted(best.items())
        ]

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
