"""SIGTERM stops `bracekit place` in seconds however many seeds it was given (slow: a real local cluster).

512 inner optimisations (8 links × 64 seeds) on one worker take minutes; the tasks go to the cluster a few at a
time, so the interrupt cancels at most a few and the cluster closes at once. The reference: the wall clock from
the signal to the exit, exit code 130, no worker process left and nothing written.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow

SRC = str(Path(__file__).resolve().parents[3] / "src")


def test_sigterm_stops_a_large_placement_in_seconds(tmp_path: Path) -> None:
    import psutil

    out = tmp_path / "out"
    env = dict(os.environ, PYTHONPATH=SRC + os.pathsep + os.environ.get("PYTHONPATH", ""))
    argv = ["place", "paper-links", "--out", str(out), "--workers", "1", "--seeds", "64", "--no-figures"]
    proc = subprocess.Popen([sys.executable, "-m", "bracekit", *argv], env=env, stderr=subprocess.PIPE)
    try:
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and not psutil.Process(proc.pid).children(recursive=True):
            time.sleep(0.1)
        time.sleep(8.0)  # the cluster up, the inner level under way
        children = psutil.Process(proc.pid).children(recursive=True)
        assert children and proc.poll() is None, "the placement ended before the signal"
        sent = time.monotonic()
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=60)
        took = time.monotonic() - sent
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 130, err.decode()
    assert took < 15.0, f"{took:.1f} s from SIGTERM to exit"
    _, alive = psutil.wait_procs(children, timeout=15)
    assert not alive, "worker processes left running"
    assert not out.exists() or not any(out.iterdir())
