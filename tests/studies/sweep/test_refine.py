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
