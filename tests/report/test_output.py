"""Output folders: whole or absent, marked with a manifest, locked, and never touching a file bracekit did not write."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from bracekit import InputError
from bracekit.errors import OutputError
from bracekit.report import output as out_mod
from bracekit.report.output import MANIFEST, atomic_directory, prepare_output


def _write(out: Path | out_mod.OutputPlan, files: dict[str, str], **kw) -> None:
    with atomic_directory(out, **kw) as tmp:
        for name, text in files.items():
            (tmp / name).write_text(text)


def _snapshot(folder: Path) -> dict[str, bytes | None]:
    """Every entry of a folder: file bytes, or None for a folder."""
    return {p.name: (p.read_bytes() if p.is_file() else None) for p in sorted(folder.iterdir())}


def _siblings(out: Path) -> list[str]:
    """Names beside OUT that bracekit made (temporary folders, backups, lock)."""
    return sorted(p.name for p in out.parent.iterdir() if p.name.startswith(f".{out.name}."))


def _dead_pid() -> int:
    proc = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    return int(proc.stdout)


def test_a_new_folder_holds_the_files_and_a_manifest(tmp_path: Path) -> None:
    out = tmp_path / "out"
    _write(out, {"a.txt": "1", "b.txt": "2"}, command="test")
    assert sorted(p.name for p in out.iterdir()) == [MANIFEST, "a.txt", "b.txt"]
    manifest = json.loads((out / MANIFEST).read_text())
    assert manifest["files"] == ["a.txt", "b.txt"] and manifest["command"] == "test"
    assert manifest["written_by"] == "bracekit" and manifest["version"]
    assert _siblings(out) == []


def test_folders_follow_the_umask(tmp_path: Path) -> None:
    old = os.umask(0o027)
    try:
        out = tmp_path / "deep" / "out"
        _write(out, {"a.txt": "1"})
        assert (out.stat().st_mode & 0o777) == 0o750
        assert (out.parent.stat().st_mode & 0o777) == 0o750
        assert ((out / "a.txt").stat().st_mode & 0o777) == 0o640
        _write(out, {"a.txt": "2"})  # a replaced output too
        assert (out.stat().st_mode & 0o777) == 0o750
    finally:
        os.umask(old)


def test_a_previous_output_is_replaced_whole(tmp_path: Path) -> None:
    out = tmp_path / "out"
    _write(out, {"a.txt": "old", "fig.png": "old"})
    _write(out, {"a.txt": "new"})
    assert _snapshot(out).keys() == {MANIFEST, "a.txt"} and (out / "a.txt").read_text() == "new"
    assert _siblings(out) == []


def test_an_empty_folder_is_replaced_whole_and_keeps_its_permissions(tmp_path: Path) -> None:
    # swapped in whole like any output (never filled file by file), with the user's permissions on OUT
    out = tmp_path / "out"
    out.mkdir(mode=0o700)
    _write(out, {"a.txt": "1"})
    assert (out.stat().st_mode & 0o777) == 0o700
    assert (out / "a.txt").read_text() == "1" and _siblings(out) == []


@pytest.mark.parametrize("manifest", [None, "not json", '{"written_by": "bracekit", "files": ["../a.txt"]}'])
def test_a_folder_with_files_bracekit_did_not_write_is_refused_and_untouched(tmp_path: Path, manifest) -> None:
    out = tmp_path / "out"
    out.mkdir()
    (out / "a.txt").write_text("mine")
    if manifest is not None:
        (out / MANIFEST).write_text(manifest)
    before = _snapshot(out)
    with pytest.raises(OutputError, match=r"holds files bracekit did not write: .*a\.txt.*overwrite=True"):
        _write(out, {"b.txt": "new"})
    assert _snapshot(out) == before and _siblings(out) == []
    assert not (tmp_path / "a.txt").exists()


def test_overwrite_replaces_bracekits_files_and_keeps_the_others(tmp_path: Path) -> None:
    out = tmp_path / "out"
    _write(out, {"summary.json": "old", "fig.png": "old"})
    (out / "notes.txt").write_text("mine")
    (out / "mine").mkdir()
    _write(out, {"summary.json": "new"}, overwrite=True)
    assert sorted(p.name for p in out.iterdir()) == [MANIFEST, "mine", "notes.txt", "summary.json"]
    assert (out / "summary.json").read_text() == "new" and (out / "notes.txt").read_text() == "mine"
    assert json.loads((out / MANIFEST).read_text())["files"] == ["summary.json"]
    assert _siblings(out) == []


@pytest.mark.parametrize("kind", ["file", "folder"])
def test_a_user_file_named_like_an_output_is_never_replaced(tmp_path: Path, kind: str) -> None:
    out = tmp_path / "out"
    _write(out, {"summary.json": "old"})
    if kind == "file":
        (out / "animation.gif").write_bytes(b"GIF89a mine")
    else:
        (out / "animation.gif").mkdir()
    before = _snapshot(out)
    for overwrite in (False, True):
        with pytest.raises(OutputError, match=r"animation\.gif"):
            _write(out, {"summary.json": "new", "animation.gif": "new"}, overwrite=overwrite)
        assert _snapshot(out) == before and _siblings(out) == []


@pytest.mark.parametrize("how", ["exchange", "two renames"])
def test_a_failed_swap_leaves_the_previous_output_intact(tmp_path: Path, monkeypatch, how: str) -> None:
    from bracekit.report import folder

    out = tmp_path / "out"
    _write(out, {"a.txt": "old", "b.txt": "old"})
    before = _snapshot(out)
    rename = os.rename

    def failing(src, dst, *a, **k):
        if ".out.new-" in str(src) and Path(dst) == out:
            raise PermissionError(13, "Permission denied", str(dst))
        return rename(src, dst, *a, **k)

    def no_exchange(a, b):
        if how == "exchange":
            raise PermissionError(13, "Permission denied", str(b))
        return False  # a file system without an atomic exchange: OUT moved aside, the new one moved in

    monkeypatch.setattr(folder, "exchange", no_exchange)
    monkeypatch.setattr(os, "rename", failing)
    with pytest.raises(OutputError, match="previous output is unchanged"):
        _write(out, {"a.txt": "new"})
    assert _snapshot(out) == before and _siblings(out) == []


def test_a_failed_move_into_a_shared_folder_puts_everything_back(tmp_path: Path, monkeypatch) -> None:
    out = tmp_path / "out"
    _write(out, {"a.txt": "old", "b.txt": "old", "c.txt": "old"})
    (out / "notes.txt").write_text("mine")
    before = _snapshot(out)
    link = os.link

    def failing(src, dst, *a, **k):  # the user's file cannot be carried into the new output
        if Path(src) == out / "notes.txt":
            raise OSError(31, "Too many links", str(dst))
        return link(src, dst, *a, **k)

    monkeypatch.setattr(os, "link", failing)
    with pytest.raises(OutputError, match="nothing was changed"):
        _write(out, {"a.txt": "new", "b.txt": "new"}, overwrite=True)
    assert _snapshot(out) == before and _siblings(out) == []


def test_a_failure_while_writing_removes_everything_made_for_it(tmp_path: Path) -> None:
    with pytest.raises(RuntimeError), atomic_directory(tmp_path / "a" / "b" / "out") as tmp:
        (tmp / "x.txt").write_text("1")
        raise RuntimeError("boom")
    assert list(tmp_path.iterdir()) == []


def test_one_writer_at_a_time(tmp_path: Path) -> None:
    out = tmp_path / "out"
    with prepare_output(out) as plan:
        assert (tmp_path / ".out.lock").read_text().strip() == str(os.getpid())
        with pytest.raises(OutputError, match=rf"another bracekit process \(pid {os.getpid()}\) is writing to"):
            prepare_output(out)
        _write(plan, {"a.txt": "1"})
        with pytest.raises(OutputError, match="used up"):
            _write(plan, {"a.txt": "2"})
    assert _siblings(out) == []
    _write(out, {"a.txt": "3"})
    assert (out / "a.txt").read_text() == "3"


def test_leftovers_of_dead_processes_are_removed_and_a_live_ones_kept(tmp_path: Path) -> None:
    out = tmp_path / "out"
    _write(out, {"a.txt": "1"})
    dead, live = _dead_pid(), os.getppid()
    (tmp_path / f".out.tmp-{dead}-0123abcd").mkdir()
    (tmp_path / f".out.tmp-{dead}-0123abcd" / "a.txt").write_text("partial")
    (tmp_path / f".out.old-{dead}-0123abcd").mkdir()
    (tmp_path / f".out.tmp-{live}-0123abcd").mkdir()
    (tmp_path / f".other.tmp-{dead}-0123abcd").mkdir()
    (tmp_path / ".out.lock").write_text(f"{dead}\n")  # a killed run's lock file is taken over
    _write(out, {"a.txt": "2"})
    assert _siblings(out) == [f".out.tmp-{live}-0123abcd"]
    assert (tmp_path / f".other.tmp-{dead}-0123abcd").is_dir()


def test_an_output_moved_aside_by_a_killed_run_is_put_back(tmp_path: Path) -> None:
    out = tmp_path / "out"
    _write(out, {"a.txt": "old"})
    aside = tmp_path / f".out.old-{_dead_pid()}-0123abcd"
    out.rename(aside)
    with prepare_output(out):
        assert (out / "a.txt").read_text() == "old" and not aside.exists()


def test_a_symbolic_link_to_a_folder_is_written_through(tmp_path: Path) -> None:
    real = tmp_path / "real"
    _write(real, {"a.txt": "old"})
    link = tmp_path / "link"
    link.symlink_to(real)
    _write(link, {"a.txt": "new"})
    assert link.is_symlink() and (link / "a.txt").read_text() == "new"


@pytest.mark.parametrize("bad", ["", ".", "..", "file"])
def test_bad_folders_are_input_errors_and_nothing_is_made(tmp_path: Path, monkeypatch, bad: str) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "file").write_text("mine")
    with pytest.raises(InputError):
        prepare_output(bad)
    assert [p.name for p in tmp_path.iterdir()] == ["file"]


def test_write_run_refuses_a_shared_folder_unless_overwrite(tmp_path: Path, short_scenario_file: Path) -> None:
    from bracekit import load_scenario, run_scenario
    from bracekit.report import write_run

    result = run_scenario(load_scenario(short_scenario_file))
    out = tmp_path / "out"
    out.mkdir()
    (out / "animation.gif").write_bytes(b"GIF89a mine")
    with pytest.raises(OutputError, match=r"animation\.gif"):
        write_run(result, out, figures=False)
    written = write_run(result, out, figures=False, overwrite=True)
    assert [p.name for p in written] == list(out_mod.run_files(figures=False))
    assert (out / "animation.gif").read_bytes() == b"GIF89a mine" and (out / "summary.json").is_file()


@pytest.mark.parametrize("target", ["missing", "empty", "digits"])
def test_a_lock_file_that_is_a_link_is_refused_and_its_target_untouched(tmp_path: Path, target: str) -> None:
    elsewhere = tmp_path / "elsewhere" / "victim"
    elsewhere.parent.mkdir()
    if target != "missing":
        elsewhere.write_text("" if target == "empty" else "123\n")
    before = elsewhere.read_bytes() if elsewhere.exists() else None
    (tmp_path / ".out.lock").symlink_to(elsewhere)
    with pytest.raises(OutputError, match="symbolic link"):
        prepare_output(tmp_path / "out")
    assert (elsewhere.read_bytes() if elsewhere.exists() else None) == before
    assert not (tmp_path / "out").exists()
