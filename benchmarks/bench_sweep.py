"""Speed of `bracekit sweep`: candidates per second on 1 and 2 local Dask workers, same candidates, same call.

The candidates are the shipped ``paper-links`` spec's links at 1 (quick) or 3 (full) fractions each, every one a
whole-task run of both braced strategies (no screening, no refinement). Each cluster is started and warmed up
(every worker imports bracekit and runs one candidate, compiling or loading the numba kernel) before the clock
starts; the start-up is reported separately. Timings depend on the machine and its load.
"""

from __future__ import annotations

import dataclasses
import tempfile
import time
from pathlib import Path
from typing import Any


def _spec(quick: bool) -> Any:
    from bracekit.studies.sweep.spec import load_spec

    spec = load_spec("paper-links")
    fractions = (0.5,) if quick else (0.26, 0.5, 0.74)
    fraction = dataclasses.replace(spec.axis("fraction"), values=fractions, low=None, high=None, count=0)
    axes = tuple(fraction if a.name == "fraction" else a for a in spec.axes)
    return dataclasses.replace(spec, axes=axes, name=f"bench-{spec.name}")


def _warm(spec: Any) -> None:
    """Import and run one candidate in this (worker) process."""
    from bracekit.studies.sweep.candidates import expand
    from bracekit.studies.sweep.context import task_context
    from bracekit.studies.sweep.evaluate import evaluate_candidate

    first = expand(spec, limit=1)[0]
    evaluate_candidate(spec, first, task_context(spec, first.inputs, first.context_key))


def _throughput(spec: Any, workers: int) -> tuple[float, float, int]:
    """(candidates per second, cluster start-up and warm-up s, candidates) on a new local cluster."""
    from bracekit.studies.sweep.engine import dask_client, run_sweep

    began = time.perf_counter()
    with dask_client(workers=workers) as client, tempfile.TemporaryDirectory() as tmp:
        client.run(_warm, spec)
        ready = time.perf_counter()
        run = run_sweep(spec, Path(tmp), client, screen=False, refine=False)
        elapsed = time.perf_counter() - ready
    return run.evaluated / elapsed, ready - began, run.evaluated


def sweep_benchmarks(quick: bool = False) -> dict[str, float]:
    """``sweep_candidates_per_s_1`` and ``_2`` (1 then 2 workers, the same candidates), start-ups and the count."""
    spec = _spec(quick)
    one, start_1, n = _throughput(spec, 1)
    two, start_2, _ = _throughput(spec, 2)
    return {
        "sweep_candidates_per_s_1": one,
        "sweep_candidates_per_s_2": two,
        "sweep_cluster_start_s_1": start_1,
        "sweep_cluster_start_s_2": start_2,
        "sweep_candidates": float(n),
    }


if __name__ == "__main__":
    import json
    import sys

    print(json.dumps(sweep_benchmarks(quick="--quick" in sys.argv), indent=2))
