"""Soft-finger contact: {b} cannot slide nor spin about the normal; it tilts about the tangents (l = 2)."""

from __future__ import annotations

import numpy as np

from bracekit.contact.base import Array, ContactType, columns, register


@register
class SoftFinger(ContactType):
    """H = [[0, 0], [x̂_t, ŷ_t]]; X = the three forces and the normal moment [0; n̂]."""

    name = "soft_finger"
    l = 2

    def H(self, frame: Array) -> Array:
        """Allowable twists of {b} (6×l), world axes, for the tangent frame `frame` (eq:constraint)."""
        zero = np.zeros(3)
        return columns((zero, frame[:, 0]), (zero, frame[:, 1]))

    def X(self, frame: Array) -> Array:
        """Constraint wrenches (6×(6−l)), world axes, reciprocal to H (Hᵀ X = 0)."""
        zero = np.zeros(3)
        return columns((frame[:, 0], zero), (frame[:, 1], zero), (frame[:, 2], zero), (zero, frame[:, 2]))


SOFT_FINGER = SoftFinger()
