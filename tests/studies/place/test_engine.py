"""A small placement end to end on a Dask local cluster: one link, one seed, one compass round (slow).

link4 of the paper's robot: its best place validates in MuJoCo (the placement's MuJoCo check is tested in
test_settle.py).
"""

from __future__ import annotations

import tomllib
from pathlib import Path

import pytest

from bracekit.studies.place.engine import PlaceRun, PlaceSettings, run_place
from bracekit.studies.place.report import write_outputs
from bracekit.studies.sweep.engine import dask_client
from bracekit.studies.sweep.refine import usable
from bracekit.studies.sweep.spec import parse_spec

pytestmark = pytest.mark.slow


def test_small_placement(tmp_path: Path) -> None:
    spec = parse_spec(
        {"name": "place-one", "base": "paper", "axes": {"link": ["link4"]}, "brace": {"normal": [0, 0, 1]}}
    )
    with dask_client(1) as client:
        run = run_place(spec, client, PlaceSettings(seeds=1, top=1, refine_rounds=1))
    assert len(run.inner) == 1 and run.inner[0].success
    assert run.best is not None and usable(run.best)
    # the best settles in MuJoCo, and every feasible evaluation with a lower C_i was checked and did not
    assert run.best["mujoco_settles"] is True
    lower = [r for r in run.evaluations if usable(r) and r["Ci_mean_gp"] < run.best["Ci_mean_gp"]]
    assert all(r["mujoco_settles"] is False for r in lower)
    assert [r["stage"] for r in run.evaluations] == ["task"] + ["refine"] * 4
    # the compass trials run ahead with the task batch are the first round's: all used, about the task's place
    assert run.unused == 0
    centre = run.evaluations[0]
    for r in run.evaluations[1:]:
        moved = (r["fraction"] != centre["fraction"], r["angle_deg"] != pytest.approx(centre["angle_deg"]))
        assert sum(moved) == 1 and r["place"] == centre["place"]
    names = write_outputs(run, tmp_path, figures=False)
    assert {"table.md", "summary.json", "evaluations.parquet", "table.csv", "best.toml"} <= set(names)
    assert run.best_start is not None
    best = tomllib.loads((tmp_path / "best.toml").read_text(encoding="utf-8"))
    assert best["brace"]["link"] == "link4" and best["start"]["guess"] == pytest.approx(list(run.best_start.q))


def test_run_ahead_changes_no_row() -> None:
    """The early whole-task run and the early MuJoCo checks leave every row and the best as the plain order gives.

    Reference: the same placement with ``run_ahead`` off (each whole-task run in its batch, each check when the
    best is chosen); three links on two workers, so the inner level's tail leaves a worker idle.
    """
    spec = parse_spec(
        {
            "name": "place-three",
            "base": "paper",
            "axes": {"link": ["link2", "link4", "link9"]},
            "brace": {"normal": [0, 0, 1]},
        }
    )
    runs = {}
    with dask_client(2) as client:
        for ahead in (False, True):
            runs[ahead] = run_place(spec, client, PlaceSettings(top=2, run_ahead=ahead))
        one = run_place(spec, client, PlaceSettings(top=1))

    assert rows(runs[True]) == rows(runs[False])
    best, plain = runs[True].best, runs[False].best
    assert best is not None and plain is not None
    assert {**best, "wall_s": 0} == {**plain, "wall_s": 0} and best["mujoco_settles"] is True
    # one place at a time (the default): the first place feasible and settled, the second is not run; every row
    # is the two-place run's (the second place's rows left out, the evaluations renumbered), the best the same
    second = runs[False].chosen[1].place
    assert usable(runs[False].evaluations[0]) and runs[False].evaluations[0]["mujoco_settles"] is True
    assert [r.place for r in one.chosen] == [runs[False].chosen[0].place]
    kept = [r for r in rows(runs[False]) if (r["link"], r["stage"]) != (second.link, "task")]
    assert len(kept) < len(rows(runs[False]))
    assert [{**r, "evaluation": 0} for r in rows(one)] == [{**r, "evaluation": 0} for r in kept]
    assert one.best is not None and {**one.best, "wall_s": 0, "evaluation": 0} == {
        **plain,
        "wall_s": 0,
        "evaluation": 0,
    }


def rows(run: PlaceRun) -> list[dict[str, object]]:
    """The run's whole-task rows without their wall times."""
    return [{k: v for k, v in r.items() if k != "wall_s"} for r in run.evaluations]
