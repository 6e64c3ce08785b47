"""Kinematic measures of Section V: k, Πσ_t, Πσ_o, σ_min, θ_z and the region barrier d."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from bracekit._linalg import angle_between, as_array, as_number, finite_math
from bracekit.errors import BarrierError, InputError, NumericalError, SingularityError
from bracekit.tolerances import MEASURE_SINGULAR_RATIO

Array = NDArray[np.float64]


def jacobian_matrix(J: ArrayLike, what: str = "the Jacobian") -> Array:
    """`J` as a finite 6×n float array (n ≥ 1); InputError naming `what` otherwise."""
    return as_array(J, f"{what} (6×n)", (6, -1))


def frobenius_condition(J: ArrayLike) -> float:
    """K = √(tr(JJᵀ) tr((JJᵀ)⁻¹)) / 6 (eq:manip) of a 6×n Jacobian; 1 when isotropic.

    Raises SingularityError when J is (numerically) rank deficient instead of returning inf, and InputError
    when J is not a finite 6×n matrix.
    """
    s = np.linalg.svd(jacobian_matrix(J), compute_uv=False)
    if s.size < 6 or not s[-1] > MEASURE_SINGULAR_RATIO * s[0]:
        ratio = s[-1] / s[0] if s.size and s[0] > 0 else 0.0
        raise SingularityError(f"the Jacobian is singular (σ_min/σ_max = {ratio:.2e}): k is unbounded")
    try:
        with np.errstate(over="raise", under="ignore"):
            return float(np.sqrt(np.sum(s**2) * np.sum(s**-2)) / 6.0)
    except FloatingPointError:  # σ beyond float64's squares: the same k from σ/σ_max (scale-free)
        r = s / s[0]
        return float(np.sqrt(np.sum(r**2) * np.sum(r**-2)) / 6.0)


@dataclass(frozen=True)
class SingularValues:
    """Singular-value measures of the translational (rows 1–3) and rotational (rows 4–6) parts of J̃."""

    prod_sigma_t: float
    prod_sigma_o: float
    sigma_t_min: float
    sigma_o_min: float


def singular_value_measures(J: ArrayLike) -> SingularValues:
    """Πσ_t, Πσ_o, σ_t,min, σ_o,min of a 6×n Jacobian (the paper applies them to J̃).

    Raises InputError when J is not a finite 6×n matrix and NumericalError when a product overflows.
    """
    a = jacobian_matrix(J)
    st = np.linalg.svd(a[:3], compute_uv=False)
    so = np.linalg.svd(a[3:], compute_uv=False)
    with finite_math("the product of J̃'s singular values"):
        return SingularValues(float(np.prod(st)), float(np.prod(so)), float(st.min()), float(so.min()))


def theta_z(z_t: ArrayLike, z_b: ArrayLike) -> float:
    """θ_z = acos(ẑ_tᵀ ẑ_b) (eq:theta), rad, computed as atan2(‖ẑ_t × ẑ_b‖, ẑ_tᵀ ẑ_b) for accuracy.

    `z_t` and `z_b` are non-zero 3-vectors (their lengths do not matter); InputError otherwise.
    """
    a, b = as_array(z_t, "z_t", (3,)), as_array(z_b, "z_b", (3,))
    if not (a.any() and b.any()):
        raise InputError("theta_z needs two non-zero 3-vectors (the surface normal and the pad axis)")
    try:
        with np.errstate(over="raise", invalid="raise", under="ignore"):
            return angle_between(a, b)
    except FloatingPointError:  # components beyond float64's products: the same angle of the scaled vectors
        return angle_between(a / np.max(np.abs(a)), b / np.max(np.abs(b)))


def region_barrier(r: float, r_max: float) -> float:
    """D = r_max² / (r_max² − r²), the bracing-region barrier (after eq:theta); 1 at the centre.

    `r` (m, ≥ 0) is the distance of the bracing point from the region centre, `r_max` (m, > 0) the region's
    radius. Raises BarrierError at or beyond r_max, where d is unbounded, and InputError for other values.
    """
    if not (isinstance(r, float) and isinstance(r_max, float) and 0.0 <= r < math.inf and 0.0 < r_max < math.inf):
        r = as_number(r, "the distance r from the region centre", nonnegative=True, unit="m")
        r_max = as_number(r_max, "the region radius r_max", positive=True, unit="m")
    if r >= r_max:
        raise BarrierError(f"the bracing point is {r:.4g} m from the region centre, at or beyond r_max = {r_max:.4g} m")
    try:
        with finite_math("the region barrier d"):
            return float(r_max**2 / (r_max**2 - r**2))
    except OverflowError:  # a Python float's square beyond float64
        raise NumericalError(f"the region barrier d overflows float64 (r_max = {r_max:.4g} m)") from None
