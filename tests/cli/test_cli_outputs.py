"""The command line's output folders: written whole or not at all, a user's files never deleted or replaced, a second
run or a signal leaving nothing behind; against the folder's listing and bytes before and after.
"""

from __future__ import annotations

import json
import os
from contextlib import nullcontext
from pathlib import Path

import pytest
from test_cli import _one_error_line, _run

from bracekit.cli.main import main


def test_run_with_a_bad_scenario_leaves_no_output_folder(capsys, tmp_path: Path) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text('name = "x"\n[robot]\nmodel = "paper-robot"\n', encoding="utf-8")
    out = tmp_path / "out"
    code, _, err = _run(["run", str(bad), "--out", str(out), "--quiet"], capsys)
    assert code == 2 and "missing key 'brace'" in err
    assert not out.exists()


# --- output folders: whole or absent, nothing of the user's touched ------------------------------
def _leftovers(out: Path) -> list[str]:
    return sorted(p.name for p in out.parent.iterdir() if p.name.startswith(f".{out.name}."))


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
