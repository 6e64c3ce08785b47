"""Speed of bracekit, for ``bracekit bench`` and ``benchmarks/run.py``: :func:`run_benchmarks` and its parts.

* "core" (benchmarks/bench_core.py, bench_batch.py, bench_rtb.py): the hot paths on the paper's robot, side by
  side in one process — the gradient-projection step on both backends against central differences and the
  reference path, numba's one-off costs, Pinocchio's floor, Robotics Toolbox when installed, batch C_e / C_i / k,
  the step at another split, and ``bracekit run paper --no-figures --quiet`` in a fresh process;
* "runs" (benchmarks/bench_runs.py): whole runs in process (``run_scenario`` of ``paper``, ``two-braces``,
  ``panda``), the step and Pinocchio's floors — the calls tools/bench_baseline.py makes on an older version;
* "sweep" (bench_runs.py): ``bracekit sweep paper-links --no-screen --no-refine`` on 1 and 2 local Dask workers;
* "figures" (bench_figures.py): ``bracekit run paper`` with and without figures, interleaved processes.

Every result carries ``machine`` (cores, load before and after, CPU model, UTC date, commit). When "runs" was
measured, the table ends with the ratios against ``compare`` (default: the committed baseline
:data:`BASELINE`, measured by tools/bench_baseline.py) and the speed goals as pass/fail rows
(benchmarks/bench_compare.py). Timings depend on the machine and its load; no timing is asserted anywhere.
"""

from __future__ import annotations

import importlib
import importlib.util
import sys
from pathlib import Path
from typing import Any

from bracekit.errors import InputError

HERE = Path(__file__).resolve().parent
#: The parts of :func:`run_benchmarks`, in the order they run.
PARTS = ("figures", "sweep", "runs", "core", "qp")
#: The result of the version before the speed work (tools/bench_baseline.py on commit e6bc01a).
BASELINE = HERE / "baseline-e6bc01a.json"


def _sibling(name: str) -> Any:
    """benchmarks/NAME.py (this folder joins sys.path: `bracekit bench` loads this file by its path)."""
    if str(HERE) not in sys.path:
        sys.path.insert(0, str(HERE))
    return importlib.import_module(name)


def _core(quick: bool) -> dict[str, Any]:
    """The part "core", or the reason it failed (its micro-benchmarks read the step's internals)."""
    try:
        return dict(_sibling("bench_core").core_benchmarks(quick))
    except Exception as exc:  # an internal API the micro-benchmarks use changed: say so, keep the other parts
        return {"core_failed": f"{type(exc).__name__}: {exc}"}


def _qp(quick: bool) -> dict[str, Any]:
    """braced_qp and bracekit.pink per step (benchmarks/bench_qp.py), or why they were skipped."""
    missing = [m for m in ("qpsolvers", "pink") if importlib.util.find_spec(m) is None]
    if missing:
        return {"qp_skipped": f"{', '.join(missing)} not installed: pip install 'bracekit[pink]'"}
    return dict(_sibling("bench_qp").qp_benchmarks(quick))


def run_benchmarks(quick: bool = False, parts: tuple[str, ...] = PARTS, compare: Path | None = None) -> dict[str, Any]:
    """Measure the parts; a JSON-serialisable dict of medians (SI units in the key names) with a "table" string.

    Args:
        quick: fewer rounds, a smaller batch, 4 sweep candidates instead of 16.
        parts: some of :data:`PARTS`.
        compare: a JSON file of ``bracekit bench --json`` or tools/bench_baseline.py to print ratios against
            (new/old of every key both hold) and the speed goals; default :data:`BASELINE` when "runs" or
            "sweep" is measured. The comparison is also returned under ``comparison``.

    Keys: see each part's module; "core" adds ``gp_step_analytic_us`` … ``scenario_wall_s`` and ``targets_met``,
    "runs" adds ``run_paper_s``, ``run_two_braces_s``, ``run_panda_s`` (and ``*_cpu_s``), ``step_gp_us``,
    ``pinocchio_floor_us``, ``pinocchio_floor_two_braces_us``; "sweep" adds ``sweep_candidates_per_s_1`` and
    ``_2`` and ``sweep_scaling_1_to_2``; "figures" adds ``figures_overhead_ratio``.
    """
    for part in parts:
        if part not in PARTS:
            raise InputError(f"unknown benchmark part '{part}'; choose from {', '.join(PARTS)}")
    cmp = _sibling("bench_compare")
    other = cmp.load(Path(compare)) if compare is not None else None  # a bad file is refused before measuring
    runs = _sibling("bench_runs")
    res: dict[str, Any] = {}
    before = runs.machine()
    if "figures" in parts:  # first: whole processes, before this one loads the machine's caches with the rest
        res.update(_sibling("bench_figures").figures_benchmarks(quick))
    if "sweep" in parts:
        res.update(runs.sweep_runs(candidates=4 if quick else 16))
    if "runs" in parts:
        res.update(runs.step_runs(calls=400 if quick else 2000, rounds=3 if quick else 7))
        res.update(runs.scenario_runs(rounds=1 if quick else 5))
        res.update(runs.per_step_runs(rounds=1 if quick else 3))
    if "core" in parts:
        core = _core(quick)
        core.update(res)  # the whole-run part's floors are the ones the comparison reads
        res = core
        if "figures_overhead_ratio" in res and "targets_met" in res:
            res["targets_met"]["figures overhead ≤ 2× the run without figures"] = res["figures_overhead_ratio"] <= 2.0
    if "qp" in parts:
        res.update(_qp(quick))
    before["load_average_after"] = runs.machine()["load_average"]
    res["machine"] = before
    res["parts"] = list(parts)
    res["quick"] = quick
    table = _sibling("bench_table")
    text = [table.core_table(res)] if "core" in parts and "core_failed" not in res else []
    if "core_failed" in res:
        text.append(f"core hot paths: not measured ({res['core_failed']})")
    text.append(table.extra_table(res))
    if "pink_frame_task_step_us" in res:
        text.append("\n".join(f"| {a} | {b} | {c} |" for a, b, c in _sibling("bench_qp").qp_table(res)))
    elif "qp_skipped" in res:
        text.append(f"braced_qp and bracekit.pink: skipped ({res['qp_skipped']})")
    if other is None and ("runs" in parts or "sweep" in parts) and BASELINE.is_file():
        compare, other = BASELINE, cmp.load(BASELINE)
    if compare is not None and other is not None:
        result = cmp.compare(res, other)
        res["comparison"] = {"against": str(compare), **cmp.as_dict(result)}
        text += ["", f"Against {Path(compare).name} (new = this run):", cmp.table(result)]
    res["table"] = "\n".join(t for t in text if t is not None)
    return res
