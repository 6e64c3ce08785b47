from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from bracekit.studies.sweep.candidates import Candidate, candidate_id, expand
from bracekit.studies.sweep.context import task_context
from bracekit.studies.sweep.evaluate import evaluate_candidate
from bracekit.studies.sweep.refine import PENALTY, interval, refine_candidate
from bracekit.studies.sweep.spec import load_spec


def test_interval_is_between_the_grid_neighbours() -> None:
    spec = load_spec("paper-links")
    assert interval(spec, 0.02) == (0.0, pytest.approx(0.06))
    lo, hi = interval(spec, 0.5)
    assert lo == pytest.approx(0.46) and hi == pytest.approx(0.54)
    assert interval(dataclasses.replace(spec, mode="random"), 0.95) == (pytest.approx(0.85), 1.0)


def test_refinement_reports_its_best_feasible_evaluation(tiny_spec: Path) -> None:
    spec = load_spec(tiny_spec)
    spec = dataclasses.replace(spec, refinement=dataclasses.replace(spec.refinement, max_evaluations=3, xatol=0.05))
    cand = expand(spec)[0]  # link4 at 0.3
    ctx = task_context(spec, {}, cand.context_key)
    out = refine_candidate(spec, cand, ctx, 0.2, 0.4)
    assert 1 <= out["evaluations"] <= 4
    if out["refined_fraction"] is None:
        pytest.skip("no feasible evaluation in the interval")
    assert 0.2 <= out["refined_fraction"] <= 0.4
    inputs = cand.inputs | {"fraction": out["refined_fraction"]}
    again = evaluate_candidate(spec, Candidate(-1, candidate_id(inputs), inputs), ctx)
    assert again["feasible"] and again["Ci_mean_gp"] == out["refined_Ci_mean_gp"] < PENALTY


class _Interrupted:
    """A Dask client stand-in whose evaluations are interrupted (Ctrl-C while waiting for a worker)."""

    def __init__(self) -> None:
        self.submitted = 0
        self.cancelled: list[object] = []

    def submit(self, *args: object, **kwargs: object) -> _Interrupted:
        self.submitted += 1
        return self

    def result(self) -> None:
        raise KeyboardInterrupt

    def cancel(self, futures: list[object]) -> None:
        self.cancelled += futures


def test_an_interrupted_refinement_cancels_its_evaluations(tiny_spec: Path, tmp_path: Path) -> None:
    from bracekit.studies.sweep.refine import refine_best
    from bracekit.studies.sweep.store import RowStore

    spec = load_spec(tiny_spec)
    cands = expand(spec)
    row = {"candidate": cands[0].id, "index": 0, "feasible": True, "Ci_mean_gp": 0.004, "fraction": 0.3}
    client = _Interrupted()
    futures: list[object] = []
    with pytest.raises(KeyboardInterrupt):
        refine_best(spec, [row], cands, {cands[0].context_key: None}, client, RowStore(tmp_path, spec), futures)
    assert client.submitted == 1 and client.cancelled == futures == [client]  # no evaluation after the interrupt
    assert not list((tmp_path / ".sweep" / "refined").iterdir())
