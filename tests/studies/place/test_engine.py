"""A small placement end to end on a Dask local cluster: one link, one seed, one compass round (slow)."""

from __future__ import annotations

import tomllib
from pathlib import Path

import pytest

from bracekit.studies.place.engine import PlaceSettings, run_place
from bracekit.studies.place.report import write_outputs
from bracekit.studies.sweep.engine import dask_client
from bracekit.studies.sweep.refine import usable
from bracekit.studies.sweep.spec import parse_spec

pytestmark = pytest.mark.slow


def test_small_placement(tmp_path: Path) -> None:
    spec = parse_spec(
        {"name": "place-one", "base": "paper", "axes": {"link": ["link2"]}, "brace": {"normal": [0, 0, 1]}}
    )
    with dask_client(1) as client:
        run = run_place(spec, client, PlaceSettings(seeds=1, top=1, refine_rounds=1))
    assert len(run.inner) == 1 and run.inner[0].success
    assert run.best is not None and usable(run.best)
    # the best is the least feasible whole-task C_i of every evaluation, and the refinement polled 4 places
    assert run.best["Ci_mean_gp"] == min(r["Ci_mean_gp"] for r in run.evaluations if usable(r))
    assert [r["stage"] for r in run.evaluations] == ["task"] + ["refine"] * 4
    names = write_outputs(run, tmp_path, figures=False)
    assert {"table.md", "summary.json", "evaluations.parquet", "table.csv", "best.toml"} <= set(names)
    assert run.best_start is not None
    best = tomllib.loads((tmp_path / "best.toml").read_text(encoding="utf-8"))
    assert best["brace"]["link"] == "link2" and best["start"]["guess"] == pytest.approx(list(run.best_start.q))
