"""Tests of a run's verdict (``valid``, ``invalid_reasons``) beside ``completed``.

References: the run's own per-sample series, judged here against the bracing region radius and the joint
limits written in the test, and the link named against the clearance model's own least link at that sample.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from bracekit.kinematics.clearance import link_clearance
from bracekit.simulation.run import run_scenario
from bracekit.simulation.samples import ContactSeries
from bracekit.simulation.scenario import load_scenario
from bracekit.simulation.trajectory import Trajectory
from bracekit.simulation.validity import verdict


def _trajectory(n: int, clearance: float, radius: float, violation: float) -> Trajectory:
    class _Samples:
        contacts = (ContactSeries(np.zeros(n), np.full(n, radius), np.zeros(n)),)

    measures = {
        "link_clearance": np.full(n, 0.05),
        "joint_limit_violation": np.zeros(n),
    }
    measures["link_clearance"][-1] = clearance
    measures["joint_limit_violation"][-1] = violation
    return Trajectory(
        strategy="braced_min_norm",
        braced=True,
        t=np.arange(n) * 0.05,
        q=np.zeros((n, 11)),
        measures=measures,
        completed=True,
        samples=_Samples(),  # type: ignore[arg-type]
    )


def test_a_clear_run_inside_its_region_and_limits_is_valid() -> None:
    sc = load_scenario("paper")
    r_max = sc.braced.brace.region_radius
    out = verdict(sc.braced, _trajectory(4, 0.01, 0.5 * r_max, 0.0), {"holds": None})
    assert out.valid and out.invalid_reasons == []


def test_each_violation_is_a_reason() -> None:
    sc = load_scenario("paper")
    r_max = sc.braced.brace.region_radius
    tr = _trajectory(4, 0.01, 1.2 * r_max, 0.02)
    tr.q[-1] = sc.guess
    out = verdict(sc.braced, tr, {"holds": False})
    assert not out.valid
    text = "\n".join(out.invalid_reasons)
    assert f"r = {1.2 * r_max:.4f} m > r_max" in text and "does not hold" in text and "by 0.02 rad" in text
    assert "surface's solid" not in text


def test_a_link_inside_the_table_makes_the_run_invalid_and_names_it() -> None:
    sc = load_scenario("paper")
    q = np.array(sc.guess, dtype=float)
    st = sc.braced.state(q)
    depth, joint = link_clearance(st)
    assert np.isfinite(depth)
    tr = _trajectory(3, -abs(depth) - 0.01, 0.0, 0.0)
    tr.q[-1] = q
    out = verdict(sc.braced, tr, {"holds": None})
    assert not out.valid
    assert f"the link of joint {joint + 1} ({sc.braced.robot.joint_names[joint]})" in out.invalid_reasons[0]
    assert f"{abs(depth) + 0.01:.4f} m inside" in out.invalid_reasons[0]


@pytest.mark.slow
def test_the_paper_runs_pass_links_through_the_table_and_are_not_valid() -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = run_scenario("paper")
    for summary in result.summaries.values():
        for name, s in summary["strategies"].items():
            assert s["completed"], name
            assert s["min_link_clearance_m"] < 0 and s["valid"] is False
            assert any("passes through the surface's solid" in r for r in s["invalid_reasons"])
            assert f"{-s['min_link_clearance_m']:.4f} m inside" in s["invalid_reasons"][0]
    assert not result.valid and result.completed
