"""Tests of bracekit.contact: surfaces, contact types (H, X) and brace validation.

References: the printed eq:H_point built by hand from the tangent frame, Salisbury's contact models
(which forces/moments each contact transmits) written out as explicit subspaces, and linear algebra
(rank, reciprocity Hᵀ X = 0 under the power pairing [v; ω]·[f; m]).
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from bracekit.contact import (
    CONTACT_TYPES,
    FRICTIONLESS_POINT,
    POINT_WITH_FRICTION,
    SOFT_FINGER,
    Brace,
    ContactType,
    Surface,
    contact_type,
)
from bracekit.errors import ContactError, InputError

VEC3 = arrays(np.float64, 3, elements=st.floats(-5.0, 5.0, allow_nan=False, allow_infinity=False))
SETTINGS = settings(max_examples=40, deadline=None)
EXPECTED_L = {"frictionless_point": 5, "point_with_friction": 3, "soft_finger": 2}


def span_projector(m: np.ndarray) -> np.ndarray:
    """Orthogonal projector onto the column space of m."""
    u, s, _ = np.linalg.svd(m, full_matrices=False)
    u = u[:, s > 1e-10 * s[0]]
    return u @ u.T


def salisbury_wrenches(contact: str, x: np.ndarray, y: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Wrenches [f; m] a contact transmits, by Salisbury's definitions, as columns."""
    o = np.zeros(3)
    forces = [np.concatenate([d, o]) for d in (x, y, z)]
    if contact == "frictionless_point":  # normal force only
        cols = [np.concatenate([z, o])]
    elif contact == "point_with_friction":  # any force, no moment
        cols = forces
    else:  # soft finger: any force and the moment about the normal
        cols = [*forces, np.concatenate([o, z])]
    return np.array(cols).T


@pytest.mark.parametrize("contact", [FRICTIONLESS_POINT, POINT_WITH_FRICTION, SOFT_FINGER], ids=CONTACT_TYPES)
@SETTINGS
@given(normal=VEC3, tangent=VEC3)
def test_contact_bases_are_reciprocal_complete_and_unit(
    contact: ContactType, normal: np.ndarray, tangent: np.ndarray
) -> None:
    assume(np.linalg.norm(normal) > 1e-3)
    n = normal / np.linalg.norm(normal)
    assume(np.linalg.norm(tangent - n * (n @ tangent)) > 1e-3)
    surface = Surface(point=np.zeros(3), normal=normal, tangent=tangent)
    H, X = contact.H(surface.frame), contact.X(surface.frame)
    l = EXPECTED_L[contact.name]
    assert H.shape == (6, l) and X.shape == (6, 6 - l) and contact.l == l
    np.testing.assert_allclose(H.T @ X, 0.0, atol=1e-12)  # reciprocal: no power through the contact
    assert np.linalg.matrix_rank(np.hstack([H, X]), tol=1e-9) == 6
    np.testing.assert_allclose(np.linalg.norm(H, axis=0), 1.0, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(X, axis=0), 1.0, atol=1e-12)


@pytest.mark.parametrize("contact", CONTACT_TYPES)
def test_constraint_wrenches_span_salisburys_transmitted_wrenches(contact: str) -> None:
    rng = np.random.default_rng(2)
    surface = Surface(point=rng.normal(size=3), normal=rng.normal(size=3), tangent=rng.normal(size=3))
    x, y, z = surface.frame.T
    X = contact_type(contact).X(surface.frame)
    np.testing.assert_allclose(span_projector(X), span_projector(salisbury_wrenches(contact, x, y, z)), atol=1e-12)
    # H is the orthogonal complement (allowable twists do no work against any transmitted wrench)
    H = contact_type(contact).H(surface.frame)
    np.testing.assert_allclose(span_projector(H) + span_projector(X), np.eye(6), atol=1e-12)


def test_frictionless_point_H_is_eq_H_point_column_by_column() -> None:
    surface = Surface(point=[0.0, 0.0, 0.0], normal=[0.2, -0.3, 1.0], tangent=[1.0, 0.5, 0.0])
    x, y, z = surface.frame[:, 0], surface.frame[:, 1], surface.frame[:, 2]
    o = np.zeros(3)
    expected = np.column_stack(
        [
            np.concatenate([x, o]),
            np.concatenate([y, o]),
            np.concatenate([o, x]),
            np.concatenate([o, y]),
            np.concatenate([o, z]),
        ]
    )
    np.testing.assert_allclose(FRICTIONLESS_POINT.H(surface.frame), expected, atol=1e-15)
    np.testing.assert_allclose(FRICTIONLESS_POINT.X(surface.frame)[:, 0], np.concatenate([z, o]), atol=1e-15)


def test_brace_H_and_X_use_the_surface_frame_and_contact() -> None:
    surface = Surface(point=[0.0, 0.0, 0.0], normal=[0.0, 0.0, 1.0])
    brace = Brace("b", surface, contact=SOFT_FINGER)
    np.testing.assert_array_equal(brace.H(), SOFT_FINGER.H(surface.frame))
    np.testing.assert_array_equal(brace.X(), SOFT_FINGER.X(surface.frame))
    assert Brace("b", surface).contact == FRICTIONLESS_POINT


@SETTINGS
@given(normal=VEC3, tangent=VEC3)
def test_surface_frame_is_orthonormal_right_handed_with_z_the_unit_normal(
    normal: np.ndarray, tangent: np.ndarray
) -> None:
    assume(np.linalg.norm(normal) > 1e-3)
    n = normal / np.linalg.norm(normal)
    in_plane = tangent - n * (n @ tangent)
    assume(np.linalg.norm(in_plane) > 1e-3)
    for s in (Surface(point=[0, 0, 0], normal=normal, tangent=tangent), Surface(point=[0, 0, 0], normal=normal)):
        F = s.frame
        np.testing.assert_allclose(F.T @ F, np.eye(3), atol=1e-12)
        assert np.linalg.det(F) == pytest.approx(1.0, abs=1e-12)
        np.testing.assert_allclose(F[:, 2], n, atol=1e-12)
        np.testing.assert_allclose(s.normal, n, atol=1e-12)
        np.testing.assert_allclose(np.cross(F[:, 0], F[:, 1]), F[:, 2], atol=1e-12)
    # a given tangent fixes x̂_t: its projection on the plane, normalised
    s = Surface(point=[0, 0, 0], normal=normal, tangent=tangent)
    np.testing.assert_allclose(s.frame[:, 0], in_plane / np.linalg.norm(in_plane), atol=1e-9)


def test_default_tangent_works_for_a_normal_along_x() -> None:
    s = Surface(point=[0, 0, 0], normal=[-3.0, 0.0, 0.0])
    np.testing.assert_allclose(s.frame[:, 2], [-1.0, 0.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(s.frame.T @ s.frame, np.eye(3), atol=1e-15)


def test_signed_distance_is_positive_on_the_normal_side() -> None:
    s = Surface(point=[1.0, 2.0, 3.0], normal=[0.0, 0.0, 2.0])
    assert s.signed_distance([5.0, -1.0, 3.25]) == pytest.approx(0.25)
    assert s.signed_distance([0.0, 0.0, 2.0]) == pytest.approx(-1.0)


@pytest.mark.parametrize(
    "normal",
    [[0.0, 0.0, 0.0], [np.nan, 0.0, 1.0], [0.0, np.inf, 1.0], [0.0, 0.0, 1e-320], "up", None],
    ids=["zero", "nan", "inf", "subnormal-only-direction-kept", "text", "none"],
)
def test_zero_or_non_finite_normal_is_a_contact_error(normal) -> None:
    if normal == [0.0, 0.0, 1e-320]:  # a direction at any scale is a direction
        np.testing.assert_array_equal(Surface(point=[0.0, 0.0, 0.0], normal=normal).normal, [0.0, 0.0, 1.0])
        return
    with pytest.raises(ContactError) as info:
        Surface(point=[0.0, 0.0, 0.0], normal=normal)
    assert "\n" not in str(info.value)
    assert isinstance(info.value, InputError)


@pytest.mark.parametrize("tangent", [[0.0, 0.0, 2.0], [0.0, 0.0, -1.0], [0.0, 0.0, 0.0]], ids=["par", "anti", "zero"])
def test_tangent_parallel_to_the_normal_is_a_contact_error(tangent: list[float]) -> None:
    """A tangent along the normal (or zero) cannot fix x̂_t."""
    with pytest.raises(ContactError, match="parallel"):
        Surface(point=[0.0, 0.0, 0.0], normal=[0.0, 0.0, 1.0], tangent=tangent)


def test_bad_surface_point_normal_size_or_tangent_are_contact_errors() -> None:
    with pytest.raises(ContactError):
        Surface(point=[0.0, 0.0], normal=[0.0, 0.0, 1.0])
    with pytest.raises(ContactError):
        Surface(point=[0.0, np.nan, 0.0], normal=[0.0, 0.0, 1.0])
    with pytest.raises(ContactError):
        Surface(point=[0.0, 0.0, 0.0], normal=[0.0, 0.0, 1.0, 0.0])
    with pytest.raises(ContactError):
        Surface(point=[0.0, 0.0, 0.0], normal=[0.0, 0.0, 1.0], tangent=[1.0, np.nan, 0.0])


def test_unknown_contact_type_is_a_contact_error_listing_the_known_ones() -> None:
    with pytest.raises(ContactError) as info:
        contact_type("glue")
    assert all(name in str(info.value) for name in CONTACT_TYPES)


@pytest.mark.parametrize("radius", [0.0, -0.1, np.nan, np.inf])
def test_non_positive_region_radius_is_a_contact_error(radius: float) -> None:
    surface = Surface(point=[0.0, 0.0, 0.0], normal=[0.0, 0.0, 1.0])
    with pytest.raises(ContactError) as info:
        Brace("b", surface, region_radius=radius)
    assert "\n" not in str(info.value)


@pytest.mark.parametrize("k_env", [0.0, -1e5, np.nan, np.inf])
def test_non_positive_environment_stiffness_is_a_contact_error(k_env: float) -> None:
    surface = Surface(point=[0.0, 0.0, 0.0], normal=[0.0, 0.0, 1.0])
    with pytest.raises(ContactError) as info:
        Brace("b", surface, environment_stiffness=k_env)
    assert "\n" not in str(info.value)


def test_valid_brace_keeps_its_radius_and_stiffness() -> None:
    surface = Surface(point=[0.0, 0.0, 0.0], normal=[0.0, 0.0, 1.0])
    brace = Brace("b", surface, region_radius=0.2, environment_stiffness=1e6)
    assert brace.region_radius == 0.2 and brace.environment_stiffness == 1e6
    assert Brace("b", surface).environment_stiffness is None


@pytest.mark.parametrize("scale", [1e-300, 1e-15, 1.0, 1e15, 1e300])
def test_surface_normal_and_tangent_normalise_at_any_scale(scale: float) -> None:
    s = Surface(point=[0.0, 0.0, 0.0], normal=[0.0, scale, scale], tangent=[scale, 0.0, 0.0])
    np.testing.assert_allclose(s.normal, [0.0, 1.0 / np.sqrt(2.0), 1.0 / np.sqrt(2.0)], rtol=0, atol=1e-15)
    np.testing.assert_allclose(s.tangent, [1.0, 0.0, 0.0], rtol=0, atol=1e-15)
    np.testing.assert_allclose(s.frame.T @ s.frame, np.eye(3), atol=1e-15)


@pytest.mark.parametrize("p", [[0.0, 0.0], "origin", None, [np.nan, 0.0, 0.0], [[0.0, 1.0], [2.0]]])
def test_signed_distance_of_a_point_that_is_not_3_finite_numbers_is_an_input_error(p: object) -> None:
    surface = Surface(np.zeros(3), np.array([0.0, 0.0, 1.0]))
    with pytest.raises(InputError):
        surface.signed_distance(p)  # type: ignore[arg-type]


def test_a_distance_beyond_float64_is_a_numerical_error() -> None:
    from bracekit.errors import NumericalError

    surface = Surface(np.array([0.0, 0.0, -1e308]), np.array([0.0, 0.0, 1.0]))
    with pytest.raises(NumericalError):
        surface.signed_distance(np.array([0.0, 0.0, 1e308]))


@pytest.mark.parametrize(
    "kwargs",
    [
        {"point": ["0", "0", "0"]},
        {"point": [True, False, True]},
        {"normal": "up"},
        {"normal": None},
        {"tangent": [1.0, 0.0]},
        {"tangent": "x"},
    ],
)
def test_surface_arguments_that_are_not_3_numbers_are_contact_errors(kwargs: dict) -> None:
    args = {"point": np.zeros(3), "normal": np.array([0.0, 0.0, 1.0]), **kwargs}
    with pytest.raises(ContactError) as info:
        Surface(**args)
    assert "\n" not in str(info.value)


def test_brace_kind_is_the_contact_type_even_when_given_by_name() -> None:
    brace = Brace("b", Surface(np.zeros(3), np.array([0.0, 0.0, 1.0])), contact="soft_finger")
    assert brace.kind is brace.contact and brace.kind.name == "soft_finger"


def test_a_brace_has_a_pad_axis_unless_told_otherwise() -> None:
    surface = Surface((0.0, 0.0, 0.0), (0.0, 0.0, 1.0))
    assert Brace("b", surface).pad_axis and not Brace("b", surface, pad_axis=False).pad_axis
    with pytest.raises(ContactError, match="pad_axis"):
        Brace("b", surface, pad_axis=1)  # type: ignore[arg-type]
