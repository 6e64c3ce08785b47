"""The command line's early end of its process (`bracekit.cli.main._end_process`) against Python's ordinary exit."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

SRC = str(Path(__file__).resolve().parents[2] / "src")

PROGRAM = """
import atexit, sys, threading, time
from bracekit.cli.main import _end_process
atexit.register(lambda: print("exit handler ran"))
if {thread}:
    threading.Thread(target=lambda: (time.sleep(0.3), print("thread done"))).start()
print("buffered", end="")
sys.stderr.write("to stderr")
{end}(3)
print(" after")
"""


def _run(end: str, thread: bool) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "PYTHONPATH": SRC}
    code = PROGRAM.format(end=end, thread=thread)
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120)


@pytest.mark.slow  # a new process (or a Dask cluster): seconds, in the slow group
def test_ends_like_the_ordinary_exit() -> None:
    """The same output, error output and status as sys.exit, the exit handlers run."""
    ours, ordinary = _run("_end_process", False), _run("sys.exit", False)
    assert ours.returncode == ordinary.returncode == 3
    assert ours.stdout == ordinary.stdout == "bufferedexit handler ran\n"
    assert ours.stderr == ordinary.stderr == "to stderr"


@pytest.mark.slow  # a new process (or a Dask cluster): seconds, in the slow group
def test_returns_while_a_thread_python_waits_for_runs() -> None:
    """A non-daemon thread still running: it returns, and the ordinary exit waits for the thread."""
    ours = _run("_end_process", True)
    assert ours.returncode == 0
    assert ours.stdout == "buffered after\nthread done\nexit handler ran\n"


@pytest.mark.slow
def test_place_from_the_console_ends_with_its_outputs_whole(tmp_path: Path) -> None:
    """`python -m bracekit place` (its process ended at once): status 0, the printed table the written one."""
    out = tmp_path / "P"
    argv = ["place", "paper-links", "--out", str(out), "--workers", "1", "--top", "1", "--refine", "0", "--no-figures"]
    env = {**os.environ, "PYTHONPATH": SRC}
    done = subprocess.run(
        [sys.executable, "-m", "bracekit", *argv], capture_output=True, text=True, env=env, timeout=600
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout == (out / "table.md").read_text()
    assert {"best.toml", "summary.json", "evaluations.parquet", "table.csv"} <= {p.name for p in out.iterdir()}
    assert done.stderr.endswith(f"run the best place: bracekit run {out}/best.toml --out DIR\n")


@pytest.mark.slow  # a new process: seconds, in the slow group
def test_a_command_started_with_its_output_closed_ends_without_a_traceback(tmp_path: Path) -> None:
    """Standard output closed at the start (Python's sys.stdout is None): the command's files, status 0, no traceback.

    Reference: the same command with its output open writes the same files.
    """
    env = {**os.environ, "PYTHONPATH": SRC}
    argv = [sys.executable, "-m", "bracekit", "run", "paper", "--no-figures", "--quiet"]
    closed = subprocess.run(
        [*argv, "--out", str(tmp_path / "closed")], stdout=None, stderr=subprocess.PIPE, text=True, env=env,
        timeout=600, pass_fds=(), preexec_fn=lambda: os.close(1),
    )  # fmt: skip
    assert closed.returncode == 0, closed.stderr
    assert "Traceback" not in closed.stderr
    opened = subprocess.run([*argv, "--out", str(tmp_path / "open")], capture_output=True, env=env, timeout=600)
    assert opened.returncode == 0
    names = [sorted(p.name for p in (tmp_path / d).iterdir()) for d in ("closed", "open")]
    assert names[0] == names[1]
