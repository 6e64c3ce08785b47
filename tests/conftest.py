"""Shared fixtures (the helpers they use live in helpers.py)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from hypothesis import settings

from helpers import random_chain_urdf, scenario_text

# CI runs the property-based tests on a fixed sequence of examples (reproducible); local runs explore anew.
settings.register_profile("ci", derandomize=True)
if os.environ.get("CI"):
    settings.load_profile("ci")


@pytest.fixture
def chain_urdf() -> str:
    """A 9-joint random chain braced on link 5 (n1 = 5 is not 6 on purpose)."""
    return random_chain_urdf(9, seed=3, brace_link=5)


# --- helpers of the core-model tests (test_robot, test_kinematics, test_compliance, test_objective) ---
@pytest.fixture
def short_scenario_file(tmp_path: Path) -> Path:
    """The paper scenario cut to its first 2 s (a tenth of the circle, 20 steps of 0.1 s per strategy)."""
    path = tmp_path / "short.toml"
    path.write_text(scenario_text(turns=0.1, dt=0.1), encoding="utf-8")
    return path
