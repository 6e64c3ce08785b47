"""The command line: JSON for scripts, one-line errors with exit code 2, no traceback, whole outputs."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from bracekit.cli.main import main

Q = "0,0.194,-2.598,0,-0.737,-2.498,-1.898,3.142,2.106,2.438,0.867"
QNEG = "-0.1,0.194,-2.598,0,-0.737,-2.498,-1.898,3.142,2.106,2.438,0.867"


def _run(args: list[str], capsys) -> tuple[int, str, str]:
    code = main(args)
    cap = capsys.readouterr()
    return code, cap.out, cap.err


def test_evaluate_json_has_the_documented_keys_and_shapes(capsys) -> None:
    code, out, _ = _run(["evaluate", "--model", "paper-robot", "--q", Q, "--json"], capsys)
    assert code == 0
    data = json.loads(out)
    shapes = {
        "J": (6, 11),
        "J1": (6, 6),
        "J2": (6, 5),
        "H": (6, 5),
        "A": (6, 10),
        "J_braced": (6, 11),
        "C_free": (6, 6),
        "C_e_projection": (6, 6),
        "C_e_constrained": (6, 6),
        "b": (3,),
        "e": (3,),
    }
    for key, shape in shapes.items():
        assert np.array(data[key]).shape == shape, key
    assert isinstance(data["k"], float) and data["k"] >= 1.0
    c = np.array(data["C_e_constrained"])
    assert np.allclose(c, c.T)


@pytest.mark.parametrize("form", [["--q", QNEG], [f"--q={QNEG}"]])
def test_negative_joint_values_work_in_both_forms(capsys, form: list[str]) -> None:
    code, out, _ = _run(["evaluate", "--model", "paper-robot", *form, "--json"], capsys)
    assert code == 0 and json.loads(out)["q"][0] == -0.1


def test_evaluate_text_summary_for_a_person(capsys) -> None:
    code, out, _ = _run(["evaluate", "--model", "paper-robot", "--q", Q], capsys)
    assert code == 0
    assert "ellipsoid" in out and "θ_z" in out and "% less" in out


def test_evaluate_with_a_urdf_and_a_brace_at_a_link_point(capsys, tmp_path: Path) -> None:
    from bracekit.model.shipped import model_path

    code, out, _ = _run(
        [
            "evaluate",
            "--urdf",
            str(model_path("paper-robot")),
            "--tip",
            "tool",
            "--brace-link",
            "link6",
            "--brace-offset",
            "0,0,0.05",
            "--q",
            Q,
            "--json",
            "--stiffness",
            ",".join(["170"] * 11),
        ],
        capsys,
    )
    assert code == 0
    assert json.loads(out)["n1"] == 6


@pytest.mark.parametrize(
    ("args", "fragment"),
    [
        (["--urdf", "/no/such.urdf", "--tip", "tool", "--brace", "brace", "--q", "0"], "not found"),
        (["--model", "paper-robot", "--q", "0,1"], "11 values"),
        (["--model", "paper-robot", "--q", Q.replace("0.867", "nan")], "finite"),
        (["--model", "paper-robot", "--q", Q.replace("0.867", "x")], "numbers"),
        (["--model", "paper-robot", "--q", Q, "--stiffness", "0"], "positive"),
        (["--model", "paper-robot", "--q", Q, "--stiffness", "1,2"], "stiffnesses"),
        (["--model", "paper-robot", "--q", Q, "--normal", "0,0,0"], "normal"),
        (["--model", "paper-robot", "--q", Q, "--brace", "nowhere"], "unknown frame"),
        (["--model", "paper-robot", "--q", Q, "--brace", "tool"], "last link"),
        (["--model", "paper-robot", "--q", Q, "--brace", "base_link"], "base"),
        (["--model", "paper-robot", "--q", Q, "--contact", "glue"], "contact type"),
        (["--model", "robby", "--q", Q], "unknown model"),
    ],
)
def test_bad_input_gives_one_line_error_and_exit_code_2(capsys, args: list[str], fragment: str) -> None:
    code, out, err = _run(["evaluate", *args], capsys)
    assert code == 2
    assert out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("bracekit: error:") and fragment in lines[0]


def test_brace_link_works_with_a_shipped_model_and_negative_offsets(capsys) -> None:
    code, out, err = _run(
        [
            "evaluate",
            "--model",
            "paper-robot",
            "--q",
            Q,
            "--brace-link",
            "link3",
            "--brace-offset",
            "-0.1,0,0",
            "--json",
        ],
        capsys,
    )
    assert code == 0, err
    data = json.loads(out)
    assert data["n1"] == 3 and data["brace_frame"] == "brace_point"


def test_malformed_urdf_is_a_one_line_error(capsys, tmp_path: Path) -> None:
    bad = tmp_path / "bad.urdf"
    bad.write_text("<robot name='x'><link name='a'/><joint name='j' type='revolute'></robot>")
    code, _, err = _run(["evaluate", "--urdf", str(bad), "--tip", "a", "--brace", "a", "--q", "0"], capsys)
    assert code == 2 and len(err.strip().splitlines()) == 1


def test_usage_errors_exit_2_without_traceback() -> None:
    proc = subprocess.run([sys.executable, "-m", "bracekit", "evaluate", "--q"], capture_output=True, text=True)
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr
    proc = subprocess.run(
        [sys.executable, "-m", "bracekit", "run", "no-such-scenario", "--out", "x"], capture_output=True, text=True
    )
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1


def test_run_with_a_bad_scenario_leaves_no_output_folder(capsys, tmp_path: Path) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text('name = "x"\n[robot]\nmodel = "paper-robot"\n', encoding="utf-8")
    out = tmp_path / "out"
    code, _, err = _run(["run", str(bad), "--out", str(out), "--quiet"], capsys)
    assert code == 2 and "missing key 'brace'" in err
    assert not out.exists()


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


def test_help_lists_the_commands(capsys) -> None:
    with pytest.raises(SystemExit) as info:
        main(["--help"])
    assert info.value.code == 0
    out = capsys.readouterr().out
    for cmd in ("evaluate", "run", "validate", "bench"):
        assert cmd in out


def test_validate_json_has_the_required_keys(capsys, tmp_path: Path) -> None:
    out = tmp_path / "val"
    code, stdout, _ = _run(["validate", "paper", "--configs", "1", "--json", "--out", str(out)], capsys)
    assert code == 0
    data = json.loads(stdout)
    assert "cases" in data
    for model in ("constrained", "projection", "free_space"):
        for key in ("median_rel_err_mujoco", "max_rel_err_mujoco", "median_rel_err_static", "max_rel_err_static"):
            assert isinstance(data[model][key], float)
    assert data["constrained"]["median_rel_err_mujoco"] < 0.01
    assert (out / "validation.png").stat().st_size > 0 and (out / "validation.json").is_file()


def test_validate_rejects_zero_configurations(capsys) -> None:
    code, _, err = _run(["validate", "--configs", "0"], capsys)
    assert code == 2 and "--configs" in err


def test_study_ranks_bracing_points_and_reports_json(capsys) -> None:
    code, out, _ = _run(["study", "--model", "paper-robot", "--q", Q, "--points-per-link", "1", "--json"], capsys)
    assert code == 0
    cands = json.loads(out)["candidates"]
    assert 8 <= len(cands) <= 10
    assert [c["Ci_constrained"] for c in cands] == sorted(c["Ci_constrained"] for c in cands)
    code, out, _ = _run(["study", "--model", "paper-robot", "--q", Q], capsys)
    assert code == 0 and "best first" in out
