"""Tests of the deepest point of a polytope piece in the post's solid (bracekit.geometry._depth) and in a further
obstacle (bracekit.geometry.inside).

References: the post's and the obstacles' signed distances written out (geometry_refs, here) at a dense sampling
of the piece (a grid of convex combinations of its corners): every sample is a point of the piece, so the least
value is never above the sampled least and is within the sampling pitch below it; SciPy's SLSQP on the
epigraph of the same problem (geometry_refs.deepest_in_solid); central differences of the value under
translations of the piece for its gradient.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy.optimize import linprog
from scipy.spatial.transform import Rotation

from bracekit.geometry._depth import deepest_in
from bracekit.geometry.inside import deepest_inside
from bracekit.geometry.obstacles import box_obstacle, cylinder_obstacle, mesh_obstacle, sphere_obstacle
from geometry_refs import deepest_in_solid, solid_distance

#: The post's radius (m), its top the plane z = 0 about the origin.
R = 0.12
C, N = np.zeros(3), np.array([0.0, 0.0, 1.0])


def _f(points: np.ndarray) -> np.ndarray:
    return solid_distance(np.atleast_2d(points), C, N, R)


def _in_hull(vertices: np.ndarray, point: np.ndarray) -> bool:
    """Whether `point` is a convex combination of `vertices` (a linear program), to 1e-9 m."""
    k = len(vertices)
    eq = np.vstack([vertices.T, np.ones(k)])
    res = linprog(np.zeros(k), A_eq=eq, b_eq=np.append(point, 1.0), bounds=[(0.0, None)] * k)
    if res.status == 0:
        return True
    slack = linprog(  # the least max-norm miss, in case of rounding
        np.append(np.zeros(k), 1.0),
        A_ub=np.block([[eq[:3], -np.ones((3, 1))], [-eq[:3], -np.ones((3, 1))]]),
        b_ub=np.concatenate([point, -point]),
        A_eq=np.append(np.ones(k), 0.0)[None],
        b_eq=[1.0],
        bounds=[(0.0, None)] * (k + 1),
    )
    return bool(slack.status == 0 and slack.fun < 1e-9)


def _dense(vertices: np.ndarray, divisions: int) -> np.ndarray:
    """Points of the hull of `vertices`: every combination of its corners with weights on a grid of 1/divisions."""
    k = len(vertices)
    rows = [c for c in itertools.product(range(divisions + 1), repeat=k - 1) if sum(c) <= divisions]
    weights = np.array([[*c, divisions - sum(c)] for c in rows], dtype=float) / divisions
    return weights @ vertices


def _pitch(vertices: np.ndarray, divisions: int) -> float:
    """How far a point of the hull can be from the grid of :func:`_dense` (the longest edge over the divisions)."""
    return float(max(np.linalg.norm(a - b) for a, b in itertools.combinations(vertices, 2))) / divisions


def _prism() -> np.ndarray:
    """A triangular prism 2 cm thick (along y) laid across the rim edge at x = R: deepest between its corners.

    Its cross-section (x, z): A = (R − 5 cm, −1 cm) inside the side and 1 cm under the top, B = (R + 1 cm,
    −6 cm) outside the side, C = (R + 1 cm, −1 cm). Its deepest corner is 1 cm deep; along A–B, where
    −5 cm + 6 cm·t = −1 cm − 5 cm·t (t = 4/11), it is 1 cm + 5 cm · 4/11 = 2.818 cm deep (at y = 0, ρ = x).
    """
    section = [(R - 0.05, -0.01), (R + 0.01, -0.06), (R + 0.01, -0.01)]
    return np.array([[x, y, z] for y in (-0.01, 0.01) for x, z in section])


#: The prism's deepest point's signed distance (m), worked out in :func:`_prism`.
PRISM = -0.01 - 0.05 * 4.0 / 11.0


def _crossing(rng: np.random.Generator) -> np.ndarray:
    """A random polytope (3 to 12 corners, 1–4 cm across) about a point near the rim, reaching into the post."""
    while True:
        angle = rng.uniform(0.0, 2.0 * np.pi)
        rho = rng.uniform(R - 0.03, R + 0.02)
        centre = np.array([rho * np.cos(angle), rho * np.sin(angle), rng.uniform(-0.03, 0.01)])
        v = centre + rng.normal(size=(int(rng.integers(3, 13)), 3)) * rng.uniform(0.005, 0.02)
        if deepest_in_solid(v, C, N, R, starts=1) < 0.0:
            return v


@pytest.mark.parametrize("seed", range(4))
def test_random_pieces_reaching_into_the_post_against_slsqp_and_a_dense_sampling(seed: int) -> None:
    rng = np.random.default_rng(seed)
    for _ in range(10):
        v = _crossing(rng)
        corners = _f(v)
        value, point, _ = deepest_in(v, R, float(corners.min()))
        assert value == pytest.approx(deepest_in_solid(v, C, N, R, starts=4, seed=seed), abs=1e-8)
        assert value <= corners.min() + 1e-15
        assert _f(point)[0] == pytest.approx(value, abs=1e-12) and _in_hull(v, point)
        if len(v) <= 6:  # a grid of combinations of every corner
            samples = _f(_dense(v, 12 if len(v) <= 5 else 8))
            assert samples.min() - _pitch(v, 12 if len(v) <= 5 else 8) <= value <= samples.min() + 1e-12


def test_a_piece_wholly_inside_is_deepest_at_the_axis_not_at_a_corner() -> None:
    """A slab across the post 5 cm under its top: corners 1 cm inside the side, its middle 5 cm below the top."""
    v = np.array([[x, y, z] for x in (-0.11, 0.11) for y in (-0.01, 0.01) for z in (-0.05, -0.06)])
    value, point, slope = deepest_in(v, R, float(_f(v).min()))
    assert _f(v).min() == pytest.approx(np.hypot(0.11, 0.01) - R)
    assert value == pytest.approx(-0.06, abs=1e-12)  # under the top by its lowest face, inside the side by 12 cm
    np.testing.assert_allclose(slope, [0.0, 0.0, 1.0], atol=1e-12)
    assert _in_hull(v, point)


def test_a_piece_crossing_the_axis_deeper_than_the_radius_is_flat() -> None:
    """Below the top by more than r_max on the axis, f = max(h, ρ − r_max) is −r_max: no motion changes f*."""
    v = np.array([[x, y, z] for x in (-0.02, 0.03) for y in (-0.01, 0.02) for z in (-R - 0.2, -R - 0.05)])
    value, _, slope = deepest_in(v, R, float(_f(v).min()))
    assert value == pytest.approx(-R, abs=1e-12)
    step = 1e-6
    fd = [(deepest_in(v + step * a, R, 0.0)[0] - deepest_in(v - step * a, R, 0.0)[0]) / (2 * step) for a in np.eye(3)]
    np.testing.assert_allclose(fd, 0.0, atol=1e-9)
    np.testing.assert_allclose(slope, fd, atol=1e-9)


def test_the_gradient_is_the_value_s_change_under_a_translation() -> None:
    rng = np.random.default_rng(5)
    checked = 0
    for v in [_prism(), *(_crossing(rng) for _ in range(8))]:
        slope = deepest_in(v, R, float(_f(v).min()))[2]
        step = 1e-6
        fd = []
        for axis in np.eye(3):
            up, down = v + step * axis, v - step * axis
            fd.append((deepest_in(up, R, 0.0)[0] - deepest_in(down, R, 0.0)[0]) / (2.0 * step))
        np.testing.assert_allclose(slope, fd, atol=1e-5)
        checked += abs(slope[2]) not in (0.0, 1.0)  # the kink: both the top and the side count
    assert checked >= 1


def _pose(rng: np.random.Generator) -> np.ndarray:
    pose = np.eye(4)
    pose[:3, :3] = Rotation.random(random_state=rng).as_matrix()
    pose[:3, 3] = rng.uniform(-0.5, 0.5, 3)
    return pose


def _signed(kind: str, points: np.ndarray, pose: np.ndarray) -> np.ndarray:
    """The obstacles' signed distances written out (half edges 0.05, 0.04, 0.06; radius 0.05, length 0.12)."""
    local = (np.atleast_2d(points) - pose[:3, 3]) @ pose[:3, :3]
    if kind == "sphere":
        return np.linalg.norm(local, axis=1) - 0.05
    if kind == "cylinder":
        d = np.column_stack([np.hypot(local[:, 0], local[:, 1]) - 0.05, np.abs(local[:, 2]) - 0.06])
    else:  # the box, and the mesh of its corners
        d = np.abs(local) - np.array([0.05, 0.04, 0.06])
    return np.linalg.norm(np.maximum(d, 0.0), axis=1) + np.minimum(d.max(axis=1), 0.0)


def _obstacle(kind: str, pose: np.ndarray):
    half = np.array([0.05, 0.04, 0.06])
    if kind == "box":
        return box_obstacle("box", 2.0 * half, pose)
    if kind == "mesh":
        return mesh_obstacle(
            "mesh", np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * half, pose
        )
    if kind == "cylinder":
        return cylinder_obstacle("cylinder", 0.05, 0.12, pose)
    return sphere_obstacle("sphere", 0.05, pose)


@pytest.mark.parametrize("kind", ["box", "mesh", "cylinder", "sphere"])
def test_a_piece_inside_a_further_obstacle_against_a_dense_sampling(kind: str) -> None:
    """Random tetrahedra about points near the obstacle's surface: the deepest point of each in the obstacle."""
    rng = np.random.default_rng(["box", "mesh", "cylinder", "sphere"].index(kind))
    pose = _pose(rng)
    obstacle = _obstacle(kind, pose)
    checked = 0
    while checked < 8:
        direction = rng.normal(size=3)
        centre = pose[:3, :3] @ (0.055 * direction / np.linalg.norm(direction)) + pose[:3, 3]
        v = centre + rng.normal(size=(4, 3)) * 0.015
        samples = _signed(kind, _dense(v, 16), pose)
        if samples.min() > -1e-3:
            continue
        checked += 1
        found = deepest_inside(obstacle, v)
        assert found is not None
        value, point, slope = found
        assert samples.min() - _pitch(v, 16) <= value <= samples.min() + 1e-9  # a point of the piece
        assert _signed(kind, point, pose)[0] == pytest.approx(value, abs=1e-9) and _in_hull(v, point)
        step = 1e-6
        fd = [
            (deepest_inside(obstacle, v + step * e)[0] - deepest_inside(obstacle, v - step * e)[0]) / (2 * step)
            for e in np.eye(3)
        ]
        np.testing.assert_allclose(slope, fd, atol=1e-5)
    assert deepest_inside(obstacle, pose[:3, 3] + np.array([[1.0, 0, 0], [1.1, 0, 0], [1.0, 0.1, 0]])) is None
