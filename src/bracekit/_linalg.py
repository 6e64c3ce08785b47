"""Low-overhead small-matrix helpers for the hot paths (internal).

NumPy's ``np.cross`` and ``np.linalg`` wrappers cost 5–30 µs per call on 3-vectors and 6×6 matrices,
far more than the arithmetic. These helpers do the same computations with less overhead: ``cross3``
gives bit-for-bit the result of ``np.cross`` for 3-vectors; ``inverse`` and ``row_basis`` call LAPACK
(``dgetrf``/``dgetri``, ``dgeqrf``/``dorgqr``/``dtrtri``) directly through SciPy's LAPACK wrappers, without
NumPy's per-call checks.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.linalg import lapack

from bracekit.errors import InputError, NumericalError

Array = NDArray[np.float64]

def _lapack() -> Any:
    """SciPy's LAPACK wrappers (the low-overhead routines of the hot paths)."""
    return lapack


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


# --- input checks and floating-point guards ---------------------------------------------------------
def show(value: object, limit: int = 60) -> str:
    """A one-line repr of `value` for an error message, shortened to about `limit` characters."""
    if isinstance(value, np.ndarray):
        text = f"an array of shape {value.shape}" if value.size > 12 else repr(value.tolist())
    else:
        try:
            text = repr(value)
        except Exception:  # a repr that fails says nothing useful
            text = f"a {type(value).__name__}"
    text = " ".join(text.split())
    return text if len(text) <= limit else text[: limit - 1] + "…"


def as_array(
    value: object,
    what: str,
    shape: tuple[int, ...] | None = None,
    *,
    error: type[Exception] | None = None,
    finite: bool = True,
) -> Array:
    """`value` as a float array: numbers only (not strings, None or booleans), of `shape` (−1: any size), finite.

    Raises `error` (default InputError) naming `what`, in one line that says what was expected.
    """
    err = error or InputError
    want = "numbers" if shape is None else _shape_text(shape)
    try:
        raw = np.asarray(value)
        if raw.dtype.kind not in "iuf":
            raise TypeError
        a = np.asarray(raw, dtype=float)
    except (TypeError, ValueError, OverflowError):
        raise err(f"{what} must be {want}, got {show(value)}") from None
    if shape is not None and (
        a.ndim != len(shape) or any(s not in (-1, d) for s, d in zip(shape, a.shape, strict=True))
    ):
        raise err(f"{what} must be {want}, got shape {a.shape}")
    if finite and not np.all(np.isfinite(a)):
        raise err(f"{what} must be finite numbers (no NaN or inf), got {show(value)}")
    return a


def _shape_text(shape: tuple[int, ...]) -> str:
    if len(shape) == 1:
        return "a list of numbers" if shape[0] == -1 else f"{shape[0]} numbers"
    dims = "×".join("k" if s == -1 else str(s) for s in shape)
    return f"a {dims} matrix of numbers" if len(shape) == 2 else f"an array of shape {dims}"


def as_number(
    value: object,
    what: str,
    *,
    positive: bool = False,
    nonnegative: bool = False,
    unit: str = "",
    error: type[Exception] | None = None,
) -> float:
    """`value` as a finite float (an int, a float or a NumPy scalar; not a bool or a string), else `error`."""
    err = error or InputError
    kind = "a positive number" if positive else "a number ≥ 0" if nonnegative else "a number"
    suffix = f" ({unit})" if unit else ""
    v = math.nan
    if not isinstance(value, bool | np.bool_) and isinstance(value, int | float | np.integer | np.floating):
        try:
            v = float(value)
        except OverflowError:  # an int beyond float64
            pass
    if not math.isfinite(v) or (positive and v <= 0.0) or (nonnegative and v < 0.0):
        raise err(f"{what} must be {kind}{suffix}, got {show(value)}")
    return v


def as_count(value: object, what: str, *, low: int = 1, high: int | None = None) -> int:
    """`value` as an int in [low, high] (a whole number, not a bool or a float), else InputError."""
    count = int(value) if isinstance(value, int | np.integer) and not isinstance(value, bool | np.bool_) else None
    if count is None or count < low or (high is not None and count > high):
        span = f"between {low} and {high}" if high is not None else f"≥ {low}"
        raise InputError(f"{what} must be a whole number {span}, got {show(value)}")
    return count


@contextmanager
def finite_math(what: str) -> Iterator[None]:
    """Raise NumPy's floating-point overflow, invalid operations and divisions by zero as NumericalError.

    Used around computations that must not give inf or NaN, so the user sees one bracekit error instead of a
    RuntimeWarning and a non-finite result. Also usable as a decorator.
    """
    try:
        with np.errstate(over="raise", invalid="raise", divide="raise"):
            yield
    except FloatingPointError as exc:
        raise NumericalError(
            f"{what} is not finite in float64 ({exc}); the inputs are too large or too small: use SI units "
            "and moderate values"
        ) from None
