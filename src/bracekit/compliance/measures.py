"""Kinematic measures of Section V: k, Πσ_t, Πσ_o, σ_min, θ_z and the region barrier d."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from bracekit._linalg import angle_between
from bracekit.errors import BarrierError, SingularityError
from bracekit.tolerances import MEASURE_SINGULAR_RATIO

Array = NDArray[np.float64]



def frobenius_condition(J: ArrayLike) -> float:
    """K = √(tr(JJᵀ) tr((JJᵀ)⁻¹)) / 6 (eq:manip) of a 6×n Jacobian; 1 when isotropic.

    Raises SingularityError when J is (numerically) rank deficient instead of returning inf.
    """
    s = np.linalg.svd(np.asarray(J, dtype=float), compute_uv=False)
    if s.size < 6 or s[-1] <= MEASURE_SINGULAR_RATIO * s[0]:
        raise SingularityError(
            f"the Jacobian is singular (σ_min/σ_max = {s[-1] / max(s[0], 1e-300):.2e}): k is unbounded"
        )
    return float(np.sqrt(np.sum(s**2) * np.sum(s**-2)) / 6.0)


@dataclass(frozen=True)
class SingularValues:
    """Singular-value measures of the translational (rows 1–3) and rotational (rows 4–6) parts of J̃."""

    prod_sigma_t: float
    prod_sigma_o: float
    sigma_t_min: float
    sigma_o_min: float


def singular_value_measures(J: ArrayLike) -> SingularValues:
    """Πσ_t, Πσ_o, σ_t,min, σ_o,min of a 6×n Jacobian (the paper applies them to J̃)."""
    a = np.asarray(J, dtype=float)
    st = np.linalg.svd(a[:3], compute_uv=False)
    so = np.linalg.svd(a[3:], compute_uv=False)
    return SingularValues(float(np.prod(st)), float(np.prod(so)), float(st.min()), float(so.min()))


def theta_z(z_t: ArrayLike, z_b: ArrayLike) -> float:
    """θ_z = acos(ẑ_tᵀ ẑ_b) (eq:theta), rad, computed as atan2(‖ẑ_t × ẑ_b‖, ẑ_tᵀ ẑ_b) for accuracy."""
    return angle_between(np.asarray(z_t, dtype=float), np.asarray(z_b, dtype=float))


def region_barrier(r: float, r_max: float) -> float:
    """D = r_max² / (r_max² − r²), the bracing-region barrier (after eq:theta); 1 at the centre.

    Raises BarrierError at or beyond r_max, where d is unbounded.
    """
    if r >= r_max:
        raise BarrierError(f"the bracing point is {r:.4g} m from the region centre, at or beyond r_max = {r_max:.4g} m")
    return float(r_max**2 / (r_max**2 - r**2))
