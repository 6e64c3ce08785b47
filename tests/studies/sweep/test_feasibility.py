"""Feasibility of a row, judged by the spec's current bounds: margins as load scales, holds, unstable samples."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any

import pytest

from bracekit.studies.sweep.candidates import Candidate, expand
from bracekit.studies.sweep.evaluate import RESULT_COLUMNS, feasibility, judge
from bracekit.studies.sweep.refine import refine_candidate, refinement_key
from bracekit.studies.sweep.report import ranked
from bracekit.studies.sweep.spec import Feasibility, load_spec, parse_spec


def completed(**values: Any) -> dict[str, Any]:
    """A completed gradient-projection row that meets the default bounds, with `values` replaced."""
    row: dict[str, Any] = {"candidate": "c", "index": 0, **dict.fromkeys(RESULT_COLUMNS)}
    row |= {
        "screened_out": False,
        "completed": True,
        "Ci_mean_gp": 0.004,
        "k_mean_gp": 10.0,
        "max_joint_limit_violation_rad": 0.0,
        "min_link_clearance_m": 0.02,
        "feasible": True,
        "failure": None,
    }
    return row | values


def test_the_default_margin_bound_is_one_load_scale(tiny_spec: Path) -> None:
    data = {"base": str(tiny_spec.parent / "short.toml"), "axes": {"link": ["link4"]}}
    spec = parse_spec(data)
    assert spec.feasibility.min_margin == 1.0
    assert load_spec("paper-links").feasibility.min_margin == 1.0
    for key in ("min_liftoff_margin", "min_slip_margin", "min_torque_margin"):
        assert judge(spec, completed(**{key: 1.0}))["feasible"]
        row = judge(spec, completed(**{key: 0.5}))  # holds only half the listed load
        assert not row["feasible"] and row["failure"] == f"{key} 0.5 < 1"


def test_a_brace_that_does_not_hold_or_is_unstable_is_not_feasible(tiny_spec: Path) -> None:
    spec = load_spec(tiny_spec)
    assert judge(spec, completed(holds=True, unstable_samples=0))["feasible"]
    assert judge(spec, completed(holds=None, unstable_samples=None))["feasible"]  # no statics
    loose = dataclasses.replace(spec, feasibility=Feasibility(min_margin=-1.0))
    no = judge(loose, completed(holds=False, min_torque_margin=0.5, unstable_samples=0))
    assert not no["feasible"] and "does not hold" in no["failure"]
    shaky = judge(spec, completed(holds=True, unstable_samples=3))
    assert not shaky["feasible"] and "3 samples" in shaky["failure"]


@pytest.mark.parametrize("ci", [None, math.inf, math.nan])
def test_a_missing_mean_ci_is_not_feasible(tiny_spec: Path, ci: float | None) -> None:
    spec = load_spec(tiny_spec)
    row = judge(spec, completed(Ci_mean_gp=ci, unstable_samples=1))
    assert not row["feasible"] and "unstable" in row["failure"]
    row = judge(spec, completed(Ci_mean_gp=ci))
    assert not row["feasible"] and "C_i" in row["failure"]


def test_a_run_that_did_not_complete_keeps_its_reason(tiny_spec: Path) -> None:
    spec = load_spec(tiny_spec)
    reason = "ConvergenceError: the start solve did not converge"
    row = judge(spec, completed(completed=False, feasible=True, failure=reason))
    assert not row["feasible"] and row["failure"] == reason


def test_judging_again_follows_the_current_bounds(tiny_spec: Path) -> None:
    spec = load_spec(tiny_spec)
    saved = judge(spec, completed(k_mean_gp=30.0))
    assert saved["feasible"]
    strict = dataclasses.replace(spec, feasibility=Feasibility(k_max=20.0))
    assert feasibility(strict, saved) == "k_mean 30 > k_max 20"
    assert not judge(strict, saved)["feasible"]
    assert judge(spec, judge(strict, saved)) == saved


def test_ranking_survives_a_feasible_row_without_mean_ci() -> None:
    rows = [
        completed(candidate="a", index=0, Ci_mean_gp=None),
        completed(candidate="b", index=1, Ci_mean_gp=0.003),
        completed(candidate="c", index=2, Ci_mean_gp=0.002),
        completed(candidate="d", index=3, feasible=False),
    ]
    assert [r["candidate"] for r in ranked(rows)] == ["c", "b", "a", "d"]


def test_refinement_ignores_an_evaluation_without_mean_ci(tiny_spec: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import bracekit.studies.sweep.refine as refine

    spec = load_spec(tiny_spec)
    calls: list[float] = []

    def fake(spec_: Any, cand: Candidate, ctx: Any, *strategies: str) -> dict[str, Any]:
        calls.append(cand.inputs["fraction"])
        return completed(fraction=cand.inputs["fraction"], Ci_mean_gp=None)  # marked feasible, no C_i

    monkeypatch.setattr(refine, "evaluate_candidate", fake)
    out = refine_candidate(spec, expand(spec)[0], None, 0.2, 0.4)  # type: ignore[arg-type]
    assert out["evaluations"] == len(calls) >= 1
    assert out["refined_fraction"] is None and out["refined_Ci_mean_gp"] is None


def test_the_refinement_key_holds_the_feasibility_bounds(tiny_spec: Path) -> None:
    spec = load_spec(tiny_spec)
    cand = expand(spec)[0]
    keys = {
        refinement_key(dataclasses.replace(spec, feasibility=f), cand, 0.2, 0.4)
        for f in (Feasibility(), Feasibility(k_max=20.0), Feasibility(min_clearance=0.01), Feasibility(min_margin=0.5))
    }
    assert len(keys) == 4
    assert refinement_key(spec, cand, 0.2, 0.4) == refinement_key(load_spec(tiny_spec), cand, 0.2, 0.4)


def test_a_run_that_is_not_valid_is_not_feasible(tiny_spec: Path) -> None:
    spec = load_spec(tiny_spec)
    assert judge(spec, completed(valid=True, invalid_reasons=None))["feasible"]
    why = "a link passes through the surface's solid: the link of joint 3 (j3) is 0.0100 m inside at t = 1.000 s"
    row = judge(spec, completed(valid=False, invalid_reasons=why))
    assert not row["feasible"] and row["failure"] == f"not valid: {why}"
