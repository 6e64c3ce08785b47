"""`bracekit place` refuses bad input with one line and exit 2, before any cluster starts or --out is made."""

from __future__ import annotations

from pathlib import Path

import pytest

from bracekit.cli.main import main


@pytest.mark.parametrize(
    ("argv", "words"),
    [
        (["no-such-spec"], "no spec or scenario"),
        (["paper-links", "--workers", "0"], "--workers"),
        (["paper-links", "--seeds", "0"], "--seeds"),
        (["paper-links", "--refine", "-1"], "--refine"),
        (["paper-links", "--seeds", "1000000"], "--seeds must be from 1 to 64"),
        (["paper-links", "--top", "1000000"], "--top must be from 1 to 64"),
        (["paper-links", "--radius", "-0.1"], "--radius must be a finite angle >= 0 rad"),
        (["paper-links", "--radius", "nan"], "--radius must be a finite angle >= 0 rad"),
    ],
)
def test_bad_input(tmp_path: Path, capsys: pytest.CaptureFixture[str], argv: list[str], words: str) -> None:
    out = tmp_path / "out"
    assert main(["place", *argv, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert words in err and "Traceback" not in err and len(err.splitlines()) == 1
    assert not out.exists()


def test_spec_with_other_axes(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    spec = tmp_path / "s.toml"
    spec.write_text('name = "s"\nbase = "paper"\n[axes]\nlink = ["link2"]\nstiffness = [100.0, 200.0]\n')
    out = tmp_path / "out"
    assert main(["place", str(spec), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert "stiffness" in err and len(err.splitlines()) == 1
    assert not out.exists()


def test_a_cobot_scenario_is_named_as_such(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    source = tmp_path / "k.toml"
    source.write_text('name = "k"\nscenario = "panda"\n[admittance]\nmass = 2.0\n')
    out = tmp_path / "out"
    assert main(["place", str(source), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert "`bracekit cobot` scenario" in err and "'base' = " not in err and len(err.splitlines()) == 1
    assert not out.exists()


WORKERS = """
import ctypes, glob, json, os, sys

def state():
    import numba, numpy
    found = glob.glob(os.path.join(os.path.dirname(numpy.__file__), "..", "numpy.libs", "libscipy_openblas*"))
    blas = getattr(ctypes.CDLL(found[0]), "scipy_openblas_get_num_threads64_", None) if found else None
    return {
        "numba": [os.environ.get("NUMBA_NUM_THREADS"), int(numba.config.NUMBA_NUM_THREADS)],
        "blas": None if blas is None else int(blas()),
        "parent": os.getppid(),
        "preloaded": "bracekit.studies.place.inner" in sys.modules,
    }

def openmp():  # OpenMP's thread counts seen by a task's thread (per thread: not what the event loop sees)
    from threadpoolctl import threadpool_info
    return [p["num_threads"] for p in threadpool_info() if p["user_api"] == "openmp"]

from bracekit.cli.place import _forked_workers
from bracekit.studies.place.workers import WorkerThreads
from bracekit.studies.sweep.engine import dask_client

with _forked_workers(), dask_client(1) as client:
    client.register_plugin(WorkerThreads())
    before = list(client.run(state).values())
    tasks = [client.submit(openmp, pure=False).result()]
    client.restart()
    after = list(client.run(state).values())
    tasks.append(client.submit(openmp, pure=False).result())
print(json.dumps({"before": before, "after": after, "pid": os.getpid(), "tasks": tasks}))
"""


@pytest.mark.slow
def test_forked_workers_take_their_threads_from_their_environment() -> None:
    """Each forked worker, and one the nanny restarts, has the workers' numba and BLAS settings, modules imported.

    In a fresh process, as the command (a test session may run numba's threads, and then spawns its workers).
    """
    import json
    import subprocess
    import sys

    from bracekit.studies.sweep.engine import WORKER_ENV

    out = subprocess.run([sys.executable, "-c", WORKERS], capture_output=True, text=True, check=True).stdout
    got = json.loads(out.splitlines()[-1])
    states = got["before"] + got["after"]
    assert len(states) == 2
    for state in states:
        assert state["numba"] == [WORKER_ENV["NUMBA_NUM_THREADS"], int(WORKER_ENV["NUMBA_NUM_THREADS"])]
        assert state["blas"] in (None, int(WORKER_ENV["OPENBLAS_NUM_THREADS"]))
        assert state["preloaded"] is True
        assert state["parent"] == got["pid"]  # forked by this process's nanny, not spawned through another
    for found in got["tasks"]:  # OpenMP's count is per thread: a task's own thread is limited too
        assert all(n == int(WORKER_ENV["OMP_NUM_THREADS"]) for n in found)


@pytest.mark.slow  # a new process (or a Dask cluster): seconds, in the slow group
def test_numba_threads_started_is_seen() -> None:
    """Started numba threads are seen (the workers are then spawned, not forked): in a fresh process."""
    import subprocess
    import sys

    code = (
        "import numba\nfrom bracekit.cli.place import _numba_threads_started as f\n"
        "before = f()\nnumba.set_num_threads(1)\nprint(before, f())\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.split() == ["False", "True"]
