"""Skew matrices and the twist/wrench maps of the paper (eq:skew_sym, eq:twists).

Twists are [v; ω] and wrenches [f; m], both (6,), referred to a point with axes parallel to a frame.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from bracekit.errors import InputError

Array = NDArray[np.float64]
_EYE6 = np.eye(6)


def skew(a: ArrayLike) -> Array:
    """[a]×, the 3×3 cross-product matrix of a 3-vector (eq:skew_sym): skew(a) @ x == a × x."""
    x, y, z = np.asarray(a, dtype=float).reshape(3).tolist()
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def twist_shift(b: ArrayLike, e: ArrayLike) -> Array:
    """S_t1 (eq:twists): moves a twist's reference point from b to e, axes unchanged. (6, 6).

    S_t1 = [[I, [b − e]×], [0, I]], so v_e = v_b + ω × (e − b).
    """
    s = _EYE6.copy()
    s[:3, 3:] = skew(np.subtract(b, e, dtype=float))
    return s


def twist_rotate(rotation: ArrayLike) -> Array:
    """S_t2 (eq:twists): re-expresses a twist given in {b}'s axes in world axes, S_t2 = diag(⁰R_b, ⁰R_b)."""
    r = np.asarray(rotation, dtype=float).reshape(3, 3)
    s = np.zeros((6, 6))
    s[:3, :3] = r
    s[3:, 3:] = r
    return s


def wrench_map(twist_map: ArrayLike) -> Array:
    """The wrench map dual to a twist map: S_w = S_tᵀ (erratum of eq:Ce in docs/model.md; keeps C_e symmetric)."""
    return np.asarray(twist_map, dtype=float).T.copy()


def unit(v: ArrayLike, what: str = "vector", error: type[InputError] = InputError) -> Array:
    """V / ‖v‖ as floats, safe for any scale (1e-300 or 1e300 components).

    Raises `error` (an InputError) naming `what` if v is zero, not finite or not numbers.
    """
    try:
        a = np.asarray(v, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise error(f"{what} must be numbers, got {v!r}") from None
    big = float(np.max(np.abs(a), initial=0.0))
    if not np.all(np.isfinite(a)) or big == 0.0:
        raise error(f"{what} must be a finite, non-zero vector, got {a.tolist()}")
    if 1e-150 < big < 1e150:  # ‖a‖ neither overflows nor underflows: the plain quotient
        return a / float(np.linalg.norm(a))
    scaled = a / big  # the largest component is ±1
    return scaled / float(np.linalg.norm(scaled))
