"""The sweep on a separately started Dask scheduler and two `dask worker` processes on 127.0.0.1."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from bracekit.cli.main import main
from bracekit.studies.sweep.engine import run_sweep
from bracekit.studies.sweep.spec import load_spec

SRC = str(Path(__file__).resolve().parents[3] / "src")


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def env() -> dict[str, str]:
    out = dict(os.environ)
    out["PYTHONPATH"] = SRC + os.pathsep + out.get("PYTHONPATH", "")
    out["NUMBA_NUM_THREADS"] = "1"
    return out


def stop(procs: list[subprocess.Popen[bytes]]) -> None:
    for p in reversed(procs):
        if p.poll() is None:
            p.terminate()
    for p in reversed(procs):
        try:
            p.wait(timeout=15)
        except subprocess.TimeoutExpired:
            p.kill()
            p.wait()


@pytest.fixture
def cluster() -> Iterator[str]:
    """`dask scheduler` and 2 `dask worker --nthreads 1` processes; torn down whatever happens."""
    port = free_port()
    address = f"tcp://127.0.0.1:{port}"
    procs: list[subprocess.Popen[bytes]] = []
    quiet = {"stdout": subprocess.DEVNULL, "stderr": subprocess.DEVNULL}
    try:
        procs.append(
            subprocess.Popen(
                [
                    sys.executable,
                    "-m",
                    "distributed.cli.dask_scheduler",
                    "--host",
                    "127.0.0.1",
                    "--port",
                    str(port),
                    "--no-dashboard",
                ],
                env=env(),
                **quiet,
            )
        )
        for _ in range(2):
            procs.append(
                subprocess.Popen(
                    [
                        sys.executable,
                        "-m",
                        "distributed.cli.dask_worker",
                        address,
                        "--nthreads",
                        "1",
                        "--nworkers",
                        "1",
                        "--no-dashboard",
                        "--host",
                        "127.0.0.1",
                    ],
                    env=env(),
                    **quiet,
                )
            )
        from distributed import Client

        with Client(address, timeout=30) as client:
            client.wait_for_workers(2, timeout=60)
        yield address
    finally:
        stop(procs)


def test_a_separately_started_scheduler_gives_the_local_table(
    tiny_spec: Path, cluster: str, client2: Any, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    import pyarrow.parquet as pq

    out = tmp_path / "remote"
    assert main(["sweep", str(tiny_spec), "--out", str(out), "--scheduler", cluster, "--no-screen", "--quiet"]) == 0
    capsys.readouterr()
    local = run_sweep(load_spec(tiny_spec), tmp_path / "local", client2, screen=False)
    table = pq.read_table(out / "results.parquet").to_pylist()
    assert [r["candidate"] for r in table] == [r["candidate"] for r in local.rows]
    assert [{k: v for k, v in r.items() if k != "wall_s"} for r in table] == [
        {k: v for k, v in r.items() if k != "wall_s"} for r in local.rows
    ]
    assert (out / "table.md").read_text().startswith("# Sweep tiny")
    assert {"results.csv", "summary.json", "heatmap.png", "pareto.png"} <= {p.name for p in out.iterdir()}


def test_an_unreachable_scheduler_is_one_input_error() -> None:
    from bracekit.errors import InputError
    from bracekit.studies.sweep.engine import dask_client

    address = f"tcp://127.0.0.1:{free_port()}"
    with pytest.raises(InputError, match="cannot connect to the Dask scheduler") as info:
        with dask_client(scheduler=address, connect_timeout=1.0):
            pass
    assert "\n" not in str(info.value)


def test_sigterm_exits_130_and_keeps_the_finished_rows(tiny_spec: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "bracekit",
            "sweep",
            str(tiny_spec),
            "--out",
            str(out),
            "--workers",
            "1",
            "--no-screen",
            "--quiet",
        ],
        env=env(),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    rows = out / ".sweep" / "rows"
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and not (rows.is_dir() and any(rows.glob("*.json"))):
            time.sleep(0.05)
        assert rows.is_dir() and any(rows.glob("*.json")), "no row was saved"
        import psutil

        children = psutil.Process(proc.pid).children(recursive=True)  # the local cluster's worker processes
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=60)
    finally:
        stop([proc])
    kept = list(rows.glob("*.json"))
    if proc.returncode == 0:  # the sweep finished before the signal arrived
        pytest.skip("the sweep finished before SIGTERM")
    assert proc.returncode == 130, err.decode()
    assert "interrupted" in err.decode().splitlines()[-1]
    assert 1 <= len(kept) <= 4
    _, alive = psutil.wait_procs(children, timeout=15)
    assert not alive, "worker processes left running"
    assert not (out / "results.csv").exists()  # the final tables are written whole at the end only
