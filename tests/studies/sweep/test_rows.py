"""Saved rows checked on load and re-run when damaged; the work folder and the cluster kept to OUT and loopback."""

from __future__ import annotations

import json
import os
import time
from pathlib import Path
from typing import Any

import pytest

from bracekit.cli.main import main
from bracekit.studies.sweep.candidates import expand
from bracekit.studies.sweep.engine import dask_client, run_sweep
from bracekit.studies.sweep.report import summary
from bracekit.studies.sweep.rows import row_problem
from bracekit.studies.sweep.spec import load_spec


def without_times(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    return [{k: v for k, v in r.items() if k != "wall_s"} for r in rows]


def _one_line(err: str, *fragments: str) -> None:
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("bracekit: error:"), err
    assert all(f in lines[0] for f in fragments), lines[0]


@pytest.fixture(scope="module")
def saved(tiny_spec: Path, client2: Any, tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Any]:
    """A sweep folder with every candidate's row saved (no screening, no refinement), and its run."""
    out = tmp_path_factory.mktemp("saved")
    return out, run_sweep(load_spec(tiny_spec), out, client2, screen=False, refine=False)


DAMAGE = {
    "empty list": "[]",
    "id only": None,  # {"candidate": id}
    "negative C_i": ("Ci_mean_gp", -5.0),
    "string C_i": ("Ci_mean_gp", "0.001"),
    "NaN k": ("k_mean_gp", float("nan")),
    "another candidate's inputs": ("fraction", 0.123),
    "deeply nested": "[" * 100_000 + "]" * 100_000,
}


@pytest.mark.parametrize("damage", list(DAMAGE))
def test_a_damaged_row_is_run_again_and_counted(
    tiny_spec: Path, client2: Any, saved: tuple[Path, Any], tmp_path: Path, damage: str
) -> None:
    folder, reference = saved
    spec = load_spec(tiny_spec)
    out = tmp_path / "out"
    (out / ".sweep").mkdir(parents=True)
    for name in ("spec.json",):
        (out / ".sweep" / name).write_bytes((folder / ".sweep" / name).read_bytes())
    rows = out / ".sweep" / "rows"
    rows.mkdir()
    for p in (folder / ".sweep" / "rows").iterdir():
        (rows / p.name).write_bytes(p.read_bytes())
    (out / ".sweep" / "refined").mkdir()
    victim = expand(spec)[-1]  # the last: ranked best before, when a damaged row was reused
    path = rows / f"{victim.id}.json"
    row = json.loads(path.read_text())
    assert row_problem(spec, victim, row) is None  # a row as saved passes
    change = DAMAGE[damage]
    if change is None:
        text = json.dumps({"candidate": victim.id})
    elif isinstance(change, str):
        text = change
    else:
        row[change[0]] = change[1]
        text = json.dumps(row)
    path.write_text(text)
    again = run_sweep(spec, out, client2, screen=False, refine=False)
    assert again.evaluated == 1 and again.rerun == 1 and again.reused == len(reference.rows) - 1
    assert summary(again)["rerun_invalid_rows"] == 1
    assert without_times(again.rows) == without_times(reference.rows)  # the fresh run's answer, not the damage
    assert row_problem(spec, victim, json.loads(path.read_text())) is None


def test_a_sweep_folder_whose_work_folder_is_a_link_is_refused_and_nothing_written_through_it(
    tiny_spec: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "out"
    elsewhere = tmp_path / "elsewhere"
    out.mkdir()
    elsewhere.mkdir()
    (out / ".sweep").symlink_to(elsewhere)
    for extra in ((), ("--overwrite",)):
        code = main(["sweep", str(tiny_spec), "--out", str(out), "--workers", "1", "--quiet", *extra])
        assert code == 2
        _one_line(capsys.readouterr().err, ".sweep", "symbolic link")
        assert list(elsewhere.iterdir()) == [] and sorted(p.name for p in out.iterdir()) == [".sweep"]


def test_a_local_cluster_listens_on_loopback_only() -> None:
    import psutil

    def listening(pids: list[int]) -> list[tuple[int, str, int]]:
        found = []
        for pid in pids:
            try:
                conns = psutil.Process(pid).net_connections(kind="inet")
            except (psutil.NoSuchProcess, psutil.AccessDenied):
                continue
            found += [(pid, c.laddr.ip, c.laddr.port) for c in conns if c.status == psutil.CONN_LISTEN]
        return found

    me = psutil.Process(os.getpid())
    before = {(ip, port) for _, ip, port in listening([me.pid])}
    with dask_client(workers=2) as client:
        assert len(client.scheduler_info()["workers"]) == 2
        tree = [me.pid, *(p.pid for p in me.children(recursive=True))]
        sockets = [s for s in listening(tree) if (s[1], s[2]) not in before]
        assert len(tree) >= 3 and sockets  # the scheduler (here) and two worker processes
        public = [s for s in sockets if s[1] not in ("127.0.0.1", "::1")]
        assert not public, f"listening beyond loopback: {public}"


@pytest.mark.parametrize(
    ("extra", "fragments"),
    [
        (["--workers", "100000"], ("--workers", "256")),
        (["--scheduler", "tcp://127.0.0.1:99999"], ("--scheduler", "port")),
        (["--scheduler", "tcp://127.0.0.1:0"], ("--scheduler", "port 0")),
    ],
)
def test_workers_and_scheduler_ports_are_refused_at_once(
    tiny_spec: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], extra: list[str], fragments: tuple[str, ...]
) -> None:
    began = time.perf_counter()
    code = main(["sweep", str(tiny_spec), "--out", str(tmp_path / "out"), "--quiet", *extra])
    assert code == 2 and time.perf_counter() - began < 2.0
    _one_line(capsys.readouterr().err, *fragments)
    assert not (tmp_path / "out").exists()


def test_a_deeply_nested_spec_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    spec = tmp_path / "deep.toml"
    spec.write_text("x = " + "[" * 50_000 + "]" * 50_000 + "\n")
    code = main(["sweep", str(spec), "--out", str(tmp_path / "out"), "--quiet"])
    assert code == 2
    _one_line(capsys.readouterr().err, "deep.toml", "deeper than")


def test_the_final_write_replaces_out_whole_and_carries_the_work_folder(
    tiny_spec: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "out"
    argv = [
        "sweep",
        str(tiny_spec),
        "--out",
        str(out),
        "--workers",
        "1",
        "--quiet",
        "--no-figures",
        "--no-refine",
        "--no-screen",
    ]
    assert main([*argv, "--limit", "1"]) == 0
    manifest = json.loads((out / ".bracekit-output.json").read_text())
    assert set(manifest["files"]) == set(manifest["sha256"]) and "results.csv" in manifest["files"]
    assert manifest["kept"] == [".sweep"]  # carried into the new folder, as bracekit's work folder
    (first,) = (out / ".sweep" / "rows").iterdir()
    inode = first.stat().st_ino
    folder = out.stat().st_ino
    assert main([*argv, "--limit", "2"]) == 0
    capsys.readouterr()
    assert out.stat().st_ino != folder  # a new folder swapped in whole
    assert len(list((out / ".sweep" / "rows").iterdir())) == 2 and first.stat().st_ino == inode  # linked, not copied
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]  # nothing left beside OUT
