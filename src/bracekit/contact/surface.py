"""The bracing surface: a plane with its tangent frame {t} (columns x̂_t, ŷ_t, ẑ_t = n̂)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from bracekit._linalg import as_array
from bracekit.errors import ContactError, NumericalError
from bracekit.spatial import unit

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
        p = _vector3(self.point, "surface point (m)")
        n = unit(_vector3(self.normal, "surface normal"), "surface normal", error=ContactError)
        if self.tangent is None:
            seed = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
        else:
            seed = _vector3(self.tangent, "surface tangent")
            big = float(np.max(np.abs(seed)))
            seed = seed / big if big > 0.0 else seed  # scale-safe; a zero tangent is caught below
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
        """n̂ᵀ(p − point), m: positive on the robot's side of the plane. `p` is a point (3,), m, world."""
        a = p if type(p) is np.ndarray and p.shape == (3,) and p.dtype == np.float64 else as_array(p, "the point", (3,))
        with np.errstate(all="ignore"):
            d = float(self.normal @ (a - self.point))
        if not math.isfinite(d):
            raise NumericalError("the distance from the bracing surface is not finite (float64 overflow)")
        return d


def _vector3(value: object, what: str) -> Array:
    """`value` as 3 finite floats (any shape of 3 numbers); ContactError naming `what` otherwise."""
    a = as_array(value, what, error=ContactError).reshape(-1)
    if a.size != 3:
        raise ContactError(f"{what} must be 3 numbers, got {a.size}")
    return a
