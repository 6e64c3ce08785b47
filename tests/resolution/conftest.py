"""Fixtures of the resolution tests (a test module's own fixture of the same name is the one its tests use)."""

from __future__ import annotations

import numpy as np
import pytest

from bracekit import load_scenario


@pytest.fixture(scope="module")
def paper():
    """The paper's scenario and 12 configurations near its start guess (the fused-step tests)."""
    sc = load_scenario("paper")
    rng = np.random.default_rng(11)
    qs = sc.guess + rng.normal(scale=0.3, size=(12, sc.robot.n))
    return sc, qs
