"""Tests of a run's verdict (``valid``, ``invalid_reasons``) beside ``completed``.

References: the run's own per-sample series, judged here against the bracing region radius and the joint
limits written in the test, and the link named against the clearance model's own least link at that sample;
the tie rule against per-link clearances written in the test.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable

import numpy as np
import pytest

from bracekit.kinematics.clearance import Clearance, LinkDistance, link_clearance
from bracekit.simulation.run import run_scenario
from bracekit.simulation.samples import ContactSeries
from bracekit.simulation.scenario import load_scenario
from bracekit.simulation.trajectory import Trajectory
from bracekit.simulation.validity import TIE_TOL, deepest_link, verdict


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


def _links(values: dict[int, float]) -> Callable[..., list[LinkDistance]]:
    def links(self: Clearance, q: object, gradient: bool = True, below: float = math.inf) -> list[LinkDistance]:
        return [LinkDistance(j, v, np.zeros(0)) for j, v in sorted(values.items())]

    return links


@pytest.mark.parametrize(
    ("values", "named"),
    [
        ({3: -0.2, 7: -0.3, 8: -0.3 - 5e-17}, 7),  # a tie at a shared joint, the higher link lower by rounding
        ({3: -0.2, 7: -0.3 - 5e-17, 8: -0.3}, 7),  # the same tie the other way round
        ({3: -0.2, 7: -0.3, 8: -0.3 - 1e-6}, 8),  # a real difference: the deeper link
        ({2: -0.1, 5: -0.1 + 0.5 * TIE_TOL, 6: 0.4}, 2),
    ],
)
def test_the_deepest_link_names_the_lowest_joint_of_a_tie(
    monkeypatch: pytest.MonkeyPatch, values: dict[int, float], named: int
) -> None:
    sc = load_scenario("paper")
    monkeypatch.setattr(Clearance, "links", _links(values))
    least, joint = deepest_link(sc.braced, sc.guess)
    assert least == min(values.values()) and joint == named


def test_the_deepest_link_is_the_clearance_models_least() -> None:
    sc = load_scenario("paper")
    st = sc.braced.state(np.array(sc.guess, dtype=float))
    least, joint = deepest_link(sc.braced, st.q)
    exact = link_clearance(st)
    assert least == exact[0]
    ties = [d.joint for d in Clearance(sc.braced).links(st.q, gradient=False) if d.clearance <= least + TIE_TOL]
    assert joint == min(ties) and exact[1] in ties


def test_the_verdict_names_the_earliest_sample_and_lowest_link_of_a_tie(monkeypatch: pytest.MonkeyPatch) -> None:
    sc = load_scenario("paper")
    monkeypatch.setattr(Clearance, "links", _links({7: -0.3, 8: -0.3 - 5e-17}))
    tr = _trajectory(4, -0.3, 0.0, 0.0)
    tr.measures["link_clearance"][1] = -0.3 + 0.1 * TIE_TOL  # within the tie, earlier
    out = verdict(sc.braced, tr, {"holds": None})
    name = sc.braced.robot.joint_names[7]
    assert out.invalid_reasons[0].endswith(f"the link of joint 8 ({name}) is 0.3000 m inside at t = 0.050 s")
