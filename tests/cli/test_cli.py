"""The command line: JSON for scripts, one-line errors with exit code 2, no traceback, whole outputs."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from contextlib import nullcontext
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


# --- output folders: whole or absent, nothing of the user's touched ------------------------------
def _leftovers(out: Path) -> list[str]:
    return sorted(p.name for p in out.parent.iterdir() if p.name.startswith(f".{out.name}."))


def _one_error_line(err: str, *fragments: str) -> None:
    """One error line (a run's warning lines, printed before it fails, are not errors)."""
    lines = [line for line in err.strip().splitlines() if not line.startswith("bracekit: warning:")]
    assert len(lines) == 1 and lines[0].startswith("bracekit: error:"), err
    assert "Traceback" not in err and all(f in lines[0] for f in fragments), lines[0]


def _run_out(out: Path, scenario: Path, capsys, *extra: str) -> tuple[int, str, str]:
    return _run(["run", str(scenario), "--out", str(out), "--no-figures", "--quiet", *extra], capsys)


def test_a_no_figures_run_keeps_a_users_animation_gif(capsys, short_scenario_file: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    out.mkdir()
    (out / "animation.gif").write_bytes(b"GIF89a mine")
    code, stdout, err = _run_out(out, short_scenario_file, capsys)
    assert code == 2 and stdout == ""
    _one_error_line(err, "did not write: animation.gif", "--overwrite")
    assert sorted(p.name for p in out.iterdir()) == ["animation.gif"]
    code, _, err = _run_out(out, short_scenario_file, capsys, "--overwrite")
    assert code == 0, err
    assert (out / "animation.gif").read_bytes() == b"GIF89a mine" and (out / "summary.json").is_file()
    code, _, err = _run_out(out, short_scenario_file, capsys, "--overwrite")  # a re-run keeps it too
    assert code == 0 and (out / "animation.gif").read_bytes() == b"GIF89a mine"
    assert _leftovers(out) == []


def test_a_rerun_replaces_the_previous_output_whole(capsys, short_scenario_file: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    assert _run_out(out, short_scenario_file, capsys)[0] == 0
    before = {p.name: p.stat().st_ino for p in out.iterdir()}
    code, _, err = _run_out(out, short_scenario_file, capsys)
    assert code == 0, err
    after = {p.name: p.stat().st_ino for p in out.iterdir()}
    assert after.keys() == before.keys() and all(after[n] != before[n] for n in after)  # every file new
    assert _leftovers(out) == []


def test_a_manifest_edited_to_list_a_users_file_never_deletes_it(
    capsys, short_scenario_file: Path, tmp_path: Path
) -> None:
    out = tmp_path / "out"
    assert _run_out(out, short_scenario_file, capsys)[0] == 0
    (out / "fig2_film_strip.png").write_bytes(b"mine")  # listed below, but bracekit recorded no hash of it
    manifest = json.loads((out / ".bracekit-output.json").read_text())
    manifest["files"].append("fig2_film_strip.png")
    manifest["sha256"]["table.md"] = "0" * 64  # and table.md edited: no longer bracekit's either
    (out / ".bracekit-output.json").write_text(json.dumps(manifest))
    code, _, err = _run_out(out, short_scenario_file, capsys)
    assert code == 2
    _one_error_line(err, "fig2_film_strip.png", "did not write")
    code, _, err = _run_out(out, short_scenario_file, capsys, "--overwrite")
    assert code == 2  # table.md is not bracekit's now, and bracekit never replaces it
    _one_error_line(err, "table.md", "never replaces")
    (out / "table.md").unlink()
    code, _, err = _run_out(out, short_scenario_file, capsys, "--overwrite")
    assert code == 0, err
    assert (out / "fig2_film_strip.png").read_bytes() == b"mine" and (out / "trajectories.npz").is_file()
    assert _leftovers(out) == []


def test_a_folder_named_like_an_output_is_refused_and_the_old_output_kept(
    capsys, short_scenario_file: Path, tmp_path: Path, no_simulation
) -> None:
    out = tmp_path / "out"
    out.mkdir()
    (out / "table.md").mkdir()
    (out / "table.md" / "mine.txt").write_text("mine")
    for extra in ((), ("--overwrite",)):
        code, _, err = _run_out(out, short_scenario_file, capsys, *extra)
        assert code == 2
        _one_error_line(err, "table.md/")
        assert (out / "table.md" / "mine.txt").read_text() == "mine" and [p.name for p in out.iterdir()] == ["table.md"]


def test_a_failed_replace_exits_2_and_keeps_the_previous_output(
    capsys, short_scenario_file: Path, tmp_path: Path, monkeypatch
) -> None:
    out = tmp_path / "out"
    assert _run_out(out, short_scenario_file, capsys)[0] == 0
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    rename = os.rename

    def failing(src, dst, *a, **k):  # e.g. a read-only parent: moving the new folder in fails
        if ".out.tmp-" in str(src):
            raise PermissionError(13, "Permission denied", str(dst))
        return rename(src, dst, *a, **k)

    monkeypatch.setattr(os, "rename", failing)
    code, _, err = _run_out(out, short_scenario_file, capsys)
    assert code == 2
    _one_error_line(err, "cannot", "unchanged")
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before and _leftovers(out) == []


def test_two_runs_into_one_folder_one_wins_whole_the_other_exits_2(
    capsys, short_scenario_file: Path, tmp_path: Path, monkeypatch
) -> None:
    import threading

    import bracekit.simulation.run as sim

    out = tmp_path / "out"
    real = sim.run_scenario
    simulating, second_done = threading.Event(), threading.Event()

    def slow(*a, **k):
        if threading.current_thread() is not threading.main_thread():  # the first run waits for the second
            simulating.set()
            assert second_done.wait(10)
        return real(*a, **k)

    monkeypatch.setattr(sim, "run_scenario", slow)
    codes: list[int] = []
    first = threading.Thread(
        target=lambda: codes.append(
            main(["run", str(short_scenario_file), "--out", str(out), "--no-figures", "--quiet"])
        )
    )
    first.start()
    try:
        assert simulating.wait(10)
        code, _, err = _run_out(out, short_scenario_file, capsys)
    finally:
        second_done.set()
        first.join(20)
    assert code == 2 and codes == [0]
    assert "another bracekit process" in err and "Traceback" not in err
    manifest = json.loads((out / ".bracekit-output.json").read_text())
    assert sorted(p.name for p in out.iterdir()) == sorted([".bracekit-output.json", *manifest["files"]])
    assert _leftovers(out) == []


def test_sigterm_cleans_up_like_ctrl_c(capsys, short_scenario_file: Path, tmp_path: Path, monkeypatch) -> None:
    import signal
    import time

    from bracekit.report import output

    here = tmp_path / "here"
    here.mkdir()
    out = here / "new" / "out"
    received: list[int] = []

    def record(signum, _frame) -> None:  # so that a SIGTERM the command does not handle never ends pytest
        received.append(signum)

    previous = signal.signal(signal.SIGTERM, record)

    def killed(*_a, **_k):
        os.kill(os.getpid(), signal.SIGTERM)
        time.sleep(3)

    monkeypatch.setattr(output, "save_trajectories", killed)
    start = time.perf_counter()
    code, _, err = _run_out(out, short_scenario_file, capsys)
    try:
        assert code == 130 and "interrupted" in err and time.perf_counter() - start < 2.5 and not received
        assert list(here.iterdir()) == []  # no output, no temporary folder, no lock, no parent made for it
        assert signal.getsignal(signal.SIGTERM) is record  # the handler before the command is back
    finally:
        signal.signal(signal.SIGTERM, previous)


@pytest.mark.parametrize("case", ["file", "current", "users", "busy"])
def test_a_bad_out_is_refused_before_any_computation(
    capsys, short_scenario_file: Path, tmp_path: Path, monkeypatch, no_simulation, case: str
) -> None:
    from bracekit.report.output import prepare_output

    monkeypatch.chdir(tmp_path)
    out = tmp_path / "out"
    if case == "file":
        out.write_text("mine")
    elif case == "current":
        out = Path(".")
    elif case == "users":
        out.mkdir()
        (out / "a.txt").write_text("mine")
    fragment = {"file": "not a folder", "current": "named folder", "users": "a.txt", "busy": "another bracekit"}[case]
    with prepare_output(tmp_path / "out") if case == "busy" else nullcontext():
        for command in (["run", str(short_scenario_file)], ["validate", str(short_scenario_file)]):
            code, stdout, err = _run(
                [*command, "--out", str(out), "--quiet" if command[0] == "run" else "--json"], capsys
            )
            assert code == 2 and stdout == ""
            _one_error_line(err, fragment)


def test_help_says_overwrite_never_deletes_other_files(capsys) -> None:
    with pytest.raises(SystemExit):
        main(["run", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "--overwrite" in text and "never deleted" in text


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
