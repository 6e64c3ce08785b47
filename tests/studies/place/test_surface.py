"""The capsule parameterisation against pad_on_surface's ray cast on the tessellated capsule."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from bracekit.geometry.pad import pad_on_surface


def test_point_and_normal_match_the_ray_cast(setup: dict[str, Any]) -> None:
    surface, robot = setup["surface"], setup["scenario"].robot
    for s, deg in [(0.2, 0.0), (0.5, 90.0), (0.8, 200.0), (0.35, -45.0)]:
        pad = pad_on_surface(robot, surface.link, s, deg)
        # the tessellation's polygon lies within r(1 − cos(π/m)) of the circle: a few tenths of a millimetre
        assert np.linalg.norm(pad.point - surface.point(s, math.radians(deg))) < 2e-3
        assert surface.normal(s, math.radians(deg)) @ pad.axis > 0.98


def test_derivatives_against_central_differences(setup: dict[str, Any]) -> None:
    surface, h = setup["surface"], 1e-6
    for phi in (0.0, 1.3, -2.7):
        dp = surface.point_derivative(0.4, phi)
        dn = surface.normal_derivative(0.4, phi)
        assert np.allclose((surface.point(0.4 + h, phi) - surface.point(0.4 - h, phi)) / (2 * h), dp[:, 0])
        assert np.allclose((surface.point(0.4, phi + h) - surface.point(0.4, phi - h)) / (2 * h), dp[:, 1])
        assert np.allclose((surface.normal(0.4, phi + h) - surface.normal(0.4, phi - h)) / (2 * h), dn[:, 1])
        assert np.allclose(dn[:, 0], 0.0)
