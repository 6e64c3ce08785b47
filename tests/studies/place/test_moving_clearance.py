"""The moving surface's clearance on capsules: ∂c/∂b from the translated Jacobians against central differences.

Reference: each link's clearance evaluated with the surface put through b ± h (no gradient asked: the
clearance rule's values alone), and the q-gradient of the fixed surface's :class:`Clearance`.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from bracekit.kinematics.clearance import Clearance
from bracekit.studies.place.clearance import MovingClearance

H = 1e-6


def test_surface_point_derivative_matches_central_differences(setup: dict[str, Any]) -> None:
    braced = setup["scenario"].braced
    moving = MovingClearance(braced)
    assert moving.mesh is None and moving.extra is None  # capsules: the analytic path
    rng = np.random.default_rng(11)
    checked = 0
    for _ in range(12):
        q = setup["q"] + 0.25 * rng.standard_normal(setup["q"].size)
        b = braced.state(q).contacts[0].b + 0.02 * rng.standard_normal(3)
        values, dq, db = moving.rows(q, b)
        assert values == pytest.approx(moving.values(q, b), abs=1e-12)
        fd = np.column_stack([(moving.values(q, b + H * e) - moving.values(q, b - H * e)) / (2 * H) for e in np.eye(3)])
        assert db == pytest.approx(fd, abs=1e-6)
        checked += int(np.abs(db).max() > 0.1)  # the surface's motion matters somewhere
        # (∂c/∂q)_b: the fixed surface's own gradient (its plane through b at the scenario's start)
        fixed = Clearance(braced)
        fixed._point = b
        want = np.array([d.gradient for d in fixed.links(q, gradient=True)])
        assert dq == pytest.approx(want, abs=1e-12)
    assert checked >= 6
