"""Tests of the readings of a tip compliance C_e (Section IV): directional compliance, C_i, ellipsoids, their input.

References, all computed from an independent Pinocchio model of the same URDF (the cases of test_first_order):
* the bordered KKT (Lagrange-multiplier) equilibrium of the WHOLE robot, `lagrange_compliance(J_e, K, a)`:
  the deflection along β_x per unit wrench along β_w, the largest over unit wrenches (by SVD and by sampling),
  and the deflection along an ellipsoid axis per unit load along it (eigenvectors of its blocks);
* :func:`bracekit.spatial.unit` for unit6, bit for bit, and its refusals.
"""

from __future__ import annotations

import numpy as np
import pytest
from test_first_order import paper_case, random_case

from bracekit.compliance.first_order import (
    compliance_ellipsoids,
    compliance_index,
    directional_compliance,
    end_effector_compliance,
)
from bracekit.errors import InputError
from helpers import random_unit


# ---------------------------------------------------------------------------------------------- measures of C_e
def test_directional_compliance_is_the_kkt_deflection_along_beta_x_per_unit_wrench_along_beta_w() -> None:
    c = random_case(9, seed=21, link=6)
    ce, kkt = end_effector_compliance(c.state), c.kkt()
    rng = np.random.default_rng(1)
    for _ in range(5):
        bx, bw = random_unit(rng, 6), random_unit(rng, 6)
        deflection = kkt @ bw  # unit wrench along β_w
        assert directional_compliance(ce, bx, bw) == pytest.approx(bx @ deflection, rel=1e-9, abs=1e-15)
    r_hat = np.r_[1.0, 0.0, 0.0, 0.0, 0.0, 0.0]  # radial force and deflection, the paper's case
    assert directional_compliance(ce, r_hat, r_hat) == pytest.approx(kkt[0, 0], rel=1e-9)


def test_directional_compliance_rejects_bad_directions() -> None:
    ce = end_effector_compliance(paper_case().state)
    with pytest.raises(InputError, match="beta_x"):
        directional_compliance(ce, np.zeros(6), np.ones(6))
    with pytest.raises(InputError, match="beta_w"):
        directional_compliance(ce, np.ones(6), np.ones(3))
    with pytest.raises(InputError):
        compliance_index(ce, [np.nan, 0, 0, 0, 0, 1.0])


def test_compliance_index_is_the_largest_deflection_along_beta_x_over_unit_wrenches() -> None:
    c = paper_case()
    ce, kkt = end_effector_compliance(c.state), c.kkt()
    bx = np.r_[random_unit(np.random.default_rng(0)), 0.0, 0.0, 0.0]
    ci = compliance_index(ce, bx)
    # SVD of the 1×6 map w ↦ β_xᵀ Δx from the KKT reference
    assert ci == pytest.approx(np.linalg.svd((bx @ kkt)[None, :], compute_uv=False)[0], rel=1e-9)
    # sampling unit wrenches: never above C_i, and close to it at the best sample
    rng = np.random.default_rng(7)
    w = rng.normal(size=(20_000, 6))
    w /= np.linalg.norm(w, axis=1, keepdims=True)
    deflections = w @ kkt.T @ bx
    assert deflections.max() <= ci * (1 + 1e-9)
    assert deflections.max() >= 0.95 * ci
    assert ci >= abs(directional_compliance(ce, bx, bx))  # never below the collinear directional compliance


@pytest.mark.parametrize("which", ["paper", "chain"])
def test_compliance_ellipsoid_axes_are_eigenvectors_and_semi_axes_the_deflection_per_unit_load(which: str) -> None:
    c = paper_case() if which == "paper" else random_case(8, seed=2, link=4)
    ell = compliance_ellipsoids(end_effector_compliance(c.state))
    kkt = c.kkt()
    for block, part in ((slice(0, 3), ell.translational), (slice(3, 6), ell.rotational)):
        np.testing.assert_allclose(part.axes.T @ part.axes, np.eye(3), atol=1e-12)
        assert np.all(np.diff(part.semi_axes) >= 0.0) and np.all(part.semi_axes >= 0.0)
        for i in range(3):
            load = np.zeros(6)
            load[block] = part.axes[:, i]  # unit force (or unit moment) along the axis
            deflection = (kkt @ load)[block]  # translation (or rotation) it causes
            np.testing.assert_allclose(deflection, part.semi_axes[i] * part.axes[:, i], atol=1e-9 * np.abs(kkt).max())
        np.testing.assert_allclose(part.semi_axes, np.linalg.eigvalsh(kkt[block, block]), rtol=1e-9, atol=1e-15)


# ---------------------------------------------------------------------------------------------- bad input
@pytest.mark.parametrize("c_e", [np.eye(3), np.full((6, 6), np.inf), "C", None, [[1.0] * 6] * 5, np.ones((6, 6, 1))])
def test_compliance_measures_refuse_anything_but_a_finite_6x6_matrix(c_e: object) -> None:
    e_x = np.r_[1.0, 0, 0, 0, 0, 0]
    for call in (
        lambda: compliance_index(c_e, e_x),
        lambda: directional_compliance(c_e, e_x, e_x),
        lambda: compliance_ellipsoids(c_e),
    ):
        with pytest.raises(InputError) as info:
            call()
        assert "\n" not in str(info.value)


@pytest.mark.parametrize("beta", [np.zeros(6), np.full(6, np.nan), [1, 0, 0], "x", None, [[1, 0, 0], [0, 0]]])
def test_a_twist_that_is_not_6_finite_numbers_is_an_input_error(beta: object) -> None:
    with pytest.raises(InputError):
        compliance_index(np.eye(6), beta)  # type: ignore[arg-type]
    with pytest.raises(InputError):
        directional_compliance(np.eye(6), [1, 0, 0, 0, 0, 0], beta)  # type: ignore[arg-type]


def test_unit6_of_a_float_twist_is_spatial_unit_bit_for_bit_and_refuses_what_it_refuses() -> None:
    """Reference: :func:`bracekit.spatial.unit` (any scale) and its InputError; a non-finite entry anywhere."""
    from bracekit.compliance.first_order import unit6
    from bracekit.errors import InputError
    from bracekit.spatial import unit

    rng = np.random.default_rng(29)
    for _ in range(2000):
        v = rng.standard_normal(6) * 10.0 ** float(rng.integers(-300, 300))
        try:
            want = unit(v.copy(), "beta_x")
        except InputError:
            with pytest.raises(InputError):
                unit6(v, "beta_x")
            continue
        assert np.array_equal(unit6(v, "beta_x"), want)
        assert np.array_equal(unit6(v.tolist(), "beta_x"), want)  # the general path
    for k in range(6):
        for bad in (np.nan, np.inf, -np.inf):
            v = np.ones(6)
            v[k] = bad
            with pytest.raises(InputError):
                unit6(v, "beta_x")
    with pytest.raises(InputError):
        unit6(np.zeros(6), "beta_x")
