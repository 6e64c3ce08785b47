"""The bracing surface: a plane with its tangent frame {t} (columns x̂_t, ŷ_t, ẑ_t = n̂)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from bracekit.errors import ContactError
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
        p = np.asarray(self.point, dtype=float).reshape(-1) if _numeric(self.point) else np.full(1, np.nan)
        if p.size != 3 or not np.all(np.isfinite(p)):
            raise ContactError(f"surface point must be 3 finite numbers (m), got {p.tolist()}")
        n = np.asarray(self.normal, dtype=float).reshape(-1) if _numeric(self.normal) else None
        if n is None or n.size != 3:
            raise ContactError(f"surface normal must be 3 numbers, got {self.normal!r}")
        n = unit(n, "surface normal", error=ContactError)
        if self.tangent is None:
            seed = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
        else:
            seed = np.asarray(self.tangent, dtype=float).reshape(-1) if _numeric(self.tangent) else np.full(1, np.nan)
            if seed.size != 3 or not np.all(np.isfinite(seed)):
                raise ContactError("surface tangent must be 3 finite numbers")
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
        """n̂ᵀ(p − point), m: positive on the robot's side of the plane."""
        return float(self.normal @ (np.asarray(p, dtype=float) - self.point))


def _numeric(value: object) -> bool:
    """Whether `value` converts to a float array (numbers, not strings or None)."""
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        return False
    return a.dtype.kind == "f" and not isinstance(value, str)
