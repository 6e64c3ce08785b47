"""The joint-limit term: value, exact gradient against central differences, unbounded joints, scenario key."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from bracekit import InputError, load_scenario
from bracekit.errors import ScenarioError
from bracekit.objective import TERMS, JointLimits, Objective, finite_difference_gradient
from bracekit.simulation.scenario import shipped_scenarios


def test_value_is_the_squared_distance_from_the_middle_over_the_span() -> None:
    term = JointLimits(np.array([-1.0, 0.0, -np.inf]), np.array([1.0, 2.0, np.inf]))
    assert term.of_q(np.array([0.0, 1.0, 123.0])) == 0.0  # middles; the unbounded joint does not count
    assert term.of_q(np.array([1.0, 2.0, -7.0])) == pytest.approx(0.5)  # 1/4 per joint at a limit
    assert np.array_equal(term.gradient_of_q(np.array([0.5, 0.0, 3.0])), [0.25, -0.5, 0.0])


def test_gradient_equals_central_differences_on_the_paper_robot() -> None:
    sc = load_scenario("paper")
    term = JointLimits(sc.robot.lower, sc.robot.upper)
    rng = np.random.default_rng(5)
    for _ in range(4):
        q = sc.guess + rng.normal(scale=0.4, size=sc.robot.n)
        st = sc.braced.state(q)
        fd = finite_difference_gradient(sc.braced, term.value, q)
        assert np.allclose(term.gradient(st), fd, rtol=1e-7, atol=1e-9)
        obj = Objective([term], [0.3])
        assert np.allclose(obj.gradient(st), 0.3 * fd, rtol=1e-7, atol=1e-9)


def test_bad_limits_are_refused() -> None:
    with pytest.raises(InputError):
        JointLimits(np.array([0.0, 1.0]), np.array([1.0, 0.5]))
    with pytest.raises(InputError):
        JointLimits(np.array([0.0]), np.array([1.0, 2.0]))
    with pytest.raises(InputError):
        JointLimits(np.array([np.nan]), np.array([1.0]))
    with pytest.raises(InputError):
        JointLimits(np.array([0.0]), np.array([1.0])).of_q(np.zeros(2))


def test_scenario_key_sets_the_weight_and_is_refused_when_negative(tmp_path: Path) -> None:
    assert "joint_limits" in TERMS
    sc = load_scenario("paper")
    assert sc.weights["joint_limits"] == 0.0  # the paper run is unchanged
    assert "joint_limits" not in sc.objective().names
    paper = shipped_scenarios()["paper"].read_text(encoding="utf-8")
    old = (
        "weights = { k = 0.5, Ci = 100.0, theta_z = 0.6, d = 0.01, clearance = 0.0, joint_limit_barrier = 0.0, "
        "conditioning = 0.0 }"
    )
    assert old in paper
    path = tmp_path / "limits.toml"
    path.write_text(paper.replace(old, old[:-1] + ", joint_limits = 2.5 }"), encoding="utf-8")
    weighted = load_scenario(path)
    assert weighted.weights["joint_limits"] == 2.5
    obj = weighted.objective()
    term = obj.terms[obj.names.index("joint_limits")]
    assert isinstance(term, JointLimits) and obj.weights[obj.names.index("joint_limits")] == 2.5
    assert np.array_equal(term.lower, sc.robot.lower) and np.array_equal(term.upper, sc.robot.upper)
    path.write_text(paper.replace(old, old[:-1] + ", joint_limits = -1.0 }"), encoding="utf-8")
    with pytest.raises(ScenarioError, match="joint_limits"):
        load_scenario(path)
