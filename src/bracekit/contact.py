"""Bracing surfaces, contact types and the brace (eq:constraint, eq:H_point).

A contact type gives H (6×l), the basis of allowable twists of {b}, and X (6×(6−l)), the basis of
constraint wrenches reciprocal to it (Hᵀ X = 0). Both are expressed at b in world axes, built from the
tangent frame {t} of the surface: columns x̂_t, ŷ_t, ẑ_t = n̂ (Salisbury's contact models).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .errors import ContactError
from .spatial import unit

Array = NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class Surface:
    """A bracing plane: a point on it (m, world) and its unit normal n̂ pointing toward the robot.

    `tangent` (optional) fixes x̂_t of the tangent frame {t}; it is made orthogonal to n̂.
    """

    point: Array
    normal: Array
    tangent: Array | None = None
    frame: Array = field(init=False, repr=False)

    def __post_init__(self) -> None:
        p = np.asarray(self.point, dtype=float).reshape(-1)
        if p.size != 3 or not np.all(np.isfinite(p)):
            raise ContactError(f"surface point must be 3 finite numbers (m), got {p.tolist()}")
        try:
            n = unit(self.normal, "surface normal")
        except ValueError as exc:
            raise ContactError(f"{exc}; give e.g. --normal 0,0,1") from exc
        if n.size != 3:
            raise ContactError(f"surface normal must have 3 components, got {n.size}")
        if self.tangent is None:
            seed = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
        else:
            seed = np.asarray(self.tangent, dtype=float).reshape(-1)
            if seed.size != 3 or not np.all(np.isfinite(seed)):
                raise ContactError("surface tangent must be 3 finite numbers")
        x = seed - n * (n @ seed)
        if np.linalg.norm(x) < 1e-9:
            raise ContactError("surface tangent is parallel to the normal; give a tangent in the plane")
        x /= np.linalg.norm(x)
        y = np.cross(n, x)
        object.__setattr__(self, "point", p)
        object.__setattr__(self, "normal", n)
        object.__setattr__(self, "tangent", x)
        object.__setattr__(self, "frame", np.column_stack([x, y, n]))

    def signed_distance(self, p: ArrayLike) -> float:
        """n̂ᵀ(p − point), m: positive on the robot's side of the plane."""
        return float(self.normal @ (np.asarray(p, dtype=float) - self.point))


@dataclass(frozen=True)
class Contact:
    """A contact type: which twists of {b} the contact allows (H) and which wrenches it transmits (X)."""

    name: str = "frictionless_point"

    def H(self, frame: Array) -> Array:
        """Allowable twists of {b} (6×l), world axes, for the tangent frame `frame` (3×3, columns x,y,z)."""
        x, y, z = frame[:, 0], frame[:, 1], frame[:, 2]
        zero = np.zeros(3)
        if self.name == "frictionless_point":  # eq:H_point
            cols = [(x, zero), (y, zero), (zero, x), (zero, y), (zero, z)]
        elif self.name == "point_with_friction":
            cols = [(zero, x), (zero, y), (zero, z)]
        elif self.name == "soft_finger":
            cols = [(zero, x), (zero, y)]
        else:  # pragma: no cover - guarded by __post_init__
            raise ContactError(f"unknown contact type '{self.name}'")
        return np.array([np.concatenate(c) for c in cols]).T

    def X(self, frame: Array) -> Array:
        """Constraint wrenches (6×(6−l)), reciprocal to H: Hᵀ X = 0."""
        x, y, z = frame[:, 0], frame[:, 1], frame[:, 2]
        zero = np.zeros(3)
        if self.name == "frictionless_point":
            cols = [(z, zero)]
        elif self.name == "point_with_friction":
            cols = [(x, zero), (y, zero), (z, zero)]
        elif self.name == "soft_finger":
            cols = [(x, zero), (y, zero), (z, zero), (zero, z)]
        else:  # pragma: no cover
            raise ContactError(f"unknown contact type '{self.name}'")
        return np.array([np.concatenate(c) for c in cols]).T

    @property
    def l(self) -> int:  # noqa: E743 - paper's name
        """Number of allowable twist directions."""
        return {"frictionless_point": 5, "point_with_friction": 3, "soft_finger": 2}[self.name]

    def __post_init__(self) -> None:
        if self.name not in CONTACT_TYPES:
            raise ContactError(f"unknown contact type '{self.name}'; choose one of {', '.join(CONTACT_TYPES)}")


CONTACT_TYPES = ("frictionless_point", "point_with_friction", "soft_finger")
FRICTIONLESS_POINT = Contact("frictionless_point")
POINT_WITH_FRICTION = Contact("point_with_friction")
SOFT_FINGER = Contact("soft_finger")


@dataclass(frozen=True, eq=False)
class Brace:
    """A bracing contact: frame {b} of the robot touching `surface` through `contact`.

    Attributes:
        frame: name of the bracing frame {b} (a frame of the robot; add one at a link point with
            ``Robot.with_point_frame``).
        surface: the bracing plane.
        contact: contact type (default: the paper's frictionless point contact).
        region_radius: r_max of the circular bracing region centred at ``surface.point`` (m), or None.
        environment_stiffness: stiffness of the environment along each constraint direction (N/m, or
            N·m/rad for constraint moments); None means rigid (the paper's assumption).
    """

    frame: str
    surface: Surface
    contact: Contact = FRICTIONLESS_POINT
    region_radius: float | None = None
    environment_stiffness: float | None = None

    def __post_init__(self) -> None:
        if self.region_radius is not None and not (np.isfinite(self.region_radius) and self.region_radius > 0):
            raise ContactError(f"bracing region radius must be a positive length (m), got {self.region_radius}")
        if self.environment_stiffness is not None and not (
            np.isfinite(self.environment_stiffness) and self.environment_stiffness > 0
        ):
            raise ContactError(
                f"environment stiffness must be positive (N/m) or omitted for rigid, got {self.environment_stiffness}"
            )

    def H(self) -> Array:
        """H of eq:constraint for this brace (6×l)."""
        return self.contact.H(self.surface.frame)

    def X(self) -> Array:
        """Constraint wrench basis X (6×(6−l)), Hᵀ X = 0."""
        return self.contact.X(self.surface.frame)
