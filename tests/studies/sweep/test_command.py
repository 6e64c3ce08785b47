"""`bracekit sweep` at the command line: no completed run, a scheduler address that is not a Dask scheduler."""

from __future__ import annotations

import csv
import http.server
import socket
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from bracekit.cli.main import main


def test_a_sweep_with_no_completed_run_writes_its_tables(
    tiny_spec: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    spec = tiny_spec.with_name("tiny_none.toml")  # k of J̃ is at least 1: every candidate is screened out
    spec.write_text(tiny_spec.read_text(encoding="utf-8").replace("[screen]\n", "[screen]\nk_max = 0.5\n"), "utf-8")
    out = tmp_path / "out"
    code = main(["sweep", str(spec), "--out", str(out), "--workers", "1", "--limit", "3", "--quiet"])
    err = capsys.readouterr().err
    assert code == 0
    assert "warning: no candidate completed a run (3 screened out or failed)" in err
    with open(out / "results.csv", encoding="utf-8") as fh:
        table = list(csv.DictReader(fh))
    assert len(table) == 3 and all(r["screened_out"] == "True" and r["completed"] == "False" for r in table)
    assert {"table.md", "summary.json", "heatmap.png", "pareto.png"} <= {p.name for p in out.iterdir()}


class Quiet(http.server.BaseHTTPRequestHandler):
    def log_message(self, format: str, *args: object) -> None:
        pass


@pytest.fixture
def http_address() -> Iterator[str]:
    """An HTTP server (as a Dask dashboard is) on a free local port, in a thread."""
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Quiet)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"tcp://127.0.0.1:{server.server_address[1]}"
    finally:
        server.shutdown()
        server.server_close()


@pytest.mark.slow  # a new process (or a Dask cluster): seconds, in the slow group
def test_an_http_server_as_scheduler_is_one_line_and_leaves_no_folder(
    tiny_spec: Path,
    http_address: str,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    import bracekit.studies.sweep.engine as engine

    monkeypatch.setattr(engine, "CONNECT_TIMEOUT", 2.0)
    out = tmp_path / "out"
    began = time.monotonic()
    code = main(["sweep", str(tiny_spec), "--out", str(out), "--scheduler", http_address, "--quiet"])
    elapsed = time.monotonic() - began
    err = capsys.readouterr().err.strip()
    assert code == 2 and elapsed < engine.CONNECT_TIMEOUT + engine.GRACE + 5
    assert len(err.splitlines()) == 1 and http_address in err and "tcp://HOST:8786" in err
    assert not out.exists() and not list(tmp_path.iterdir())  # no folder, no lock file left behind


@pytest.mark.slow  # a new process (or a Dask cluster): seconds, in the slow group
def test_an_unreachable_scheduler_leaves_no_folder(
    tiny_spec: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    import bracekit.studies.sweep.engine as engine

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        address = f"tcp://127.0.0.1:{s.getsockname()[1]}"  # nothing listens once closed
    monkeypatch.setattr(engine, "CONNECT_TIMEOUT", 1.0)
    out = tmp_path / "nested" / "out"
    assert main(["sweep", str(tiny_spec), "--out", str(out), "--scheduler", address, "--quiet"]) == 2
    assert "cannot connect to the Dask scheduler" in capsys.readouterr().err
    assert not (tmp_path / "nested").exists()
    assert main(["sweep", str(tiny_spec), "--out", str(out), "--scheduler", address, "--quiet"]) == 2
    assert "cannot connect" in capsys.readouterr().err  # not refused as a folder of another sweep
