"""Point contact with friction: {b} cannot slide but turns freely (l = 3); it transmits any force."""

from __future__ import annotations

import numpy as np

from bracekit.contact.base import Array, ContactType, columns, register


@register
class PointWithFriction(ContactType):
    """H = [[0, 0, 0], [x̂_t, ŷ_t, ẑ_t]] (rotations only); X = the three forces [x̂_t; 0], [ŷ_t; 0], [n̂; 0]."""

    name = "point_with_friction"
    l = 3

    def H(self, frame: Array) -> Array:
        """Allowable twists of {b} (6×l), world axes, for the tangent frame `frame` (eq:constraint)."""
        zero = np.zeros(3)
        return columns((zero, frame[:, 0]), (zero, frame[:, 1]), (zero, frame[:, 2]))

    def X(self, frame: Array) -> Array:
        """Constraint wrenches (6×(6−l)), world axes, reciprocal to H (Hᵀ X = 0)."""
        zero = np.zeros(3)
        return columns((frame[:, 0], zero), (frame[:, 1], zero), (frame[:, 2], zero))


POINT_WITH_FRICTION = PointWithFriction()
