"""The preloaded (second-order) compliance against the nonlinear static equilibrium it linearises."""

from __future__ import annotations

import numpy as np
import pytest

from bracekit.compliance import end_effector_compliance, preloaded_compliance
from bracekit.errors import InputError
from bracekit.simulation import Scenario, load_scenario, solve_start
from bracekit.validate.statics import solve_static_equilibrium


@pytest.fixture(scope="module")
def paper_start() -> tuple[Scenario, np.ndarray]:
    sc = load_scenario("paper")
    return sc, solve_start(sc.braced, sc.task.position(0.0), sc.guess).q


def test_preloaded_compliance_without_preload_is_the_constrained_model(paper_start) -> None:
    sc, q = paper_start
    c0 = preloaded_compliance(sc.braced, q, 0.0)
    np.testing.assert_allclose(c0, end_effector_compliance(sc.braced.state(q), "constrained"), rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("preload", [1.0, 20.0, 50.0])
def test_preloaded_compliance_is_the_derivative_of_the_nonlinear_static_solve(paper_start, preload: float) -> None:
    """Central differences of the preloaded equilibrium (bilateral contact) under ±1 mN tip wrenches."""
    sc, q = paper_start
    braced, robot, surface = sc.braced, sc.robot, sc.braced.brace.surface
    args = (robot.model, q, robot.stiffness, braced.brace_id, robot.tip_id, surface.point, surface.normal)
    h = 1e-3
    fd = np.empty((6, 6))
    for j in range(6):
        w = np.zeros(6)
        w[j] = h
        plus = solve_static_equilibrium(*args, w, bilateral=True, preload=preload).deflection
        minus = solve_static_equilibrium(*args, -w, bilateral=True, preload=preload).deflection
        fd[:, j] = (plus - minus) / (2.0 * h)
    c = preloaded_compliance(braced, q, preload)
    np.testing.assert_allclose(c, fd, rtol=0, atol=1e-7 * np.max(np.abs(fd)))
    first = end_effector_compliance(braced.state(q), "constrained")
    assert np.max(np.abs(first - fd)) > 100 * np.max(np.abs(c - fd))  # the preload term matters here


@pytest.mark.parametrize("preload", [-1.0, np.nan, "1", True])
def test_bad_preload_is_an_input_error(paper_start, preload) -> None:
    sc, q = paper_start
    with pytest.raises(InputError, match="preload"):
        preloaded_compliance(sc.braced, q, preload)
