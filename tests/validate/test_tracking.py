"""Tests of bracekit.validate.tracking: each strategy's tool compliance along β_x, followed in MuJoCo."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import pytest

import bracekit as bk
from bracekit.compliance.first_order import end_effector_compliance, free_space_compliance
from bracekit.errors import InputError
from bracekit.simulation.run import RunResult, run_scenario
from bracekit.validate.tracking import (
    PAPER_RANKING,
    TrackingPoint,
    TrackingReport,
    TrackingStrategy,
    run_tracking_validation,
)
from helpers import scenario_text

pytestmark = pytest.mark.slow  # MuJoCo simulations


@pytest.fixture(scope="module")
def short_run(tmp_path_factory: pytest.TempPathFactory) -> RunResult:
    """The paper scenario cut to its first 2 s (20 steps of 0.1 s per strategy)."""
    path: Path = tmp_path_factory.mktemp("track") / "short.toml"
    path.write_text(scenario_text(turns=0.1, dt=0.1), encoding="utf-8")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", bk.errors.BracekitWarning)
        return run_scenario(path, both_models=False)


@pytest.fixture(scope="module")
def report(short_run: RunResult) -> TrackingReport:
    return run_tracking_validation(short_run, points=2, force=1.0)


def test_every_strategy_is_checked_at_the_first_and_last_sample(short_run: RunResult, report: TrackingReport) -> None:
    runs = short_run.trajectories[short_run.compliance_model]
    assert list(report.strategies) == list(runs)
    for name, st in report.strategies.items():
        assert [p.index for p in st.points] == [0, runs[name].t.size - 1]
        assert st.braced == runs[name].braced


def test_measured_compliance_along_beta_x_matches_the_first_order_model(report: TrackingReport) -> None:
    for st in report.strategies.values():
        for p in st.points:
            assert not p.contact_opened
            assert p.rel_err < 0.01, (st.strategy, p.index, p.measured, p.predicted)
            # the tangent model (preload's geometric stiffness) is at least as close as the first-order one
            assert abs(p.measured - p.predicted_tangent) <= abs(p.measured - p.predicted) + 1e-3 * p.predicted


def test_sticking_pad_matches_the_sticking_point_model_and_does_not_slip(report: TrackingReport) -> None:
    for st in report.strategies.values():
        if not st.braced:
            continue
        for p in st.points:
            assert p.predicted_slip is False and not p.slipped, (st.strategy, p.index, p.slip)
            assert p.measured_sticking is not None and p.predicted_sticking is not None
            assert p.rel_err_sticking is not None and p.rel_err_sticking < 0.01
            # friction only adds constraints: the sticking pad is stiffer than the frictionless one
            assert p.measured_sticking < p.measured


def test_predictions_are_the_bracekit_compliances_along_beta_x(short_run: RunResult, report: TrackingReport) -> None:
    sc = short_run.scenario
    for st in report.strategies.values():
        p = st.points[-1]
        beta = sc.beta_x(p.t)
        state = sc.braced.state(p.q)
        c = end_effector_compliance(state, "constrained") if st.braced else free_space_compliance(state)
        assert p.predicted == pytest.approx(beta @ c @ beta / (beta @ beta), rel=1e-12)
        # C_i = ‖β_xᵀ C‖ bounds the deflection along β_x per unit force along β_x
        assert p.ci is not None and p.predicted <= p.ci * (1 + 1e-12)


def test_the_papers_ranking_holds_on_the_short_run_and_is_reported(report: TrackingReport) -> None:
    measured = report.ranking("measured_mean")
    assert measured["holds"] is True and measured["order"] == list(PAPER_RANKING)
    assert report.ranking("predicted_mean")["order"] == measured["order"]
    data = report.to_json()
    json.dumps(data, allow_nan=False)
    assert data["ranking"]["measured"]["holds"] is True
    assert set(data["strategies"]) == set(PAPER_RANKING)
    text = report.table_text()
    assert "paper's ranking, MuJoCo, frictionless pad" in text and "holds" in text


def _strategy(name: str, value: float) -> TrackingStrategy:
    q, beta = np.zeros(3), np.array([1.0, 0, 0, 0, 0, 0])
    point = TrackingPoint(
        0, 0.0, q, beta, 0.0, 0.0, None, value, value, None, value,
        None, None, None, 0.0, None, False, None, False, None,
    )  # fmt: skip
    return TrackingStrategy(name, name != "free_space_min_norm", [point], 0.0)


def test_a_ranking_against_the_paper_is_reported_with_the_pair_that_breaks_it() -> None:
    rep = TrackingReport("x", "constrained", {})
    for name, value in zip(PAPER_RANKING, (3e-3, 1e-3, 2e-3), strict=True):
        rep.strategies[name] = _strategy(name, value)
    rk = rep.ranking("measured_mean")
    assert rk["holds"] is False
    assert rk["order"] == ["free_space_min_norm", "braced_gradient_projection", "braced_min_norm"]
    assert rk["violations"] == ["braced_gradient_projection (0.002) is not stiffer than braced_min_norm (0.001)"]


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"points": 0}, "points"),
        ({"force": -1.0}, "tool force"),
        ({"timestep": 2e-3}, "timestep"),
        ({"strategies": ["nope"]}, "no run named nope"),
        ({"path_friction": 1}, "path_friction"),
    ],
)
def test_bad_arguments_are_refused(short_run: RunResult, kwargs: dict, match: str) -> None:
    with pytest.raises(InputError, match=match):
        run_tracking_validation(short_run, **kwargs)


def test_a_bad_first_argument_is_refused() -> None:
    with pytest.raises(InputError, match="RunResult"):
        run_tracking_validation(3.0)  # type: ignore[arg-type]


class _Fake:
    """A strategy's tracking summary with given numbers (duck-typed TrackingStrategy)."""

    def __init__(self, measured: float, predicted: float, worst: float) -> None:
        self._s = {"measured_mean": measured, "predicted_mean": predicted, "max_rel_err": worst}

    def summary(self) -> dict:
        return self._s


def test_disagreements_flag_errors_beyond_the_tolerance_and_a_reversed_measured_order() -> None:
    from bracekit.validate.tracking import TRACKING_TOL, TrackingReport

    ok = TrackingReport("x", "constrained", {})
    ok.strategies.update(
        free_space_min_norm=_Fake(3.0, 3.0, 0.01),
        braced_min_norm=_Fake(2.0, 2.0, 0.01),
        braced_gradient_projection=_Fake(1.0, 1.0, 0.01),
    )
    assert ok.disagreements() == []
    bad = TrackingReport("x", "constrained", {})
    bad.strategies.update(
        free_space_min_norm=_Fake(3.0, 3.0, 0.01),
        braced_min_norm=_Fake(0.9, 2.0, 2 * TRACKING_TOL),  # off by more than the tolerance, and below GP
        braced_gradient_projection=_Fake(1.0, 1.0, 0.01),
    )
    lines = bad.disagreements()
    assert any("braced_min_norm: measured compliance off" in w for w in lines)
    assert any("MuJoCo orders the strategies" in w for w in lines)
