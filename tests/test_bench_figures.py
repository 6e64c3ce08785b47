"""The figures benchmark's bookkeeping: both commands alternate, medians and their ratio (no timing asserted)."""

from __future__ import annotations

import statistics
import subprocess
from pathlib import Path

import bench_figures
import pytest


def test_runs_alternate_into_fresh_folders_and_the_ratio_is_of_the_medians(monkeypatch) -> None:
    calls: list[tuple[Path, bool]] = []
    times = [3.0, 1.0, 5.0, 2.0, 4.0, 1.5, 3.5, 1.2, 3.2, 1.1]
    clock = iter(times)

    def fake(out: Path, figures: bool) -> tuple[float, float]:
        calls.append((out, figures))
        wall = next(clock)
        return wall, 0.5 * wall

    monkeypatch.setattr(bench_figures, "_run", fake)
    r = bench_figures.figures_benchmarks(quick=False)
    assert [f for _, f in calls] == [True, False, True, False, False, True, True, False, False, True]
    assert len({out for out, _ in calls}) == len(calls)  # a fresh output folder each time
    with_figures = [t for (_, f), t in zip(calls, times, strict=True) if f][1:]  # the first pair warms up
    without = [t for (_, f), t in zip(calls, times, strict=True) if not f][1:]
    assert r["run_figures_s"] == statistics.median(with_figures)
    assert r["run_no_figures_s"] == statistics.median(without)
    assert r["figures_overhead_ratio"] == pytest.approx(r["run_figures_s"] / r["run_no_figures_s"])
    assert (
        r["run_figures_cpu_s"] == 0.5 * r["run_figures_s"] and r["run_no_figures_cpu_s"] == 0.5 * r["run_no_figures_s"]
    )


def test_a_failing_run_is_reported(monkeypatch, tmp_path: Path) -> None:
    def failing(cmd, **_kw):
        return subprocess.CompletedProcess(cmd, 2, "", "bracekit: error: no such scenario\n")

    monkeypatch.setattr(bench_figures.subprocess, "run", failing)
    with pytest.raises(RuntimeError, match="exited with 2: bracekit: error: no such scenario"):
        bench_figures._run(tmp_path / "out", figures=False)
