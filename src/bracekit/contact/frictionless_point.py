"""The paper's frictionless point contact: {b} slides on the plane and turns freely (eq:H_point, l = 5)."""

from __future__ import annotations

import numpy as np

from bracekit.contact.base import Array, ContactType, columns, register


@register
class FrictionlessPoint(ContactType):
    """H = [[x̂_t, ŷ_t, 0, 0, 0], [0, 0, x̂_t, ŷ_t, ẑ_t]] (eq:H_point); X = [n̂; 0], the normal force."""

    name = "frictionless_point"
    l = 5

    def H(self, frame: Array) -> Array:
        """Allowable twists of {b} (6×l), world axes, for the tangent frame `frame` (eq:constraint)."""
        x, y, z = frame[:, 0], frame[:, 1], frame[:, 2]
        zero = np.zeros(3)
        return columns((x, zero), (y, zero), (zero, x), (zero, y), (zero, z))

    def X(self, frame: Array) -> Array:
        """Constraint wrenches (6×(6−l)), world axes, reciprocal to H (Hᵀ X = 0)."""
        return columns((frame[:, 2], np.zeros(3)))

    def load_wrenches(self, frame: Array, friction: float | None) -> Array:
        """[n̂; 0] without friction; with μ > 0 the point sticks under load: the three forces [x̂_t, ŷ_t, n̂; 0]."""
        if friction is not None and friction > 0.0:
            zero = np.zeros(3)
            return columns((frame[:, 0], zero), (frame[:, 1], zero), (frame[:, 2], zero))
        return self.X(frame)


FRICTIONLESS_POINT = FrictionlessPoint()
