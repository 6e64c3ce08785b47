"""Bracing contacts: the surface, the contact types (one file each) and the brace (eq:constraint, eq:H_point).

Adding a contact type: a new file with a :class:`ContactType` subclass decorated with ``@register``, and its
import below (the registration line).
"""

from bracekit.contact.base import REGISTRY, ContactType, contact_type, register
from bracekit.contact.brace import Brace
from bracekit.contact.frictionless_point import FRICTIONLESS_POINT, FrictionlessPoint
from bracekit.contact.point_with_friction import POINT_WITH_FRICTION, PointWithFriction
from bracekit.contact.soft_finger import SOFT_FINGER, SoftFinger
from bracekit.contact.surface import Surface

#: The contact type names accepted by scenarios and the command line.
CONTACT_TYPES: tuple[str, ...] = tuple(REGISTRY)

__all__ = [
    "CONTACT_TYPES",
    "FRICTIONLESS_POINT",
    "POINT_WITH_FRICTION",
    "REGISTRY",
    "SOFT_FINGER",
    "Brace",
    "ContactType",
    "FrictionlessPoint",
    "PointWithFriction",
    "SoftFinger",
    "Surface",
    "contact_type",
    "register",
]
