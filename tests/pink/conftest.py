"""Fixtures of the bracekit.pink tests: started scenarios, pink configurations, central differences."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

from bracekit.simulation.scenario import load_scenario
from bracekit.simulation.simulate import solve_start


@pytest.fixture(scope="session")
def panda() -> Any:
    """The shipped panda scenario and its start configuration (one brace)."""
    sc = load_scenario("panda")
    q = solve_start(sc.braced, sc.task.position(0.0), sc.guess, rotation=sc.task.rotation).q
    return sc, q


@pytest.fixture(scope="session")
def two() -> Any:
    """The shipped two-braces scenario and its start configuration."""
    sc = load_scenario("two-braces")
    q = solve_start(sc.braced, sc.task.position(0.0), sc.guess, rotation=sc.task.rotation).q
    return sc, q


@pytest.fixture
def config() -> Callable[[Any, np.ndarray], Any]:
    """Pink's Configuration of a scenario's robot at q."""
    pink = pytest.importorskip("pink")

    def make(sc: Any, q: np.ndarray) -> Any:
        model = sc.braced.robot.model
        return pink.Configuration(model, model.createData(), q)

    return make


@pytest.fixture
def fd() -> Callable[..., np.ndarray]:
    """Central differences (columns per joint) of a vector function of q, step h (rad)."""

    def diff(fn: Callable[[np.ndarray], np.ndarray], q: np.ndarray, h: float = 1e-6) -> np.ndarray:
        cols = []
        for i in range(q.size):
            dq = np.zeros(q.size)
            dq[i] = h
            cols.append((fn(q + dq) - fn(q - dq)) / (2 * h))
        return np.array(cols).T

    return diff
