"""Command-line reproductions of hostile or broken inputs: one line and the documented exit code, before any work."""

from __future__ import annotations

import dataclasses
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from bracekit.cli.main import main
from helpers import random_chain_urdf, scenario_text

Q = "0.0,0.194,-2.598,0.0,-0.737,-2.498,-1.898,3.142,2.106,2.438,0.867"
LONG = "a" * 300


def _run(argv: list[str], capsys) -> tuple[int, str, str]:
    code = main(argv)
    out, err = capsys.readouterr()
    return code, out, err


def _one_error_line(err: str, *fragments: str) -> None:
    lines = [line for line in err.strip().splitlines() if not line.startswith("bracekit: warning:")]
    assert len(lines) == 1 and lines[0].startswith("bracekit: error:") and "Traceback" not in err, err
    assert all(f in lines[0] for f in fragments), lines[0]


def test_a_deeply_nested_scenario_is_one_line(tmp_path: Path, capsys, no_simulation) -> None:
    path = tmp_path / "deep.toml"
    path.write_text("x = " + "[" * 100_000 + "]" * 100_000 + "\n")
    for command in (["run", str(path), "--out", str(tmp_path / "out")], ["validate", str(path)]):
        code, _, err = _run(command, capsys)
        assert code == 2
        _one_error_line(err, "deep.toml", "deeper than")


@pytest.mark.parametrize("command", ["run", "validate", "sweep", "view"])
def test_an_out_name_too_long_is_refused_before_any_work(
    command: str, tmp_path: Path, capsys, short_scenario_file: Path, no_simulation
) -> None:
    pytest.importorskip("mujoco") if command == "validate" else None
    out = str(tmp_path / LONG)
    argv = {
        "run": ["run", str(short_scenario_file), "--out", out, "--no-figures", "--quiet"],
        "validate": ["validate", str(short_scenario_file), "--out", out],
        "sweep": ["sweep", "paper-links", "--out", out, "--quiet", "--no-figures"],
        "view": ["view", out],
    }[command]
    code, _, err = _run(argv, capsys)
    assert code == 2
    _one_error_line(err)
    assert "too long" in err or "at most" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["short.toml"]


@pytest.mark.parametrize(
    "argv",
    [
        ["evaluate", "--model", "paper-robot", "--q", Q, "--json"],
        ["study", "--model", "paper-robot", "--q", Q, "--json", "--points-per-link", "1"],
    ],
    ids=["evaluate", "study"],
)
def test_json_into_a_full_device_is_one_line(argv: list[str]) -> None:
    if not os.path.exists("/dev/full"):
        pytest.skip("no /dev/full here")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    with open("/dev/full", "w") as full:
        proc = subprocess.run(
            [sys.executable, "-m", "bracekit", *argv], stdout=full, stderr=subprocess.PIPE, text=True, env=env
        )
    assert proc.returncode == 2, proc.stderr
    _one_error_line(proc.stderr, "cannot write the output", "No space left")


def test_a_far_brace_offset_is_one_line(tmp_path: Path, capsys, no_simulation) -> None:
    text = scenario_text(turns=0.05, dt=0.1).replace(
        'frame = "brace"', 'frame = "pad"\nlink = "link6"\noffset = [1e300, 0.0, 0.0]'
    )
    path = tmp_path / "far.toml"
    path.write_text(text)
    code, _, err = _run(["run", str(path), "--out", str(tmp_path / "out")], capsys)
    assert code == 2
    _one_error_line(err, "offset", "beyond")


@pytest.mark.parametrize("mass", ["nan", "inf", "-5", "1e300"])
def test_a_bad_urdf_mass_is_one_line_naming_the_link(tmp_path: Path, capsys, mass: str) -> None:
    path = tmp_path / "robot.urdf"
    path.write_text(
        random_chain_urdf(5, seed=1, brace_link=3).replace('<mass value="0.5"/>', f'<mass value="{mass}"/>')
    )
    argv = ["evaluate", "--urdf", str(path), "--tip", "tip", "--brace", "brace", "--q", "0,0,0,0,0", "--gravity"]
    code, _, err = _run(argv, capsys)
    assert code == 2
    _one_error_line(err, "link 'l1'", "mass")


@pytest.mark.parametrize("value", ["10", "1e308", "-4"])
@pytest.mark.parametrize("command", ["evaluate", "study"])
def test_joint_values_outside_the_limits_are_refused_unless_allowed(capsys, command: str, value: str) -> None:
    q = Q.split(",")
    q[2] = value  # joint 3 of the paper robot
    argv = [command, "--model", "paper-robot", "--q", ",".join(q), "--json"]
    argv += ["--points-per-link", "1"] if command == "study" else []
    code, _, err = _run(argv, capsys)
    assert code == 2
    _one_error_line(err, "joint 3", "outside its limits", "--allow-outside-limits")
    if value == "10":  # allowed on request: the model is still computed there
        code, out, err = _run([*argv, "--allow-outside-limits"], capsys)
        assert code == 0 and out.strip().startswith("{"), err


def test_too_many_wrenches_are_refused_at_once(tmp_path: Path, capsys, no_simulation) -> None:
    rows = ", ".join(["[0.0, 0.0, -1.0, 0.0, 0.0, 0.0]"] * 400)
    text = scenario_text(turns=0.05, dt=0.1) + f"\n[loads]\nwrenches = [{rows}]\n"
    path = tmp_path / "loads.toml"
    path.write_text(text)
    began = time.perf_counter()
    code, _, err = _run(["run", str(path), "--out", str(tmp_path / "out")], capsys)
    assert code == 2 and time.perf_counter() - began < 5.0
    _one_error_line(err, "wrenches", "at most 32")
    argv = ["evaluate", "--model", "paper-robot", "--q", Q]
    for _ in range(40):
        argv += ["--wrench", "0,0,-1,0,0,0"]
    code, _, err = _run(argv, capsys)
    assert code == 2
    _one_error_line(err, "--wrench", "at most 32")


def test_a_failed_run_of_any_model_is_named_on_stderr(
    tmp_path: Path, capsys, short_scenario_file: Path, monkeypatch
) -> None:
    import bracekit.simulation.run as sim

    real = sim.run_scenario

    def projection_fails(*a, **k):
        result = real(*a, **k)
        runs = result.trajectories["projection"]
        name = "braced_gradient_projection"
        runs[name] = dataclasses.replace(runs[name], completed=False, failure="SingularityError: J1 is singular")
        return result

    monkeypatch.setattr(sim, "run_scenario", projection_fails)
    code, _, err = _run(
        ["run", str(short_scenario_file), "--out", str(tmp_path / "out"), "--no-figures", "--quiet"], capsys
    )
    assert code == 1
    assert "braced_gradient_projection (projection model) did not complete: SingularityError: J1 is singular" in err


def test_a_read_only_out_is_found_before_the_simulation(
    tmp_path: Path, capsys, short_scenario_file: Path, monkeypatch, no_simulation
) -> None:
    out = tmp_path / "out"
    out.mkdir()
    if os.geteuid() == 0:  # root writes anywhere: ask the permission check as for any other user
        access = os.access
        monkeypatch.setattr(os, "access", lambda p, mode, **k: False if Path(p) == out else access(p, mode, **k))
    else:
        out.chmod(0o555)
    try:
        code, _, err = _run(["run", str(short_scenario_file), "--out", str(out), "--no-figures"], capsys)
    finally:
        out.chmod(0o755)
    assert code == 2
    _one_error_line(err, "not writable")
