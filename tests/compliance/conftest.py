"""Fixtures of the compliance tests."""

from __future__ import annotations

import numpy as np
import pytest

from bracekit import load_scenario


@pytest.fixture(scope="module")
def paper():
    """The paper's scenario and 60 configurations drawn uniformly within its joint limits (the batch tests)."""
    sc = load_scenario("paper")
    rng = np.random.default_rng(7)
    Q = rng.uniform(sc.robot.lower, sc.robot.upper, size=(60, sc.robot.n))
    return sc, Q
