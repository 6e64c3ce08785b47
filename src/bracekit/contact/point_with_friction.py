"""Point contact with friction: {b} cannot slide but turns freely (l = 3); it transmits any force."""

from __future__ import annotations

from bracekit.contact.base import ContactType, register


@register
class PointWithFriction(ContactType):
    """H = [[0, 0, 0], [x̂_t, ŷ_t, ẑ_t]] (rotations only); X = the three forces [x̂_t; 0], [ŷ_t; 0], [n̂; 0]."""

    name = "point_with_friction"
    l = 3
    slides = ""
    turns = "xyz"


POINT_WITH_FRICTION = PointWithFriction()
