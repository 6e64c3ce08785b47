"""A place's whole-task row: a compass trial runs gradient projection only, as the sweep's refinement.

Reference: the same place's row with both braced strategies (the runs are independent of each other, so every
gradient-projection column and the feasibility are the same) and `bracekit run` of the place's scenario for the
minimum-norm C_i.
"""

from __future__ import annotations

from typing import Any

import pytest

from bracekit.simulation.run import run_scenario
from bracekit.studies.place.inner import InnerSettings, optimise_start
from bracekit.studies.place.outer import TASK_COLUMNS, _scenario, evaluate_place
from bracekit.studies.sweep.context import task_context

#: The columns of the minimum-norm run (None in a compass trial's row).
MIN_NORM = ("Ci_mean_min_norm", "k_mean_min_norm", "completed_min_norm", "failure_min_norm")


@pytest.mark.slow
def test_a_trial_runs_gradient_projection_only(setup: dict[str, Any]) -> None:
    spec = setup["spec"]
    r = optimise_start(spec, "link2", 0.5, setup["q"], InnerSettings())
    assert r.success, r.message
    context = task_context(spec, {}, "{}")
    both = evaluate_place(spec, r.place, r.q, context, "task")
    trial = evaluate_place(spec, r.place, r.q, context, "refine")
    assert both["feasible"] and trial["feasible"], (both["failure"], trial["failure"])
    assert all(trial[c] is None for c in MIN_NORM)
    assert both["completed_min_norm"] is True
    same = [c for c in TASK_COLUMNS if c not in (*MIN_NORM, "warnings", "wall_s")]
    assert {c: trial[c] for c in same} == {c: both[c] for c in same}
    result = run_scenario(_scenario(spec, r.place, r.q, "capsule")[1], both_models=False)
    assert result.summary["strategies"]["braced_min_norm"]["Ci_mean"] == pytest.approx(
        both["Ci_mean_min_norm"], rel=1e-12
    )
