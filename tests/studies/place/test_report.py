"""best.toml: the TOML text reads back to the scenario data, and `bracekit run` runs it to the evaluated C_i."""

from __future__ import annotations

import json
import tomllib
from pathlib import Path
from typing import Any

import pytest

from bracekit.cli.main import main
from bracekit.studies.place.inner import InnerSettings, optimise_start
from bracekit.studies.place.outer import evaluate_place
from bracekit.studies.place.scenario import place_data
from bracekit.studies.place.surface import link_surface
from bracekit.studies.place.toml_text import toml_text
from bracekit.studies.sweep.context import task_context


def test_toml_text_reads_back() -> None:
    data = {
        "name": "x",
        "flag": True,
        "robot": {"model": "paper-robot", "stiffness": 170.0},
        "gp": {"weights": {"k": 0.5, "Ci": 100.0}, "odd key": [1, 2.5e-9, -3.0]},
        "loads": {"wrenches": [[0.0, 0.0, -10.0, 0.0, 0.0, 0.0]]},
        "text": 'quote " and ° sign',
    }
    assert tomllib.loads(toml_text(data)) == data


@pytest.mark.slow
def test_best_scenario_runs(setup: dict[str, Any], tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    spec = setup["spec"]
    r = optimise_start(spec, "link2", 0.5, setup["q"], InnerSettings())
    assert r.success, r.message
    surface = link_surface(spec.base_scenario().robot, "link2")
    data = place_data(spec, surface, r.place, r.q)
    path = tmp_path / "best.toml"
    path.write_text(toml_text(data), encoding="utf-8")
    assert tomllib.loads(path.read_text(encoding="utf-8")) == data
    row = evaluate_place(spec, r.place, r.q, task_context(spec, {}, "{}"), "task")
    assert row["feasible"], row["failure"]
    out = tmp_path / "run"
    assert main(["run", str(path), "--out", str(out), "--no-figures", "--quiet"]) == 0
    summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    gp = summary["strategies"]["braced_gradient_projection"]
    assert gp["completed"]
    assert gp["Ci_mean"] == pytest.approx(row["Ci_mean_gp"], rel=1e-9)
