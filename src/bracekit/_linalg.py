"""Low-overhead small-matrix helpers for the hot paths (internal).

NumPy's ``np.cross`` and ``np.linalg`` wrappers cost 5–30 µs per call on 3-vectors and 6×6 matrices,
far more than the arithmetic. These helpers do the same computations with less overhead: ``cross3``
gives bit-for-bit the result of ``np.cross`` for 3-vectors; ``inverse`` and ``row_basis`` call LAPACK
(``dgetrf``/``dgetri``, ``dgeqrf``/``dorgqr``/``dtrtri``) directly through SciPy, imported on first use so
that ``import bracekit`` stays light.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]

_LAPACK: Any = None


def _lapack() -> Any:
    global _LAPACK
    if _LAPACK is None:
        from scipy.linalg import lapack

        _LAPACK = lapack
    return _LAPACK


def cross3(a: Array, b: Array) -> Array:
    """A × b of two 3-vectors; the same floating-point operations as ``np.cross``, at a tenth of its cost."""
    return np.array(cross3_list(a.tolist(), b.tolist()))


def cross3_list(a: Sequence[float], b: Sequence[float]) -> list[float]:
    """A × b of the first three entries of two sequences of floats, as a list: cross3 without arrays."""
    a0, a1, a2 = a[0], a[1], a[2]
    b0, b1, b2 = b[0], b[1], b[2]
    return [a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0]


def angle_between(a: Array, b: Array) -> float:
    """atan2(‖a × b‖, a·b), rad: measures.theta_z bit for bit (the same operations), without np.cross."""
    return float(np.arctan2(np.linalg.norm(cross3(a, b)), a @ b))


def inverse(m: Array) -> Array | None:
    """The inverse of a small square matrix by LU with partial pivoting; None if a pivot is exactly zero.

    Near-singular input gives huge (possibly inf or nan) entries: callers bound the condition number
    with the result, e.g. ``not ‖m‖²_F ‖m⁻¹‖²_F < limit`` (which is also true for nan).
    """
    lp = _lapack()
    lu, piv, info = lp.dgetrf(m)
    if info != 0:
        return None
    inv, info = lp.dgetri(lu, piv)
    return None if info != 0 else inv


def row_basis(a: Array) -> tuple[Array, Array] | None:
    """Aᵀ = Q R for a full-row-rank A (m×k, m ≤ k) by Householder QR: Q (k×m) orthonormal and R⁻¹ (m×m).

    Then A⁺ = Q R⁻ᵀ and I − A⁺A = I − Q Qᵀ, with errors proportional to cond(A), not cond(A)² as with
    (AAᵀ)⁻¹. None if R has an exactly zero diagonal; ‖A‖_F ‖R⁻¹‖_F ≥ cond(A) bounds the condition.
    """
    lp = _lapack()
    m = a.shape[0]
    qr, tau, _, info = lp.dgeqrf(a.T)
    if info != 0:
        return None
    rinv, info = lp.dtrtri(qr[:m])  # reads the upper triangle only
    if info != 0:
        return None
    q, _, info = lp.dorgqr(qr, tau)
    return (q, rinv * _upper(m)) if info == 0 else None


_UPPER: dict[int, Array] = {}


def _upper(m: int) -> Array:
    """The 0/1 mask of the upper triangle of an m×m matrix (np.triu is slow on small matrices)."""
    if m not in _UPPER:
        _UPPER[m] = np.triu(np.ones((m, m)))
    return _UPPER[m]
