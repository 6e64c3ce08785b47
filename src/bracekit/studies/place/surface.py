"""The pad's place as continuous variables: a point on a link's capsule surface, θ = (fraction, angle).

The link's capsule (its collision capsule, or the default capsule of radius r) has the axis from the link's
joint origin o to the next joint's origin o' (:func:`bracekit.geometry.pad.link_axis`, link frame). With the
unit axis ẑ = (o' − o)/|o' − o|, the reference direction x̂ (the link frame's x made perpendicular to ẑ, its y
if x is along ẑ) and ŷ = ẑ × x̂ — the rule of :func:`bracekit.geometry.pad.pad_on_surface` — the pad is

    p(s, φ) = o + s (o' − o) + r u(φ),     u(φ) = cos φ x̂ + sin φ ŷ,     n(φ) = −u(φ)

(link frame, m): s the fraction along the axis (0 at the joint, 1 at the next joint), φ the angle about the
axis (rad; degrees in files, as in ``surface = {fraction, angle}``), n the surface's inward unit normal there
(the pad axis). Both are smooth in θ = (s, φ); :meth:`LinkSurface.point_derivative` and
:meth:`LinkSurface.normal_derivative` give ∂p/∂θ (3×2) and ∂n/∂θ (3×2), exact.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from bracekit.geometry.pad import link_frame
from bracekit.model.geometry import DEFAULT_LINK_RADIUS
from bracekit.model.robot import Robot
from bracekit.studies.place.snapped import SnappedSurface, snapped_surface

Array = NDArray[np.float64]


@dataclass(frozen=True)
class LinkSurface:
    """A link's capsule surface in the link's frame (m): axis origin o, axis o' − o, frame (x̂, ŷ), radius r."""

    link: str
    origin: Array
    axis: Array
    x: Array
    y: Array
    radius: float

    def direction(self, angle: float) -> Array:
        """u(φ) = cos φ x̂ + sin φ ŷ (3,), the outward radial direction at `angle` (rad)."""
        return math.cos(angle) * self.x + math.sin(angle) * self.y

    def point(self, fraction: float, angle: float) -> Array:
        """p(s, φ) (3,), m, link frame."""
        return self.origin + fraction * self.axis + self.radius * self.direction(angle)

    def normal(self, fraction: float, angle: float) -> Array:
        """n(φ) = −u(φ) (3,): the surface's inward unit normal, link frame (the same at every fraction)."""
        return -self.direction(angle)

    def fraction_bounds(self, bounds: tuple[float, float]) -> tuple[float, float]:
        """The fraction's bounds on this surface: `bounds` (the capsule spans the whole axis)."""
        return bounds

    def point_derivative(self, fraction: float, angle: float) -> Array:
        """∂p/∂(s, φ) (3×2): [o' − o, r u'(φ)], m and m/rad."""
        du = -math.sin(angle) * self.x + math.cos(angle) * self.y
        return np.column_stack([self.axis, self.radius * du])

    def normal_derivative(self, fraction: float, angle: float) -> Array:
        """∂n/∂(s, φ) (3×2): [0, −u'(φ)], 1/rad."""
        du = -math.sin(angle) * self.x + math.cos(angle) * self.y
        return np.column_stack([np.zeros(3), -du])


def link_radius(robot: Robot, link: str) -> float:
    """The radius (m) of the capsules of `link`'s joint: the largest, or DEFAULT_LINK_RADIUS without any."""
    joint = int(robot.model.frames[robot.frame_id(link)].parentJoint)
    radii = [c.radius for c in robot.link_capsules(DEFAULT_LINK_RADIUS) if c.joint == joint]
    return float(max(radii, default=DEFAULT_LINK_RADIUS))


#: A pad's surface: the analytic capsule about the joint line, or a collision surface snapped to.
PadSurface = LinkSurface | SnappedSurface


#: The surfaces a pad may be placed on: the capsule about the joint line, or the link's collision surface.
SurfaceKind = Literal["capsule", "collision"]


def link_surface(robot: Robot, link: str, kind: SurfaceKind = "capsule") -> PadSurface:
    """The surface the pad of `link` is placed on; ContactError for a link without length.

    ``capsule``: the capsule of the module about the joint line. ``collision``: the link's collision surface
    (its URDF primitives and meshes, or its capsules without any), snapped to
    (:class:`~bracekit.studies.place.snapped.SnappedSurface`, the rule of ``surface = {fraction, angle}``).
    """
    if kind == "collision":
        return snapped_surface(robot, link)
    o, axis, _, z, x = link_frame(robot, link, "it carries no placement")
    return LinkSurface(link, o, axis, x, np.cross(z, x), link_radius(robot, link))
