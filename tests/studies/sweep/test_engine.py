from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import pytest

from bracekit.studies.sweep.candidates import expand
from bracekit.studies.sweep.engine import dask_client, run_sweep
from bracekit.studies.sweep.spec import load_spec
from bracekit.studies.sweep.store import RowStore, SweepStateError


def without_times(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    return [{k: v for k, v in r.items() if k != "wall_s"} for r in rows]


@pytest.fixture(scope="module")
def reference(tiny_spec: Path, client2: Any, tmp_path_factory: pytest.TempPathFactory) -> Any:
    """The tiny sweep on 2 local workers, every candidate simulated."""
    return run_sweep(load_spec(tiny_spec), tmp_path_factory.mktemp("ref"), client2, screen=False)


def test_results_are_identical_on_one_and_two_workers(tiny_spec: Path, reference: Any, tmp_path: Path) -> None:
    spec = load_spec(tiny_spec)
    with dask_client(workers=1) as client:
        one = run_sweep(spec, tmp_path, client, screen=False)
    assert one.workers == 1 and reference.workers == 2
    assert [r["candidate"] for r in one.rows] == [c.id for c in expand(spec)]
    assert without_times(one.rows) == without_times(reference.rows)
    assert one.refined == reference.refined
    assert one.evaluated == 4 and one.reused == 0


def test_resume_skips_finished_candidates(tiny_spec: Path, reference: Any, client2: Any, tmp_path: Path) -> None:
    spec = load_spec(tiny_spec)
    first = run_sweep(spec, tmp_path, client2, screen=False, limit=2, refine=False)
    assert first.evaluated == 2 and len(first.rows) == 2
    saved = {p.name: p.stat().st_mtime_ns for p in (tmp_path / ".sweep" / "rows").iterdir()}
    assert len(saved) == 2
    second = run_sweep(spec, tmp_path, client2, screen=False)
    assert second.evaluated == 2 and second.reused == 2
    assert {p.name: p.stat().st_mtime_ns for p in (tmp_path / ".sweep" / "rows").iterdir() if p.name in saved} == saved
    assert without_times(second.rows) == without_times(reference.rows)
    third = run_sweep(spec, tmp_path, client2, screen=False)
    assert third.evaluated == 0 and third.reused == 4
    assert third.rows == second.rows  # the saved rows, wall times included


def test_an_interrupt_keeps_the_finished_rows(tiny_spec: Path, reference: Any, client2: Any, tmp_path: Path) -> None:
    spec = load_spec(tiny_spec)
    seen: list[str] = []

    def stop(row: dict[str, Any]) -> None:
        seen.append(row["candidate"])
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_sweep(spec, tmp_path, client2, screen=False, on_row=stop)
    rows = sorted(p.stem for p in (tmp_path / ".sweep" / "rows").glob("*.json"))
    assert seen and set(seen) <= set(rows) and len(rows) < 4
    assert not [p for p in (tmp_path / ".sweep" / "rows").iterdir() if p.name.endswith(".tmp")]
    again = run_sweep(spec, tmp_path, client2, screen=False)
    assert again.evaluated == 4 - len(rows)
    assert without_times(again.rows) == without_times(reference.rows)


def test_another_specs_partial_results_are_refused(tiny_spec: Path, tmp_path: Path) -> None:
    RowStore(tmp_path, load_spec(tiny_spec))
    with pytest.raises(SweepStateError, match="another sweep spec"):
        RowStore(tmp_path, load_spec("paper-links"))


def test_screening_keeps_rows_for_every_candidate(
    tiny_spec: Path, reference: Any, client2: Any, tmp_path: Path
) -> None:
    from bracekit.studies.sweep.context import task_context
    from bracekit.studies.sweep.screen import screen_context, select

    spec = load_spec(tiny_spec)
    cands = expand(spec)
    verdicts = select(spec, screen_context(spec, task_context(spec, {}, cands[0].context_key), cands))
    run = run_sweep(spec, tmp_path, client2)
    assert len(run.rows) == 4
    assert run.screened_out == sum(v is not None for v in verdicts.values()) == 4 - run.evaluated
    by_id = {r["candidate"]: r for r in reference.rows}
    for row in run.rows:
        assert row["screened_out"] == (verdicts[row["candidate"]] is not None)
        if row["screened_out"]:
            assert row["failure"] == verdicts[row["candidate"]] and row["Ci_mean_gp"] is None
        else:
            assert {k: v for k, v in row.items() if k != "wall_s" and not k.startswith("screen_")} == {
                k: v for k, v in by_id[row["candidate"]].items() if k != "wall_s" and not k.startswith("screen_")
            }
    assert len(os.listdir(tmp_path / ".sweep" / "rows")) == run.evaluated


def test_a_resumed_sweep_judges_saved_rows_by_the_current_bounds(
    tiny_spec: Path, reference: Any, client2: Any, tmp_path: Path
) -> None:
    spec = load_spec(tiny_spec)
    run_sweep(spec, tmp_path / "out", client2, screen=False, limit=2, refine=False)
    k = [r["k_mean_gp"] for r in reference.rows[:2] if r["completed"]]
    assert k, "no completed run among the first two candidates"
    strict_text = tiny_spec.read_text() + f"[feasibility]\nk_max = {0.5 * min(k) + 0.5}\n"
    strict_path = tiny_spec.with_name("tiny_strict.toml")
    strict_path.write_text(strict_text, encoding="utf-8")
    strict = load_spec(strict_path)
    assert strict.fingerprint() == spec.fingerprint()  # the bounds may change between runs
    resumed = run_sweep(strict, tmp_path / "out", client2, screen=False, limit=2, refine=False)
    assert resumed.evaluated == 0 and resumed.reused == 2
    fresh = run_sweep(strict, tmp_path / "fresh", client2, screen=False, limit=2, refine=False)
    assert fresh.evaluated == 2
    assert without_times(resumed.rows) == without_times(fresh.rows)
    saved = reference.rows[:2]  # the verdicts the rows were saved with
    assert any(r["failure"] != s["failure"] for r, s in zip(resumed.rows, saved, strict=True))
    assert not any(r["feasible"] for r in resumed.rows)


def copy_spec(tiny_spec: Path, folder: Path) -> Path:
    folder.mkdir()
    for name in ("tiny.toml", "short.toml"):
        (folder / name).write_text((tiny_spec.parent / name).read_text(encoding="utf-8"), encoding="utf-8")
    return folder / "tiny.toml"


def test_rows_from_edited_base_files_are_refused(tiny_spec: Path, tmp_path: Path) -> None:
    path = copy_spec(tiny_spec, tmp_path / "spec")
    RowStore(tmp_path / "out", load_spec(path))
    RowStore(tmp_path / "out", load_spec(path))  # the same files: accepted
    base = path.with_name("short.toml")
    base.write_text(base.read_text(encoding="utf-8") + "# edited\n", encoding="utf-8")
    edited = load_spec(path)
    assert edited.base_data == load_spec(tiny_spec).base_data  # the same data, other bytes
    with pytest.raises(
        SweepStateError, match=r"base scenario files .* changed since, not reused; give another --out"
    ) as info:
        RowStore(tmp_path / "out", edited)
    assert "\n" not in str(info.value)


def test_a_urdf_file_of_the_base_is_in_the_fingerprint(tiny_spec: Path, tmp_path: Path) -> None:
    import dataclasses

    spec = load_spec(tiny_spec)
    urdf = tmp_path / "arm.urdf"
    urdf.write_text("<robot name='a'/>", encoding="utf-8")
    data = dict(spec.base_data) | {"robot": {"urdf": "arm.urdf", "tip": "tip"}}
    with_urdf = dataclasses.replace(spec, base_data=data, base_dir=tmp_path)
    assert with_urdf.base_files() == [spec.base_path, urdf]
    before = with_urdf.fingerprint_parts()
    urdf.write_text("<robot name='b'/>", encoding="utf-8")
    after = with_urdf.fingerprint_parts()
    assert before["files"] != after["files"] and before["spec"] == after["spec"]


def test_rows_of_another_bracekit_version_are_refused(
    tiny_spec: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import bracekit.studies.sweep.spec as spec_module

    RowStore(tmp_path, load_spec(tiny_spec))
    monkeypatch.setattr(spec_module, "__version__", "0.0.0-other")
    with pytest.raises(SweepStateError, match=r"partial results of bracekit .* \(this is 0\.0\.0-other\)"):
        RowStore(tmp_path, load_spec(tiny_spec))


def test_an_older_work_folder_is_refused_as_another_version(tiny_spec: Path, tmp_path: Path) -> None:
    import json

    RowStore(tmp_path, load_spec(tiny_spec))
    marker = tmp_path / ".sweep" / "spec.json"
    held = json.loads(marker.read_text(encoding="utf-8"))
    old = {k: v for k, v in held.items() if k not in ("parts", "fingerprint")}
    old |= {"bracekit": "0.0.1", "fingerprint": "x"}
    marker.write_text(json.dumps(old), encoding="utf-8")  # as an older bracekit wrote it: no "parts"
    with pytest.raises(SweepStateError, match=r"partial results of bracekit 0\.0\.1"):
        RowStore(tmp_path, load_spec(tiny_spec))


def test_the_probe_connects_with_the_clients_security_arguments(monkeypatch: pytest.MonkeyPatch) -> None:
    import distributed
    import distributed.comm.core

    from bracekit.studies.sweep.engine import probe

    seen: dict[str, Any] = {}

    async def fake_connect(address: str, timeout: float, **kwargs: Any) -> Any:
        seen.update(kwargs)
        raise OSError("refused")

    marker = {"ssl_context": "from the Dask config", "require_encryption": True}
    monkeypatch.setattr(distributed.Security, "get_connection_args", lambda self, role: dict(marker))
    monkeypatch.setattr(distributed.comm.core, "connect", fake_connect)  # what probe() calls
    assert "refused" in (probe("tls://127.0.0.1:9", 2.0) or "")
    assert seen == marker  # a TLS scheduler configured for Client() is reached by the probe too


def test_rows_equal_candidates_evaluated_one_by_one_in_this_process(tiny_spec: Path, reference: Any) -> None:
    """The sweep runs candidates from the reference start while the free-space run goes on: the rows are those of
    each candidate evaluated here, after its whole task context, without Dask."""
    from bracekit.studies.sweep.context import task_context
    from bracekit.studies.sweep.evaluate import evaluate_candidate, judge

    spec = load_spec(tiny_spec)
    candidates = expand(spec)
    context = task_context(spec, {}, candidates[0].context_key)
    assert {c.context_key for c in candidates} == {context.key}
    for c, row in zip(candidates, reference.rows, strict=True):
        here = judge(spec, evaluate_candidate(spec, c, context))
        assert row["Ci_mean_free_space"] is not None
        assert without_times([{k: here.get(k) for k in row}]) == without_times([row]), c.id


def test_screening_in_chunks_equals_one_call_for_the_whole_context(
    tiny_spec: Path, client2: Any, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Each chunk of a context's candidates is screened by its own task: the same screening and verdicts."""
    from bracekit.studies.sweep import engine
    from bracekit.studies.sweep.context import task_context
    from bracekit.studies.sweep.screen import screen_context, select

    spec = load_spec(tiny_spec)
    cands = expand(spec)
    whole = screen_context(spec, task_context(spec, {}, cands[0].context_key), cands)
    verdicts = select(spec, whole)
    assert engine.chunks(cands, 3) == [cands[:3], cands[3:]]
    monkeypatch.setattr(engine, "SCREEN_CHUNK", 1)  # a task per candidate
    run = run_sweep(spec, tmp_path, client2, refine=False)
    for s, row in zip(whole, run.rows, strict=True):
        assert row["candidate"] == s.candidate
        assert (row["screen_Ci_mean"], row["screen_k_max"], row["screen_clearance_m"]) == (
            s.Ci_mean,
            s.k_max,
            s.clearance,
        )
        assert row["screened_out"] == (verdicts[s.candidate] is not None)


def test_refinements_on_the_cluster_equal_searches_in_this_process(
    tiny_spec: Path, client2: Any, tmp_path: Path
) -> None:
    """Three searches share the two workers evaluation by evaluation: each is the search run in one process."""
    from bracekit.studies.sweep.context import task_context
    from bracekit.studies.sweep.refine import interval, refine_candidate, usable

    text = tiny_spec.read_text(encoding="utf-8").replace('["link4", "link8"]', '["link4"]')
    path = tiny_spec.with_name("tiny_three.toml")  # three feasible points on link4, all refined
    path.write_text(text.replace("[0.3, 0.7]", "[0.2, 0.25, 0.3]").replace("top = 1", "top = 3"), encoding="utf-8")
    spec = load_spec(path)
    run = run_sweep(spec, tmp_path, client2, screen=False)
    best = sorted((r for r in run.rows if usable(r)), key=lambda r: (r["Ci_mean_gp"], r["index"]))[:3]
    assert len(best) == 3, "not three feasible candidates: fewer searches side by side"
    assert [r["candidate"] for r in run.refined] == [r["candidate"] for r in best]
    by_id = {c.id: c for c in expand(spec)}
    context = task_context(spec, {}, expand(spec)[0].context_key)
    for row, got in zip(best, run.refined, strict=True):
        c = by_id[row["candidate"]]
        here = refine_candidate(spec, c, context, *interval(spec, c.inputs["fraction"]))
        assert got["evaluations"] == here["evaluations"] and got["interval"] == list(here["interval"])
        improved = here["refined_Ci_mean_gp"] is not None and here["refined_Ci_mean_gp"] < row["Ci_mean_gp"]
        assert got["improved"] == improved
        if improved:
            for key in ("refined_fraction", "refined_Ci_mean_gp", "refined_k_mean_gp", "refined_point"):
                assert got[key] == here[key], key


def _worker_settings(dask_worker: Any) -> tuple[object, object, bool]:
    import dask

    sampling = "profile" in dask_worker.periodic_callbacks  # distributed's statistical profiler, every 10 ms
    return dask.config.get("distributed.worker.profile.enabled"), os.environ.get("OMP_NUM_THREADS"), sampling


def test_local_workers_run_one_thread_and_no_profiler(client2: Any) -> None:
    settings = client2.run(_worker_settings)
    assert len(settings) == 2
    assert all(found == (False, "1", False) for found in settings.values()), settings
