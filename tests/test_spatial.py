"""Tests of bracekit.spatial: skew matrices and the twist/wrench maps of eq:twists.

References are hand-written rigid-body formulas (np.cross, explicit block algebra), never the functions
under test.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from bracekit.errors import InputError
from bracekit.spatial import rotation_with_z, skew, twist_rotate, twist_shift, unit, wrench_map

FINITE = st.floats(-10.0, 10.0, allow_nan=False, allow_infinity=False)
VEC3 = arrays(np.float64, 3, elements=FINITE)
VEC6 = arrays(np.float64, 6, elements=FINITE)
SETTINGS = settings(max_examples=40, deadline=None)


def rotation(r: np.ndarray) -> np.ndarray:
    """A rotation matrix from a rotation vector (Rodrigues, via pinocchio's exp3)."""
    return np.asarray(pin.exp3(np.asarray(r, dtype=float)))


@SETTINGS
@given(a=VEC3, x=VEC3)
def test_skew_times_vector_equals_cross_product(a: np.ndarray, x: np.ndarray) -> None:
    np.testing.assert_allclose(skew(a) @ x, np.cross(a, x), atol=1e-12)


def test_skew_matches_eq_skew_sym_entries_and_is_antisymmetric() -> None:
    a1, a2, a3 = 1.5, -2.0, 0.25
    expected = np.array([[0.0, -a3, a2], [a3, 0.0, -a1], [-a2, a1, 0.0]])
    s = skew([a1, a2, a3])
    np.testing.assert_array_equal(s, expected)
    np.testing.assert_array_equal(s.T, -s)
    assert s.shape == (3, 3)


def test_skew_rejects_a_vector_of_the_wrong_size() -> None:
    with pytest.raises(ValueError):
        skew([1.0, 2.0])


@SETTINGS
@given(b=VEC3, e=VEC3, twist=VEC6)
def test_twist_shift_moves_the_reference_point_from_b_to_e(b: np.ndarray, e: np.ndarray, twist: np.ndarray) -> None:
    v_b, omega = twist[:3], twist[3:]
    v_e = v_b + np.cross(omega, e - b)  # rigid-body velocity field, by hand
    np.testing.assert_allclose(twist_shift(b, e) @ twist, np.concatenate([v_e, omega]), atol=1e-10)


def test_twist_shift_agrees_with_a_rigid_body_moved_by_finite_differences() -> None:
    # A body turning with ω about an axis through c and translating with v: point p moves with v + ω × (p − c).
    rng = np.random.default_rng(4)
    c, v, omega = rng.normal(size=3), rng.normal(size=3), rng.normal(size=3)
    b, e = rng.normal(size=3), rng.normal(size=3)
    h = 1e-6

    def moved(p: np.ndarray, t: float) -> np.ndarray:
        return c + rotation(omega * t) @ (p - c) + v * t

    vel_b = (moved(b, h) - moved(b, -h)) / (2 * h)
    vel_e = (moved(e, h) - moved(e, -h)) / (2 * h)
    out = twist_shift(b, e) @ np.concatenate([vel_b, omega])
    np.testing.assert_allclose(out[:3], vel_e, atol=1e-8)
    np.testing.assert_allclose(out[3:], omega, atol=0)


def test_twist_shift_has_the_block_structure_of_eq_twists() -> None:
    b, e = np.array([0.1, 0.2, 0.3]), np.array([-0.4, 0.5, 1.0])
    s = twist_shift(b, e)
    np.testing.assert_array_equal(s[:3, :3], np.eye(3))
    np.testing.assert_array_equal(s[3:, 3:], np.eye(3))
    np.testing.assert_array_equal(s[3:, :3], np.zeros((3, 3)))
    d = b - e
    np.testing.assert_allclose(s[:3, 3:], [[0, -d[2], d[1]], [d[2], 0, -d[0]], [-d[1], d[0], 0]], atol=1e-15)


@SETTINGS
@given(r=VEC3, twist=VEC6)
def test_twist_rotate_reexpresses_both_parts_in_world_axes(r: np.ndarray, twist: np.ndarray) -> None:
    R = rotation(r)
    expected = np.concatenate([R @ twist[:3], R @ twist[3:]])
    np.testing.assert_allclose(twist_rotate(R) @ twist, expected, atol=1e-10)


def test_twist_rotate_of_a_quarter_turn_about_z_maps_x_to_y() -> None:
    R = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    out = twist_rotate(R) @ np.array([1.0, 0.0, 0.0, 0.0, 0.0, 2.0])
    np.testing.assert_allclose(out, [0.0, 1.0, 0.0, 0.0, 0.0, 2.0], atol=1e-15)


@SETTINGS
@given(b=VEC3, e=VEC3, twist=VEC6, wrench=VEC6)
def test_wrench_map_of_twist_shift_preserves_power(
    b: np.ndarray, e: np.ndarray, twist: np.ndarray, wrench: np.ndarray
) -> None:
    # Twist t_b at b maps to t_e = S_t t_b; the wrench w_e at e maps to w_b = S_w w_e. Power is frame-free.
    s_t = twist_shift(b, e)
    t_e = s_t @ twist
    w_b = wrench_map(s_t) @ wrench
    scale = 1.0 + np.linalg.norm(twist) * np.linalg.norm(wrench) * (1.0 + np.linalg.norm(b - e))
    assert abs(w_b @ twist - wrench @ t_e) <= 1e-10 * scale


@SETTINGS
@given(b=VEC3, e=VEC3, wrench=VEC6)
def test_wrench_map_of_twist_shift_transfers_the_moment_by_hand(
    b: np.ndarray, e: np.ndarray, wrench: np.ndarray
) -> None:
    # A force f with moment m at e is, at b, the force f with moment m + (e − b) × f (paper's S_w1).
    f, m = wrench[:3], wrench[3:]
    expected = np.concatenate([f, m + np.cross(e - b, f)])
    np.testing.assert_allclose(wrench_map(twist_shift(b, e)) @ wrench, expected, atol=1e-9)


@SETTINGS
@given(r=VEC3, twist=VEC6, wrench=VEC6)
def test_wrench_map_of_twist_rotate_expresses_a_world_wrench_in_body_axes(
    r: np.ndarray, twist: np.ndarray, wrench: np.ndarray
) -> None:
    R = rotation(r)
    s_w = wrench_map(twist_rotate(R))
    np.testing.assert_allclose(s_w @ wrench, np.concatenate([R.T @ wrench[:3], R.T @ wrench[3:]]), atol=1e-10)
    # power: body-axes twist · body-axes wrench == world twist · world wrench
    assert abs((s_w @ wrench) @ twist - wrench @ (twist_rotate(R) @ twist)) < 1e-9 * (1 + np.abs(twist).sum()) * (
        1 + np.abs(wrench).sum()
    )


def test_wrench_map_returns_a_copy_not_a_view() -> None:
    s = twist_shift([0.0, 0.0, 0.0], [1.0, 2.0, 3.0])
    w = wrench_map(s)
    w[0, 0] = 99.0
    assert s[0, 0] == 1.0


def test_unit_normalises_a_vector() -> None:
    np.testing.assert_allclose(unit([3.0, 0.0, 4.0]), [0.6, 0.0, 0.8], atol=1e-15)
    assert unit([0.0, 0.0, 1e-6]).tolist() == [0.0, 0.0, 1.0]


@pytest.mark.parametrize(
    "bad",
    [[0.0, 0.0, 0.0], [np.nan, 1.0, 0.0], [np.inf, 0.0, 0.0], ["a", 0.0, 0.0]],
    ids=["zero", "nan", "inf", "text"],
)
def test_unit_rejects_zero_or_non_finite_vectors_naming_what(bad: list) -> None:
    with pytest.raises(InputError, match="surface normal") as info:
        unit(bad, "surface normal")
    assert "\n" not in str(info.value)


@pytest.mark.parametrize("scale", [1e-320, 1e-300, 1e-14, 1.0, 1e200, 1e300, 1e308])
def test_unit_is_exact_at_any_scale(scale: float) -> None:
    """‖v‖ of 1e300-size components overflows and of 1e-300 underflows; the unit vector must not."""
    out = unit([3.0 * scale, 0.0, -4.0 * scale] if scale < 1e300 else [scale, 0.0, -scale])
    want = np.array([0.6, 0.0, -0.8]) if scale < 1e300 else np.array([1.0, 0.0, -1.0]) / np.sqrt(2.0)
    if scale == 1e-320:  # subnormal inputs keep only a few digits
        want = np.array([3e-320, 0.0, -4e-320]) / np.linalg.norm(np.array([3.0, 0.0, -4.0])) / 1e-320
        np.testing.assert_allclose(out, want, atol=1e-3)
    else:
        np.testing.assert_allclose(out, want, rtol=0, atol=2e-16)
    assert abs(np.linalg.norm(out) - 1.0) < 1e-15


@pytest.mark.parametrize("bad", [[1.0, 2.0], "abc", None, [np.nan, 0.0, 0.0], [[1.0], [2.0, 3.0]]])
def test_skew_and_twist_shift_refuse_anything_but_3_finite_numbers(bad: object) -> None:
    with pytest.raises(InputError):
        skew(bad)  # type: ignore[arg-type]
    with pytest.raises(InputError):
        twist_shift(bad, np.zeros(3))  # type: ignore[arg-type]


def test_twist_shift_of_points_whose_difference_overflows_is_a_numerical_error() -> None:
    from bracekit.errors import NumericalError

    with pytest.raises(NumericalError):
        twist_shift(np.array([1e308, 0.0, 0.0]), np.array([-1e308, 0.0, 0.0]))


@pytest.mark.parametrize("bad", [np.eye(2), "R", None, np.full((3, 3), np.inf)])
def test_twist_rotate_and_wrench_map_refuse_wrong_shapes(bad: object) -> None:
    with pytest.raises(InputError):
        twist_rotate(bad)  # type: ignore[arg-type]
    with pytest.raises(InputError):
        wrench_map(bad)  # type: ignore[arg-type]


@settings(max_examples=60, deadline=None)
@given(arrays(np.float64, 3, elements=st.floats(-1e3, 1e3)))
def test_rotation_with_z_is_a_rotation_whose_z_is_the_axis(axis: np.ndarray) -> None:
    if not np.any(axis):
        with pytest.raises(InputError):
            rotation_with_z(axis)
        return
    r = rotation_with_z(axis)
    np.testing.assert_allclose(r.T @ r, np.eye(3), atol=1e-12)
    assert np.linalg.det(r) == pytest.approx(1.0, abs=1e-12)
    np.testing.assert_allclose(r[:, 2], unit(axis), atol=1e-12)


def test_rotation_with_z_of_plus_z_is_the_identity() -> None:
    np.testing.assert_array_equal(rotation_with_z([0.0, 0.0, 3.0]), np.eye(3))
