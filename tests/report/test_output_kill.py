"""Output folders under SIGKILL: killed before ANY file operation of a write, OUT holds the previous output or the
new one (never a mix, never a lost user file), and the next run recovers every leftover beside it."""

from __future__ import annotations

import json
import os
import signal
from collections.abc import Callable
from pathlib import Path

import pytest

from bracekit.report import folder
from bracekit.report.output import MANIFEST, atomic_directory, prepare_output

#: The file operations a write may do; the child is killed just before the n-th of them.
OPERATIONS = ("rename", "replace", "link", "unlink", "rmdir", "mkdir", "chmod")


def _state(out: Path) -> dict[str, bytes | None] | None:
    """Every entry under OUT (bytes of files, None for folders; the manifest as the files it lists), or None."""
    if not out.is_dir():
        return None
    state: dict[str, bytes | None] = {}
    for root, dirs, files in os.walk(out):
        for name in dirs:
            state[os.path.relpath(os.path.join(root, name), out)] = None
        for name in files:
            path = Path(root, name)
            rel = os.path.relpath(path, out)
            state[rel] = (
                json.dumps(sorted(json.loads(path.read_text())["files"])).encode()
                if rel == MANIFEST
                else path.read_bytes()
            )
    return state


def _killed_at(n: int, write: Callable[[], None], exchange: bool = True) -> bool:
    """Run `write` in a forked child that SIGKILLs itself before its n-th file operation; True if it finished.

    With `exchange` False the child has no atomic exchange (as on a file system without one): two renames.
    """
    pid = os.fork()
    if pid == 0:  # the child: count the operations, die at the n-th
        try:
            count = 0

            def counting(real: Callable[..., object]) -> Callable[..., object]:
                def op(*a: object, **k: object) -> object:
                    nonlocal count
                    count += 1
                    if count == n:
                        os.kill(os.getpid(), signal.SIGKILL)
                    return real(*a, **k)

                return op

            for name in OPERATIONS:
                setattr(os, name, counting(getattr(os, name)))
            folder.exchange = counting(folder.exchange if exchange else lambda a, b: False)  # type: ignore[assignment]
            write()
            os._exit(0)
        except BaseException:
            os._exit(3)
    _, status = os.waitpid(pid, 0)
    if os.WIFSIGNALED(status):
        assert os.WTERMSIG(status) == signal.SIGKILL
        return False
    assert os.WEXITSTATUS(status) == 0, "the write failed without being killed"
    return True


def _previous_output(out: Path, keep: tuple[str, ...]) -> None:
    with atomic_directory(out, command="test") as tmp:
        for name in ("summary.json", "table.md", "old.png"):
            (tmp / name).write_text(f"previous {name}")
    (out / "notes.txt").write_text("the user's notes")
    (out / "mine").mkdir()
    (out / "mine" / "data.csv").write_text("the user's data")
    (out / "linked.txt").symlink_to("notes.txt")
    if keep:
        (out / ".sweep" / "rows").mkdir(parents=True)
        (out / ".sweep" / "rows" / "abc.json").write_text('{"candidate": "abc"}')


def _new_output(out: Path, keep: tuple[str, ...]) -> Callable[[], None]:
    def write() -> None:
        with prepare_output(out, overwrite=True, files=("summary.json", "table.md", "new.png"), keep=keep) as plan:
            with atomic_directory(plan) as tmp:
                for name in ("summary.json", "table.md", "new.png"):
                    (tmp / name).write_text(f"new {name}")

    return write


@pytest.mark.parametrize("swap", ["exchange", "two renames"])
@pytest.mark.parametrize("case", ["users-files", "sweep-work-folder", "fresh"])
def test_a_kill_at_any_file_operation_leaves_a_whole_folder_and_the_next_run_recovers(
    tmp_path: Path, case: str, swap: str
) -> None:
    keep = (".sweep",) if case == "sweep-work-folder" else ()
    states: dict[int, dict[str, bytes | None] | None] = {}
    previous: dict[str, bytes | None] | None = None
    n = 0
    while True:
        n += 1
        assert n < 400, "the write never finished"
        root = tmp_path / f"k{n}"
        root.mkdir()
        out = root / "out"
        if case != "fresh":
            _previous_output(out, keep)
        previous = _state(out)
        finished = _killed_at(n, _new_output(out, keep), exchange=swap == "exchange")
        killed = _state(out)
        with prepare_output(out, overwrite=True, keep=keep):  # the next run: recovers first, under the lock
            states[n] = _state(out)
        if swap == "exchange" or killed is not None:  # OUT never missing with an atomic exchange
            assert states[n] == killed, f"recovery changed OUT after a kill at operation {n}"
        else:  # killed between the two renames: OUT missing for an instant, the previous output put back
            assert states[n] == previous, f"the previous output was not put back after a kill at operation {n}"
        recovered = states[n]
        assert sorted(p.name for p in root.iterdir()) == (["out"] if recovered is not None else []), n
        if finished:
            break
    new = states[n]
    assert new is not None and new != previous
    assert "new.png" in new and "old.png" not in new
    if previous is not None:
        for user in ("notes.txt", "mine", "mine/data.csv", "linked.txt"):
            assert new[user] == previous[user]
    bad = {k: sorted(set(s or {}) ^ set(new)) for k, s in states.items() if s not in (previous, new)}
    assert not bad, f"OUT was neither the previous output nor the new one after kills at: {bad}"
    assert n > (3 if case == "fresh" else 10)  # the write does many file operations; each one was a kill point


def test_sighup_cleans_up_like_ctrl_c(capsys, short_scenario_file: Path, tmp_path: Path, monkeypatch) -> None:
    import time

    from bracekit.cli.main import main
    from bracekit.report import output

    here = tmp_path / "here"
    here.mkdir()
    received: list[int] = []
    previous = signal.signal(signal.SIGHUP, lambda signum, _frame: received.append(signum))

    def hung_up(*_a, **_k):
        os.kill(os.getpid(), signal.SIGHUP)
        time.sleep(3)

    monkeypatch.setattr(output, "save_trajectories", hung_up)
    try:
        code = main(["run", str(short_scenario_file), "--out", str(here / "out"), "--no-figures", "--quiet"])
        err = capsys.readouterr().err
        assert code == 130 and "interrupted" in err and not received
        assert list(here.iterdir()) == []  # no output, no temporary folder, no lock
    finally:
        signal.signal(signal.SIGHUP, previous)
