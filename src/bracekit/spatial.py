"""Skew matrices and the twist/wrench maps of the paper (eq:skew_sym, eq:twists).

Twists are [v; ω] and wrenches [f; m], both (6,), referred to a point with axes parallel to a frame.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from bracekit._linalg import as_array, show
from bracekit.errors import InputError, NumericalError

Array = NDArray[np.float64]
_EYE6 = np.eye(6)


def _floats(a: ArrayLike, shape: tuple[int, ...], what: str) -> Array:
    """`a` itself if it is a float64 array of `shape` (the hot path), else :func:`as_array` with its checks."""
    if type(a) is np.ndarray and a.shape == shape and a.dtype == np.float64:
        return a
    return as_array(a, what, shape)


def skew(a: ArrayLike) -> Array:
    """[a]×, the 3×3 cross-product matrix of a 3-vector (eq:skew_sym): [a]× x = a × x."""
    x, y, z = _floats(a, (3,), "the vector of skew()").tolist()
    if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(z)):
        raise InputError(f"skew() needs 3 finite numbers, got {[x, y, z]}")
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def twist_shift(b: ArrayLike, e: ArrayLike) -> Array:
    """S_t1 (eq:twists): moves a twist's reference point from b to e, axes unchanged. (6, 6).

    S_t1 = [[I, [b − e]×], [0, I]], so v_e = v_b + ω × (e − b).
    """
    b0, b1, b2 = _floats(b, (3,), "the point b").tolist()
    e0, e1, e2 = _floats(e, (3,), "the point e").tolist()
    x, y, z = b0 - e0, b1 - e1, b2 - e2  # Python floats: an overflow gives inf, caught below
    if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(z)):
        raise NumericalError("b − e is not finite; give finite points of moderate size (m)")
    s = _EYE6.copy()
    s[:3, 3:] = ((0.0, -z, y), (z, 0.0, -x), (-y, x, 0.0))
    return s


def twist_rotate(rotation: ArrayLike) -> Array:
    """S_t2 (eq:twists): re-expresses a twist given in {b}'s axes in world axes, S_t2 = diag(⁰R_b, ⁰R_b)."""
    r = _floats(rotation, (3, 3), "the rotation")
    if not np.isfinite(r).all():
        raise InputError("the rotation must be finite numbers (no NaN or inf)")
    s = np.zeros((6, 6))
    s[:3, :3] = r
    s[3:, 3:] = r
    return s


def wrench_map(twist_map: ArrayLike) -> Array:
    """The wrench map dual to a twist map: S_w = S_tᵀ (erratum of eq:Ce in docs/model.md; keeps C_e symmetric)."""
    return as_array(twist_map, "the twist map", (6, 6)).T.copy()


def unit(v: ArrayLike, what: str = "vector", error: type[InputError] = InputError) -> Array:
    """V / ‖v‖ as floats, safe for any scale (1e-300 or 1e300 components).

    Raises `error` (an InputError) naming `what` if v is zero, not finite or not numbers.
    """
    a = as_array(v, what, finite=False, error=error).reshape(-1)
    big = float(np.max(np.abs(a), initial=0.0))
    if not np.all(np.isfinite(a)) or big == 0.0:
        raise error(f"{what} must be a finite, non-zero vector, got {show(a)}")
    if 1e-150 < big < 1e150:  # ‖a‖ neither overflows nor underflows: the plain quotient
        return a / float(np.linalg.norm(a))
    scaled = a / big  # the largest component is ±1
    return scaled / float(np.linalg.norm(scaled))


def rotation_with_z(axis: ArrayLike, what: str = "axis", error: type[InputError] = InputError) -> Array:
    """A rotation matrix (3×3) whose third column is the unit vector of `axis`.

    The first column is the component of the coordinate axis least aligned with `axis` orthogonal to it, so
    an `axis` along a coordinate axis gives a signed permutation (identity for +z). Raises `error` naming
    `what` for a zero or non-finite axis.
    """
    z = unit(axis, what, error)
    if np.allclose(z, (0.0, 0.0, 1.0), rtol=0.0, atol=1e-15):
        return np.eye(3)
    seed = np.zeros(3)
    seed[int(np.argmin(np.abs(z)))] = 1.0
    x = seed - (seed @ z) * z
    x /= float(np.linalg.norm(x))
    return np.column_stack([x, np.cross(z, x), z])
