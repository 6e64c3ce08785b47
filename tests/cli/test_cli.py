"""The command line's `evaluate` and help: JSON for scripts, one-line errors with exit code 2, no traceback; the numbers
against the library (bracekit.studies.evaluate, load_capacity) and Pinocchio's Jacobian.
"""

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


def _one_error_line(err: str, *fragments: str) -> None:
    """One error line (a run's warning lines, printed before it fails, are not errors)."""
    lines = [line for line in err.strip().splitlines() if not line.startswith("bracekit: warning:")]
    assert len(lines) == 1 and lines[0].startswith("bracekit: error:"), err
    assert "Traceback" not in err and all(f in lines[0] for f in fragments), lines[0]


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


def test_evaluate_statics_match_the_library_and_print_for_a_person(capsys) -> None:
    import bracekit as bk
    from bracekit.statics import load_capacity

    flags = [
        "--gravity",
        "--preload",
        "20",
        "--friction",
        "0.5",
        "--wrench",
        "0,0,-10,0,0,0",
        "--wrench",
        "10,0,0,0,0,0",
    ]
    code, out, _ = _run(["evaluate", "--model", "paper-robot", "--q", Q, *flags, "--json"], capsys)
    assert code == 0
    data = json.loads(out)
    robot = bk.load_model("paper-robot")
    braced = bk.BracedRobot(robot, bk.Brace("brace", bk.Surface(np.array(data["b"]), np.array([0.0, 0.0, 1.0]))))
    w = np.array([[0, 0, -10, 0, 0, 0], [10, 0, 0, 0, 0, 0]], dtype=float)
    cap = load_capacity(braced, np.array(data["q"]), w, preload=20.0, gravity=True, friction=0.5)
    assert data["slip"] == pytest.approx(list(cap.slip)) and data["torque"] == pytest.approx(list(cap.torque))
    assert data["slip_margin"] == pytest.approx(cap.slip_margin) and data["liftoff"] == [None, None]  # never lifts
    assert np.array(data["C_e_preloaded"]).shape == (6, 6) and len(data["tau0"]) == 11
    code, out, _ = _run(["evaluate", "--model", "paper-robot", "--q", Q, *flags], capsys)
    assert code == 0 and "statics: gravity on, preload 20 N, μ = 0.5" in out and "slip" in out


@pytest.mark.parametrize(
    ("flags", "match"),
    [
        (["--preload", "-1"], "preload"),
        (["--preload", "20,30"], "--preload"),
        (["--preload", "1e9"], "preload"),
        (["--wrench", "1,2"], "--wrench"),
        (["--friction", "x"], "--friction"),
        (["--friction", "0.5,0.7"], "--friction"),
    ],
)
def test_evaluate_refuses_bad_statics_flags_in_one_line(capsys, flags: list[str], match: str) -> None:
    code, _, err = _run(["evaluate", "--model", "paper-robot", "--q", Q, *flags], capsys)
    assert code == 2 and match in err and len(err.strip().splitlines()) == 1


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


def test_evaluate_with_a_urdf_of_continuous_joints(capsys, tmp_path: Path) -> None:
    import pinocchio as pin

    from helpers import continuous_chain_urdf, pin_frame_jacobian

    text, revolute = continuous_chain_urdf(7, seed=3, continuous=(1, 2, 4, 7))
    path = tmp_path / "continuous.urdf"
    path.write_text(text)
    q = [0.2, 4.0, -0.5, 0.3, -7.0, 0.4, 9.0]  # angles, some beyond ±π (joint 5, revolute, beyond its limits)
    args = ["evaluate", "--urdf", str(path), "--tip", "tip", "--brace-link", "l4", "--brace-offset", "0,0,0.05"]
    code, _, err = _run([*args, "--q", ",".join(map(str, q)), "--json"], capsys)
    assert code == 2 and "joint 5 (j5) = -7 is outside its limits [-3.14, 3.14]" in err
    code, out, _ = _run([*args, "--q", ",".join(map(str, q)), "--json", "--allow-outside-limits"], capsys)
    assert code == 0
    data = json.loads(out)
    assert len(data["q"]) == 7 and np.array(data["J"]).shape == (6, 7)
    np.testing.assert_allclose(data["J"], pin_frame_jacobian(pin.buildModelFromXML(revolute), "tip", q), atol=1e-12)


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


def test_help_lists_the_commands(capsys) -> None:
    with pytest.raises(SystemExit) as info:
        main(["--help"])
    assert info.value.code == 0
    out = capsys.readouterr().out
    for cmd in ("evaluate", "run", "validate", "bench"):
        assert cmd in out


def test_evaluate_with_two_brace_links_matches_the_library(capsys) -> None:
    from bracekit import load_model
    from bracekit.studies.evaluate import evaluate

    args = ["--brace-link", "link6", "--brace-offset", "0,0,0.05", "--brace-link", "link8", "--brace-offset"]
    args += ["-0.1,0,0", "--normal", "0,0,1", "--normal", "1,0,0"]
    code, out, err = _run(["evaluate", "--model", "paper-robot", "--q", Q, *args, "--json"], capsys)
    assert code == 0, err
    data = json.loads(out)
    robot = load_model("paper-robot").with_point_frames(
        [("brace_point", "link6", [0, 0, 0.05], None), ("brace_point_2", "link8", [-0.1, 0, 0], None)]
    )
    q = np.array([float(x) for x in Q.split(",")])
    ref = evaluate(robot, ["brace_point", "brace_point_2"], q, normal=[[0, 0, 1], [1, 0, 0]])
    assert [b["frame"] for b in data["braces"]] == ["brace_point", "brace_point_2"]
    assert np.allclose(data["C_e_constrained"], ref["C_e_constrained"], rtol=1e-12, atol=0)
    assert data["G_rank"] == 2 and data["G_dependent_rows"] == [] and data["C_e_projection"] is None
    assert np.allclose(data["braces"][1]["normal"], [1, 0, 0]) and "b" in data["braces"][0]


def test_evaluate_text_lists_each_brace(capsys) -> None:
    code, out, err = _run(
        ["evaluate", "--model", "paper-robot", "--q", Q, "--brace", "brace", "--brace", "flange"], capsys
    )
    assert code == 0, err
    assert "2 braces" in out and "'brace'" in out and "'flange'" in out and "rank 2" in out


@pytest.mark.parametrize(
    ("flags", "match"),
    [
        (["--brace", "brace", "--brace", "flange", "--normal", "0,0,1"], "one --normal per brace"),
        (["--brace", "brace", "--normal", "0,0,1", "--normal", "1,0,0"], "one --normal for the one brace"),
        (["--brace-link", "link6", "--brace-link", "link8", "--brace-offset", "0,0,0"], "one --brace-offset per"),
        (["--brace-link", "link6", "--brace-link", "link8", "--brace", "a"], "each --brace names one link point"),
        (["--brace", "brace", "--brace", "flange", "--preload", "-1"], "preload"),
        (["--brace", "brace", "--brace", "flange", "--normal", "0,1", "--normal", "0,0,1"], "3 numbers"),
    ],
)
def test_evaluate_refuses_mismatched_brace_flags_in_one_line(capsys, flags: list[str], match: str) -> None:
    code, out, err = _run(["evaluate", "--model", "paper-robot", "--q", Q, *flags], capsys)
    assert code == 2 and out == ""
    _one_error_line(err, match)
