"""bracekit.pink's barriers against central differences and a brute-force lateral distance."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

pink = pytest.importorskip("pink")

from bracekit.errors import InputError  # noqa: E402
from bracekit.kinematics import BracedRobot  # noqa: E402
from bracekit.pink import BraceRegionBarrier, LinkClearanceBarrier  # noqa: E402
from bracekit.simulation.scenario import load_scenario  # noqa: E402
from bracekit.simulation.simulate import solve_start  # noqa: E402


@pytest.fixture(scope="module")
def panda() -> Any:
    sc = load_scenario("panda")
    q = solve_start(sc.braced, sc.task.position(0.0), sc.guess, rotation=sc.task.rotation).q
    return sc, q


def _config(sc: Any, q: np.ndarray) -> Any:
    model = sc.braced.robot.model
    return pink.Configuration(model, model.createData(), q)


def _fd(fn: Any, q: np.ndarray, h: float = 1e-6) -> np.ndarray:
    cols = []
    for i in range(q.size):
        dq = np.zeros(q.size)
        dq[i] = h
        cols.append((fn(q + dq) - fn(q - dq)) / (2 * h))
    return np.array(cols).T


def test_the_region_barrier_is_r_max_squared_minus_r_squared(panda: Any) -> None:
    sc, q = panda
    barrier = BraceRegionBarrier(sc.braced)
    brace = sc.braced.brace
    b = sc.braced.state(q).b
    r = np.linalg.norm((b - brace.surface.point)[:2])  # the post's top is horizontal: lateral = x, y
    assert barrier.compute_barrier(_config(sc, q)) == pytest.approx([brace.region_radius**2 - r**2], abs=1e-12)
    fd = _fd(lambda x: barrier.compute_barrier(_config(sc, x)), q)
    assert np.max(np.abs(barrier.compute_jacobian(_config(sc, q)) - fd)) < 1e-8


def test_the_clearance_barrier_gradient_is_the_derivative_of_the_clearance(panda: Any) -> None:
    sc, q = panda
    barrier = LinkClearanceBarrier(sc.braced, _config(sc, q), clearance_min=0.01)
    h = barrier.compute_barrier(_config(sc, q))
    assert h.shape == (len(barrier.names),) and np.all(h > -0.01)
    fd = _fd(lambda x: barrier.compute_barrier(_config(sc, x)), q)
    assert np.max(np.abs(barrier.compute_jacobian(_config(sc, q)) - fd)) < 1e-6


def test_a_region_barrier_needs_a_region(panda: Any) -> None:
    sc, _ = panda
    import dataclasses

    braced = BracedRobot(sc.braced.robot, dataclasses.replace(sc.braced.brace, region_radius=None, surface_radius=None))
    with pytest.raises(InputError, match="region_radius"):
        BraceRegionBarrier(braced)
