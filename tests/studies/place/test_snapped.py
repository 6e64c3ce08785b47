"""The snapped surface (the Panda's collision capsules, tessellated) against pad_on_surface and central differences.

pad_on_surface (:mod:`bracekit.geometry.pad`) is the independent reference of the point and the pad axis; the
derivatives are checked where the ray stays on one triangle over the difference step (the parameterisation is
piecewise smooth), and through the inner problem's objective gradient on the Panda.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from bracekit.geometry.pad import _well_inside, pad_on_surface
from bracekit.model.robot import Robot
from bracekit.studies.place.inner import InnerSettings, StartProblem
from bracekit.studies.place.snapped import SnappedSurface
from bracekit.studies.place.spec import load_place_spec
from bracekit.studies.place.surface import link_surface
from bracekit.studies.sweep.context import context_scenario, reference_start

H = 1e-7


@pytest.fixture(scope="module")
def robot() -> Robot:
    return load_place_spec("panda").base_scenario().robot


@pytest.mark.parametrize("link", ["panda_link2", "panda_link3", "panda_link4", "panda_link6"])
def test_point_and_axis_match_pad_on_surface(robot: Robot, link: str) -> None:
    surface = link_surface(robot, link, "collision")
    assert isinstance(surface, SnappedSurface)
    lo, hi = surface.fraction_bounds((0.02, 0.98))
    compared = 0
    for f, deg in [(0.1, 0.0), (0.3, 90.0), (0.7, 200.0), (0.9, -45.0)]:
        s = lo + f * (hi - lo)
        point = surface.point(s, math.radians(deg))
        # on the link's surface: a point of one of its triangles (barycentric coordinates in [0, 1])
        assert _on_triangles(surface.triangles, point)
        if not _well_inside(surface.triangles, surface.centre(s)):
            continue  # pad_on_surface casts from the cross-section's centroid there, not from the smooth line
        pad = pad_on_surface(robot, link, s, deg)
        assert np.allclose(point, pad.point, atol=1e-12)
        # the interpolated normal against the facet's: within the tessellation's angle
        assert surface.normal(s, math.radians(deg)) @ pad.axis > math.cos(math.radians(15.0))
        compared += 1
    assert compared >= 2


def _on_triangles(tri: np.ndarray, p: np.ndarray, tol: float = 1e-9) -> bool:
    """Whether p lies on one of the triangles (t, 3, 3): in its plane and inside its edges."""
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    n = np.cross(b - a, c - a)
    area2 = np.einsum("ij,ij->i", n, n)
    ok = area2 > 0.0
    dist = np.abs(np.einsum("ij,ij->i", p - a, n)) / np.sqrt(np.where(ok, area2, 1.0))
    u = np.einsum("ij,ij->i", np.cross(c - b, p - b), n) / np.where(ok, area2, 1.0)
    v = np.einsum("ij,ij->i", np.cross(a - c, p - c), n) / np.where(ok, area2, 1.0)
    w = 1.0 - u - v
    return bool(np.any(ok & (dist < tol) & (u > -tol) & (v > -tol) & (w > -tol)))


def _same_face(surface: SnappedSurface, s: float, phi: float) -> bool:
    n0 = surface.normal(s, phi)
    return all(
        np.allclose(surface.normal(s + a, phi + b), n0, atol=1e-12)
        for a, b in ((H, 0.0), (-H, 0.0), (0.0, H), (0.0, -H))
    )


@pytest.mark.parametrize("link", ["panda_link3", "panda_link4"])
def test_derivatives_against_central_differences(robot: Robot, link: str) -> None:
    surface = link_surface(robot, link, "collision")
    assert isinstance(surface, SnappedSurface)
    rng = np.random.default_rng(3)
    checked = 0
    lo, hi = surface.fraction_bounds((0.02, 0.98))
    for s, phi in zip(rng.uniform(lo, hi, 20), rng.uniform(-math.pi, math.pi, 20), strict=True):
        if not _same_face(surface, s, phi):
            continue
        dp = surface.point_derivative(s, phi)
        fd_s = (surface.point(s + H, phi) - surface.point(s - H, phi)) / (2 * H)
        fd_phi = (surface.point(s, phi + H) - surface.point(s, phi - H)) / (2 * H)
        assert np.allclose(dp[:, 0], fd_s, atol=1e-6) and np.allclose(dp[:, 1], fd_phi, atol=1e-6)
        dn = surface.normal_derivative(s, phi)
        fd_n = [
            (surface.normal(s + a, phi + b) - surface.normal(s - a, phi - b)) / (2 * H) for a, b in ((H, 0), (0, H))
        ]
        assert np.allclose(dn, np.column_stack(fd_n), atol=1e-5)
        checked += 1
    assert checked >= 10


def test_inner_gradient_on_the_panda() -> None:
    spec = load_place_spec("panda-links")
    q = reference_start(context_scenario(spec, {}))
    problem = StartProblem(spec, "panda_link4", q, InnerSettings(surface="collision"))
    rng = np.random.default_rng(7)
    surface = problem.surface
    assert isinstance(surface, SnappedSurface)
    for _ in range(20):  # a place whose ray stays on one triangle over the step
        lo, hi = surface.fraction_bounds((0.02, 0.98))
        s, phi = float(rng.uniform(lo, hi)), float(rng.uniform(-math.pi, math.pi))
        if _same_face(surface, s, phi):
            break
    x = np.concatenate([q + 0.02 * rng.standard_normal(q.size), [s, phi]])
    _, grad = problem.objective(x)
    fd = np.array(
        [(problem.objective(x + H * e)[0] - problem.objective(x - H * e)[0]) / (2 * H) for e in np.eye(x.size)]
    )
    assert np.allclose(grad, fd, rtol=1e-4, atol=1e-5)
