"""The joint-limit barrier: value, exact gradient against central differences, the barrier at a limit, key."""

from __future__ import annotations

import numpy as np
import pytest

from bracekit import load_scenario
from bracekit.errors import BarrierError
from bracekit.objective import TERMS, JointLimitBarrier, finite_difference_gradient


def test_value_is_zero_at_the_middles_and_grows_without_bound_at_a_limit() -> None:
    term = JointLimitBarrier(np.array([-1.0, 0.0, -np.inf]), np.array([1.0, 2.0, np.inf]))
    assert term.of_q(np.array([0.0, 1.0, 55.0])) == 0.0  # the unbounded joint does not count
    # span² / (4 (q_max − q)(q − q_min)) − 1 at q = 0.5 on (−1, 1): 4 / (4 · 0.5 · 1.5) − 1 = 1/3
    assert term.of_q(np.array([0.5, 1.0, 0.0])) == pytest.approx(1.0 / 3.0)
    near = [term.of_q(np.array([1.0 - eps, 1.0, 0.0])) for eps in (1e-1, 1e-3, 1e-6)]
    assert near[0] < near[1] < near[2] and near[2] > 1e5
    with pytest.raises(BarrierError, match="joint 2"):
        term.of_q(np.array([0.0, 2.0, 0.0]))


def test_gradient_equals_central_differences_on_the_paper_robot() -> None:
    sc = load_scenario("paper")
    term = JointLimitBarrier(sc.robot.lower, sc.robot.upper)
    rng = np.random.default_rng(8)
    for _ in range(4):
        q = np.clip(sc.guess + rng.normal(scale=0.4, size=sc.robot.n), sc.robot.lower + 0.05, sc.robot.upper - 0.05)
        fd = finite_difference_gradient(sc.braced, term.value, q)
        assert np.allclose(term.gradient(sc.braced.state(q)), fd, rtol=1e-6, atol=1e-8)


def test_scenario_key_is_registered_and_off_by_default() -> None:
    assert TERMS["joint_limit_barrier"] is JointLimitBarrier
    sc = load_scenario("paper")
    assert sc.weights["joint_limit_barrier"] == 0.0
    assert "joint_limit_barrier" not in sc.objective().names
