"""Tests of bracekit.compliance.measures (Section V): k, Πσ_t, Πσ_o, σ_min, θ_z and the region barrier d.

References: eigenvalues of JJᵀ (numpy.linalg.eigvalsh), determinants of the 3×3 blocks of JJᵀ,
arccos / exact angles, and the barrier formula by hand.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from bracekit.compliance.measures import frobenius_condition, region_barrier, singular_value_measures, theta_z
from bracekit.errors import BarrierError, SingularityError

SETTINGS = settings(max_examples=40, deadline=None)


def random_jacobian(seed: int, n: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return rng.normal(size=(6, n)) * rng.uniform(0.1, 2.0, size=(6, 1))


@pytest.mark.parametrize("scale", [1e-3, 1.0, 7.5])
def test_condition_number_of_an_isotropic_jacobian_is_one(scale: float) -> None:
    assert frobenius_condition(scale * np.eye(6)) == pytest.approx(1.0, abs=1e-12)
    # [I 0; 0 I]-type 6×n Jacobians with orthonormal rows are isotropic too
    q, _ = np.linalg.qr(np.random.default_rng(1).normal(size=(9, 9)))
    assert frobenius_condition(scale * q[:6]) == pytest.approx(1.0, abs=1e-12)
    assert frobenius_condition(scale * np.hstack([np.eye(6), np.zeros((6, 3))])) == pytest.approx(1.0, abs=1e-12)


@SETTINGS
@given(seed=st.integers(0, 2**31), n=st.integers(6, 12))
def test_condition_number_equals_the_trace_formula_via_eigenvalues(seed: int, n: int) -> None:
    J = random_jacobian(seed, n)
    lam = np.linalg.eigvalsh(J @ J.T)
    expected = math.sqrt(lam.sum() * (1.0 / lam).sum()) / 6.0
    k = frobenius_condition(J)
    # eigvalsh of JJᵀ loses about eps·cond(J)² relative accuracy on the smallest eigenvalue
    assert k == pytest.approx(expected, rel=max(1e-10, 1e-14 * np.linalg.cond(J) ** 2))
    assert k >= 1.0 - 1e-12  # k = 1 only when isotropic


def test_condition_number_of_a_known_diagonal_jacobian() -> None:
    # singular values 1, 1, 1, 1, 1, 2: tr(JJᵀ) = 9, tr((JJᵀ)⁻¹) = 5.25
    J = np.diag([1.0, 1.0, 1.0, 1.0, 1.0, 2.0])
    assert frobenius_condition(J) == pytest.approx(math.sqrt(9 * 5.25) / 6.0, rel=1e-14)


@pytest.mark.parametrize(
    "J",
    [
        np.zeros((6, 7)),
        np.hstack([np.eye(6)[:, :5], np.eye(6)[:, :2]]),  # rank 5
        np.eye(6)[:, :5],  # fewer than 6 columns
        np.diag([1.0, 1.0, 1.0, 1.0, 1.0, 1e-14]),  # numerically singular
    ],
    ids=["zero", "rank-5", "6x5", "tiny-sigma"],
)
def test_singular_jacobian_raises_singularity_error_not_inf(J: np.ndarray) -> None:
    with pytest.raises(SingularityError) as info:
        frobenius_condition(J)
    assert "\n" not in str(info.value)


def test_nearly_singular_but_regular_jacobian_gives_a_large_finite_k() -> None:
    J = np.diag([1.0, 1.0, 1.0, 1.0, 1.0, 1e-6])
    assert frobenius_condition(J) == pytest.approx(math.sqrt(5.000000000001 * (5 + 1e12)) / 6.0, rel=1e-9)


@SETTINGS
@given(seed=st.integers(0, 2**31), n=st.integers(3, 12))
def test_singular_value_products_are_sqrt_det_of_the_block_grams(seed: int, n: int) -> None:
    J = random_jacobian(seed, n)
    sv = singular_value_measures(J)
    Jt, Jo = J[:3], J[3:]
    assert sv.prod_sigma_t == pytest.approx(math.sqrt(np.linalg.det(Jt @ Jt.T)), rel=1e-8)
    assert sv.prod_sigma_o == pytest.approx(math.sqrt(np.linalg.det(Jo @ Jo.T)), rel=1e-8)
    assert sv.sigma_t_min == pytest.approx(math.sqrt(np.linalg.eigvalsh(Jt @ Jt.T).min()), rel=1e-6, abs=1e-12)
    assert sv.sigma_o_min == pytest.approx(math.sqrt(np.linalg.eigvalsh(Jo @ Jo.T).min()), rel=1e-6, abs=1e-12)


def test_singular_value_measures_of_a_block_diagonal_jacobian() -> None:
    J = np.zeros((6, 6))
    J[:3, :3] = np.diag([2.0, 3.0, 0.5])
    J[3:, 3:] = np.diag([1.0, 4.0, 0.25])
    sv = singular_value_measures(J)
    assert (sv.prod_sigma_t, sv.sigma_t_min) == pytest.approx((3.0, 0.5), rel=1e-14)
    assert (sv.prod_sigma_o, sv.sigma_o_min) == pytest.approx((1.0, 0.25), rel=1e-14)


@SETTINGS
@given(
    a=st.floats(0.0, 2 * math.pi, allow_nan=False),
    b=st.floats(0.05, math.pi - 0.05, allow_nan=False),
)
def test_theta_z_matches_acos_for_well_conditioned_angles(a: float, b: float) -> None:
    z_t = np.array([0.0, 0.0, 1.0])
    z_b = np.array([math.sin(b) * math.cos(a), math.sin(b) * math.sin(a), math.cos(b)])
    assert theta_z(z_t, z_b) == pytest.approx(math.acos(float(z_t @ z_b)), abs=1e-12)
    assert theta_z(z_t, z_b) == pytest.approx(b, abs=1e-12)


@pytest.mark.parametrize("eps", [1e-9, 1e-7, 1e-5])
def test_theta_z_is_accurate_near_zero_and_near_pi(eps: float) -> None:
    rng = np.random.default_rng(3)
    R, _ = np.linalg.qr(rng.normal(size=(3, 3)))  # an arbitrary orientation of both vectors
    z_t = R @ np.array([0.0, 0.0, 1.0])
    near_zero = R @ np.array([math.sin(eps), 0.0, math.cos(eps)])
    near_pi = R @ np.array([math.sin(eps), 0.0, -math.cos(eps)])
    assert theta_z(z_t, near_zero) == pytest.approx(eps, rel=1e-6)
    assert math.pi - theta_z(z_t, near_pi) == pytest.approx(eps, rel=1e-6)
    assert theta_z(z_t, z_t) == 0.0
    assert theta_z(z_t, -z_t) == pytest.approx(math.pi, abs=1e-15)


def test_region_barrier_is_one_at_the_centre_and_follows_the_formula() -> None:
    assert region_barrier(0.0, 0.2) == 1.0
    for r in (0.05, 0.1, 0.19, 0.1999999):
        assert region_barrier(r, 0.2) == pytest.approx(0.04 / (0.04 - r * r), rel=1e-9)
    assert region_barrier(0.1, 0.2) < region_barrier(0.15, 0.2) < region_barrier(0.19, 0.2)


@pytest.mark.parametrize("r", [0.2, 0.2000001, 0.3, 10.0])
def test_region_barrier_raises_barrier_error_at_or_beyond_r_max(r: float) -> None:
    with pytest.raises(BarrierError) as info:
        region_barrier(r, 0.2)
    assert "\n" not in str(info.value)


# ---------------------------------------------------------------------------------------------- bad input
@pytest.mark.parametrize(
    "J",
    [
        np.full((6, 7), np.nan),
        np.array([[np.inf] * 7] + [[1.0] * 7] * 5),
        np.eye(3),
        np.ones(6),
        "J",
        None,
        [[1, 2], [3]],
    ],
)
def test_measures_of_a_jacobian_that_is_not_a_finite_6xn_matrix_are_input_errors(J: object) -> None:
    from bracekit.errors import InputError

    for fn in (frobenius_condition, singular_value_measures):
        with pytest.raises(InputError) as info:
            fn(J)  # type: ignore[arg-type]
        assert "\n" not in str(info.value)


@pytest.mark.parametrize("scale", [1e-170, 1e160, 1e300])
def test_condition_number_is_scale_free_even_where_the_squares_leave_float64(scale: float) -> None:
    J = random_jacobian(3, 8)
    assert frobenius_condition(scale * J) == pytest.approx(frobenius_condition(J), rel=1e-12)


def test_singular_value_products_that_overflow_are_numerical_errors_not_warnings() -> None:
    from bracekit.errors import NumericalError

    with pytest.raises(NumericalError, match="not finite"):
        singular_value_measures(1e160 * random_jacobian(4, 8))


def test_theta_z_refuses_zero_nan_or_wrongly_sized_vectors_and_is_scale_free() -> None:
    from bracekit.errors import InputError

    for a, b in (([0, 0, 0], [0, 0, 1]), ([np.nan, 0, 0], [0, 0, 1]), ([1, 0], [0, 0, 1]), ("z", [0, 0, 1])):
        with pytest.raises(InputError):
            theta_z(a, b)  # type: ignore[arg-type]
    big = np.array([1e300, 0.0, 1e300])
    assert theta_z(big, [0.0, 0.0, 1.0]) == pytest.approx(np.pi / 4, rel=1e-15)


@pytest.mark.parametrize(
    ("r", "r_max"), [(np.nan, 0.15), (0.1, np.nan), (-0.1, 0.15), (0.1, 0.0), ("0.1", 0.15), (0.1, None), (True, 1.0)]
)
def test_region_barrier_refuses_values_that_are_not_a_distance_and_a_radius(r: object, r_max: object) -> None:
    from bracekit.errors import InputError

    with pytest.raises(InputError) as info:
        region_barrier(r, r_max)  # type: ignore[arg-type]
    assert "\n" not in str(info.value)
