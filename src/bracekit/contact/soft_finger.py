"""Soft-finger contact: {b} cannot slide nor spin about the normal; it tilts about the tangents (l = 2)."""

from __future__ import annotations

from bracekit.contact.base import ContactType, register


@register
class SoftFinger(ContactType):
    """H = [[0, 0], [x̂_t, ŷ_t]]; X = the three forces and the normal moment [0; n̂]."""

    name = "soft_finger"
    l = 2
    slides = ""
    turns = "xy"


SOFT_FINGER = SoftFinger()
