"""Benchmarks of bracekit (not part of the test run): ``python benchmarks/run.py [--quick] [--json FILE]``.

Prints the table of :func:`bench.run_benchmarks` (benchmarks/bench.py) (the same as ``bracekit bench``): the hot
paths (the braced gradient-projection step on both backends, numba's compilation and cache-load times,
Pinocchio's floor, Robotics Toolbox for Python when it is installed, batch throughput), whole runs in process,
the sweep on 1 and 2 Dask workers and the figures' overhead, then the ratios against ``--compare`` (default the
committed baseline) and the speed goals. The numba rows need ``pip install bracekit[fast]``; without numba they
say "skipped".
``--profile`` prints where a step and the scenario spend their time (cProfile) instead.
"""

from __future__ import annotations

import argparse
import cProfile
import json
import pstats
import sys
import warnings
from pathlib import Path


def _profile(top: int) -> None:
    import numpy as np

    from bracekit.resolution.fused import GradientProjectionStep, numba_available
    from bracekit.simulation.run import run_scenario
    from bracekit.simulation.scenario import load_scenario

    sc = load_scenario("paper")
    strategy = sc.strategy("braced_gradient_projection")
    xdot = np.concatenate([sc.task.velocity(0.0), np.zeros(3)])
    step = GradientProjectionStep(sc.braced, strategy)  # type: ignore[arg-type]
    names = {"sc": sc, "strategy": strategy, "step": step, "q": sc.guess, "xdot": xdot, "run_scenario": run_scenario}
    cases = [
        ("reference step x 2000", "for _ in range(2000): strategy.velocity(sc.braced.state(q, hessians=True), xdot)"),
        ("fused step, NumPy backend x 2000", "for _ in range(2000): step(q, xdot)"),
    ]
    if numba_available():
        names["step_nb"] = GradientProjectionStep(sc.braced, strategy, backend="numba")  # type: ignore[arg-type]
        names["step_nb"](sc.guess, xdot)  # compile or load the kernel outside the profile
        cases.append(("fused step, numba backend x 2000", "for _ in range(2000): step_nb(q, xdot)"))
    cases.append(("run_scenario('paper')", "run_scenario(sc)"))
    for label, code in cases:
        prof = cProfile.Profile()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            prof.runctx(code, names, {})
        print(f"=== {label} ===")
        pstats.Stats(prof, stream=sys.stdout).sort_stats("tottime").print_stats(top)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer rounds and a smaller batch")
    ap.add_argument("--json", type=Path, help="also write the results as JSON to this file")
    ap.add_argument("--only", action="append", help="run only this part (repeat): figures, sweep, runs, core")
    ap.add_argument("--compare", type=Path, help="print ratios against this JSON (default: the committed baseline)")
    ap.add_argument("--profile", action="store_true", help="print cProfile tables instead of benchmarking")
    ap.add_argument("--top", type=int, default=25, help="rows per profile table (default 25)")
    args = ap.parse_args()
    if args.profile:
        _profile(args.top)
        return 0
    from bench import PARTS, run_benchmarks

    parts = tuple(args.only) if args.only else PARTS
    results = run_benchmarks(quick=args.quick, parts=parts, compare=args.compare)
    print(results["table"])
    if args.json is not None:
        args.json.write_text(json.dumps(results, indent=2) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
