"""The paper's frictionless point contact: {b} slides on the plane and turns freely (eq:H_point, l = 5)."""

from __future__ import annotations

from bracekit.contact.base import Array, ContactType, axis_columns, register


@register
class FrictionlessPoint(ContactType):
    """H = [[x̂_t, ŷ_t, 0, 0, 0], [0, 0, x̂_t, ŷ_t, ẑ_t]] (eq:H_point); X = [n̂; 0], the normal force."""

    name = "frictionless_point"
    l = 5
    slides = "xy"
    turns = "xyz"

    def load_wrenches(self, frame: Array, friction: float | None) -> Array:
        """[n̂; 0] without friction; with μ > 0 the point sticks under load: the three forces [x̂_t, ŷ_t, n̂; 0]."""
        if friction is not None and friction > 0.0:
            return axis_columns(frame, "xyz", "")
        return self.X(frame)


FRICTIONLESS_POINT = FrictionlessPoint()
