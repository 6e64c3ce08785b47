"""Contact types (Salisbury's models): each gives H, the allowable twists of {b}, and X, the constraint wrenches.

H (6×l) and X (6×(6−l)) are expressed at b in world axes and built from the tangent frame {t} of the surface,
whose columns are x̂_t, ŷ_t and ẑ_t = n̂ (eq:constraint). They are reciprocal: Hᵀ X = 0. A contact type owns all
its maths in its own file and registers its TOML/CLI name with :func:`register`.
"""

from __future__ import annotations

from abc import ABC
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from bracekit._linalg import show
from bracekit.errors import ContactError

Array = NDArray[np.float64]


def columns(*cols: tuple[Array, Array]) -> Array:
    """A 6×k matrix whose column j is ``[cols[j][0]; cols[j][1]]`` (linear part, then angular part)."""
    return np.array([np.concatenate(c) for c in cols]).T


def axis_columns(frame: Array, linear: str, angular: str) -> Array:
    """[a; 0] for each tangent-frame axis a named in ``linear``, then [0; a] for each in ``angular`` (6×k).

    Axes are named "x", "y", "z" (x̂_t, ŷ_t, ẑ_t = n̂: the columns of ``frame``), in that order.
    """
    zero = np.zeros(3)
    return columns(*((frame[:, _AXIS[a]], zero) for a in linear), *((zero, frame[:, _AXIS[a]]) for a in angular))


_AXIS = {"x": 0, "y": 1, "z": 2}


def _others(axes: str) -> str:
    """The tangent-frame axes not in ``axes``, in order."""
    return "".join(a for a in "xyz" if a not in axes)


class ContactType(ABC):
    """A contact type: which twists of {b} the contact allows (H) and which wrenches it transmits (X).

    Subclasses set ``name`` (the TOML and CLI name), ``l`` (the number of allowable twist directions) and the
    tangent-frame axes along which {b} slides (``slides``) and about which it turns (``turns``), from which
    :meth:`H` and :meth:`X` follow for a tangent frame (3×3, columns x̂_t, ŷ_t, ẑ_t = n̂, world axes); a
    contact that is not a selection of those axes overrides :meth:`H` and :meth:`X` instead. Instances carry no
    state: two instances of one type are equal.
    """

    name: ClassVar[str]
    l: ClassVar[int]
    #: Tangent-frame axes ("x", "y", "z" = n̂) along which {b} may slide, and about which it may turn.
    slides: ClassVar[str] = ""
    turns: ClassVar[str] = ""

    def H(self, frame: Array) -> Array:
        """Allowable twists of {b} (6×l), world axes, eq:constraint: the slides, then the turns."""
        return axis_columns(frame, self.slides, self.turns)

    def X(self, frame: Array) -> Array:
        """Constraint wrenches (6×(6−l)), world axes, reciprocal to H (Hᵀ X = 0).

        A force along each axis {b} cannot slide along, then a moment about each axis it cannot turn about.
        """
        return axis_columns(frame, _others(self.slides), _others(self.turns))

    def load_wrenches(self, frame: Array, friction: float | None) -> Array:
        """The wrenches the contact transmits under a load with Coulomb friction μ (6×c), world axes.

        Its constraint wrenches X by default: what the contact holds in the first place. A contact that sticks
        under friction (a frictionless point with μ > 0 holds a 3-D force) returns more. The statics check its
        lift-off (the normal force n̂ᵀF > 0) and, with μ > 0, its slip (‖F_t‖ < μ n̂ᵀF) on the force rows.
        """
        return self.X(frame)

    def __eq__(self, other: object) -> bool:
        return type(self) is type(other)

    def __hash__(self) -> int:
        return hash(type(self))

    def __repr__(self) -> str:
        return f"{type(self).__name__}()"


#: name → contact type, filled by :func:`register` (the names of the TOML key ``brace.contact`` and of ``--contact``).
REGISTRY: dict[str, type[ContactType]] = {}


def register(cls: type[ContactType]) -> type[ContactType]:
    """Class decorator: make a contact type available by its ``name``."""
    if cls.name in REGISTRY:
        raise ContactError(f"contact type '{cls.name}' is registered twice")
    REGISTRY[cls.name] = cls
    return cls


def contact_type(name: str | ContactType) -> ContactType:
    """The contact type called `name` (an instance is returned as is); ContactError names the choices."""
    if isinstance(name, ContactType):
        return name
    cls = REGISTRY.get(name) if isinstance(name, str) else None
    if cls is None:
        raise ContactError(f"unknown contact type {show(name)}; choose one of {', '.join(REGISTRY)}")
    return cls()
