"""The command line's `run`, `validate` and `study`, with one brace and two: the written summary against the scenario,
the validation against MuJoCo and the nonlinear static solve.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from test_cli import Q, _run


def test_run_writes_summary_table_and_trajectories(capsys, short_scenario_file: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    code, stdout, _ = _run(
        [
            "run",
            str(short_scenario_file),
            "--out",
            str(out),
            "--no-figures",
            "--quiet",
            "--compliance-model",
            "projection",
        ],
        capsys,
    )
    assert code == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["compliance_model"] == "projection"
    assert set(summary["strategies"]) == {"free_space_min_norm", "braced_min_norm", "braced_gradient_projection"}
    assert (out / "table.md").is_file() and (out / "table.csv").is_file() and (out / "trajectories.npz").is_file()
    assert "Table I" in stdout


def test_validate_json_has_the_required_keys(capsys, tmp_path: Path) -> None:
    out = tmp_path / "val"
    args = ["validate", "paper", "--configs", "1", "--tracking-points", "1", "--json", "--out", str(out)]
    code, stdout, _ = _run(args, capsys)
    assert code == 0
    data = json.loads(stdout)
    assert "cases" in data
    assert data["preloaded"]["median_rel_err_mujoco"] < 0.01  # gravity and preloads 1–50 N
    runs = {"free_space_min_norm", "braced_min_norm", "braced_gradient_projection"}
    assert set(data["tracking"]["strategies"]) == runs
    for model in ("constrained", "projection", "free_space"):
        for key in ("median_rel_err_mujoco", "max_rel_err_mujoco", "median_rel_err_static", "max_rel_err_static"):
            assert isinstance(data[model][key], float)
    assert data["constrained"]["median_rel_err_mujoco"] < 0.01
    assert (out / "validation.png").stat().st_size > 0 and (out / "validation.json").is_file()


def test_validate_checks_the_holding_statics_in_mujoco_when_the_scenario_has_them(capsys, tmp_path: Path) -> None:
    import re

    from helpers import scenario_text

    text = re.sub(r"(?m)^stiffness = .*$", "stiffness = 170.0\ngravity = true", scenario_text(), count=1)
    text = re.sub(r"(?m)^region_radius = .*$", "region_radius = 0.15\npreload = 20.0\nfriction = 0.5", text, count=1)
    path = tmp_path / "hold.toml"
    path.write_text(text + "\n[loads]\nwrenches = [[0.0, 0.0, -10.0, 0.0, 0.0, 0.0]]\n", encoding="utf-8")
    code, stdout, _ = _run(["validate", str(path), "--configs", "1", "--tracking-points", "0", "--json"], capsys)
    assert code == 0
    s = json.loads(stdout)["holding"]["summary"]
    assert s["unloaded_normal_max_rel_err"] < 0.02 and s["force_median_rel_err"] < 0.02
    assert s["margin_cases"] > 0 and s["margin_agree"] == s["margin_cases"]


def test_validate_rejects_zero_configurations(capsys) -> None:
    code, _, err = _run(["validate", "--configs", "0"], capsys)
    assert code == 2 and "--configs" in err
    code, _, err = _run(["validate", "--tracking-points", "-1"], capsys)
    assert code == 2 and "--tracking-points" in err


def test_study_ranks_bracing_points_and_reports_json(capsys) -> None:
    code, out, _ = _run(["study", "--model", "paper-robot", "--q", Q, "--points-per-link", "1", "--json"], capsys)
    assert code == 0
    cands = json.loads(out)["candidates"]
    assert 8 <= len(cands) <= 10
    assert [c["Ci_constrained"] for c in cands] == sorted(c["Ci_constrained"] for c in cands)
    code, out, _ = _run(["study", "--model", "paper-robot", "--q", Q], capsys)
    assert code == 0 and "best first" in out


def _two_braces_toml(tmp_path: Path) -> Path:
    """The paper scenario, cut short, with a second pad (HEBI link 9's origin) on a wall."""
    import re

    from helpers import scenario_text

    text = scenario_text(turns=0.05, dt=0.1)
    start, end = text.index("[brace]"), text.index("[task]")
    braces = (
        '[[brace]]\nframe = "brace"\npoint = [0.70, -0.15, -0.30]\nnormal = [0.0, 0.0, 1.0]\nregion_radius = 0.15\n\n'
        '[[brace]]\nlink = "link9"\nframe = "wall_pad"\npoint = [1.02, 0.0098, -0.29]\nnormal = [0.0, -1.0, 0.0]\n'
        "region_radius = 0.5\n\n"
    )
    text = text[:start] + braces + text[end:]
    text = re.sub(r"weights = \{[^}]*\}", "weights = { Ci = 100.0, d = 0.01 }", text)
    path = tmp_path / "two.toml"
    path.write_text(text, encoding="utf-8")
    return path


def test_run_and_validate_with_two_braces(capsys, tmp_path: Path) -> None:
    path = _two_braces_toml(tmp_path)
    code, _, _ = _run(["run", str(path), "--no-figures", "--quiet", "--out", str(tmp_path / "out")], capsys)
    assert code == 0
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    for name in ("braced_min_norm", "braced_gradient_projection"):
        s = summary["strategies"][name]
        assert s["completed"] and len(s["braces"]) == 2
        assert max(b["max_contact_violation_m"] for b in s["braces"]) < 1e-9
    code, out, _ = _run(["validate", str(path), "--configs", "1", "--json"], capsys)
    assert code == 0
    s = json.loads(out)["summary"]
    assert s["n_ok"] > 0 and s["constrained_vs_mujoco"]["median"] < 0.01


def test_a_run_with_two_braces_reports_each_brace_s_margins(capsys, tmp_path: Path) -> None:
    text = _two_braces_toml(tmp_path).read_text(encoding="utf-8")
    text = text.replace("region_radius = 0.15\n", "region_radius = 0.15\npreload = 30.0\nfriction = 0.5\n", 1)
    text = text.replace("[robot]\n", "[robot]\ngravity = true\n", 1)
    text += "\n[loads]\nwrenches = [[0.0, 0.0, -10.0, 0.0, 0.0, 0.0]]\n"
    path = tmp_path / "two-hold.toml"
    path.write_text(text, encoding="utf-8")
    code, _, _ = _run(["run", str(path), "--no-figures", "--quiet", "--out", str(tmp_path / "hold")], capsys)
    assert code == 0
    s = json.loads((tmp_path / "hold" / "summary.json").read_text())["strategies"]["braced_min_norm"]
    assert {"min_liftoff_margin", "min_slip_margin"} <= set(s["braces"][0]) and len(s["braces"]) == 2
    per_brace = [b["min_slip_margin"] for b in s["braces"] if b["min_slip_margin"] is not None]
    assert s["min_slip_margin"] == pytest.approx(min(per_brace))  # the run's margin is the least over braces


def test_the_projection_model_with_two_braces_is_refused_in_one_line(capsys, tmp_path: Path) -> None:
    path = _two_braces_toml(tmp_path)
    args = [
        "run",
        str(path),
        "--no-figures",
        "--quiet",
        "--compliance-model",
        "projection",
        "--out",
        str(tmp_path / "o"),
    ]
    code, _, err = _run(args, capsys)
    assert code == 2 and "defined for one brace" in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "o").exists()


def test_the_preloaded_model_runs_with_two_braces_and_a_preload(capsys, tmp_path: Path) -> None:
    path = _two_braces_toml(tmp_path)
    text = path.read_text(encoding="utf-8").replace(
        "region_radius = 0.15\n", "region_radius = 0.15\npreload = 5.0\n", 1
    )
    path.write_text(text, encoding="utf-8")
    args = [
        "run",
        str(path),
        "--no-figures",
        "--quiet",
        "--compliance-model",
        "preloaded",
        "--out",
        str(tmp_path / "o"),
    ]
    code, _, err = _run(args, capsys)
    assert code == 0, err
    summary = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert summary["compliance_model"] == "preloaded"
    assert summary["strategies"]["braced_gradient_projection"]["completed"]


@pytest.mark.slow
def test_validate_two_braces_reports_every_block_and_skips_none(capsys, tmp_path: Path) -> None:
    pytest.importorskip("mujoco")
    args = ["validate", "two-braces", "--configs", "1", "--tracking-points", "1", "--out", str(tmp_path / "v")]
    code, out, _ = _run(args, capsys)
    assert code == 0 and "not checked" not in out
    for heading in (
        "MuJoCo vs static solve",  # the statics: the first-order models against the nonlinear static solve
        "Validation of the preloaded compliance",
        "Validation of the holding statics in MuJoCo, scenario 'two-braces'",
        "Lift-off and slip scales under a slow load ramp in MuJoCo, scenario 'two-braces'",
        "Tracking check in MuJoCo, scenario 'two-braces'",
    ):
        assert heading in out
    data = json.loads((tmp_path / "v" / "validation.json").read_text())
    assert "skipped" not in data
    holding, capacity = data["holding"], data["capacity"]
    assert holding["holding"]["preloads_N"] == [5.0, 5.0]
    s = holding["summary"]
    assert s["margin_cases"] > 0 and s["margin_agree"] == s["margin_cases"] and s["force_max_rel_err"] < 0.02
    # each wrench fails a different brace first, and MuJoCo fails that brace
    firsts = {c["ramp"]["brace"] for c in capacity["cases"] if c["variant"] == "scenario"}
    assert firsts == {0, 1}
    assert all(c["ramp"]["mujoco_brace"] == c["ramp"]["brace"] for c in capacity["cases"] if c["status"] == "ok")
    assert capacity["counts"]["disagrees"] == 0 and capacity["max_rel_err"] < 0.05
