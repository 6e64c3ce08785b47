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


def _worker_state() -> dict[str, object]:
    """What a worker holds before any task: numba's thread setting, BLAS's threads, its parent, the modules."""
    import ctypes
    import glob
    import os
    import sys

    import numba
    import numpy

    found = glob.glob(os.path.join(os.path.dirname(numpy.__file__), "..", "numpy.libs", "libscipy_openblas*"))
    blas = getattr(ctypes.CDLL(found[0]), "scipy_openblas_get_num_threads64_", None) if found else None
    return {
        "numba": (os.environ.get("NUMBA_NUM_THREADS"), int(numba.config.NUMBA_NUM_THREADS)),
        "blas": None if blas is None else int(blas()),
        "parent": os.getppid(),
        "preloaded": "bracekit.studies.place.inner" in sys.modules,
    }


@pytest.mark.slow
def test_workers_are_forked_from_a_server_in_their_own_environment() -> None:
    """Each worker, and one the nanny restarts, has the workers' numba and BLAS settings and the modules imported.

    Not forked from this process (a lock another thread held, this process's settings), but from the fork
    server, which imported the placement's modules once.
    """
    import os

    from bracekit.cli.place import _forked_workers
    from bracekit.studies.sweep.engine import WORKER_ENV, dask_client

    one = int(WORKER_ENV["NUMBA_NUM_THREADS"])
    with _forked_workers(), dask_client(1) as client:
        before = list(client.run(_worker_state).values())
        client.restart()
        after = list(client.run(_worker_state).values())
    for state in before + after:
        assert state["numba"] == (WORKER_ENV["NUMBA_NUM_THREADS"], one)
        assert state["blas"] in (None, int(WORKER_ENV["OPENBLAS_NUM_THREADS"]))
        assert state["preloaded"] is True
        assert state["parent"] != os.getpid()
    assert before[0]["parent"] == after[0]["parent"]  # the same server
