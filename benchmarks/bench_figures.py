"""What the figures add to ``bracekit run paper``: the run with and without ``--no-figures``, side by side.

:func:`figures_benchmarks` runs ``python -m bracekit run paper --quiet`` end to end in fresh processes, each
into a fresh output folder, alternating the two commands (with figures and the animation, and with
``--no-figures``) so that both see the same machine load, and returns their median wall times and ratio.
Timings depend on the machine and its load; no timing is asserted anywhere.
"""

from __future__ import annotations

import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

#: The target (README, Speed): the run with every figure and the animation at most twice the run without.
TARGET_FIGURES_OVERHEAD_RATIO = 2.0


def _run(out: Path, figures: bool) -> tuple[float, float]:
    """Wall and CPU time (s, the process and its children) of one ``bracekit run paper --quiet`` into `out`.

    Raises RuntimeError if the run fails.
    """
    cmd = [sys.executable, "-m", "bracekit", "run", "paper", "--quiet", "--out", str(out)]
    if not figures:
        cmd.append("--no-figures")
    used = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
    elapsed = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - used.ru_utime) + (after.ru_stime - used.ru_stime)
    if proc.returncode != 0:
        tail = (proc.stderr.strip().splitlines() or ["no message"])[-1]
        raise RuntimeError(f"{' '.join(cmd[1:])} exited with {proc.returncode}: {tail}")
    if figures and not (out / "animation.gif").is_file():
        raise RuntimeError(f"{' '.join(cmd[1:])} wrote no animation.gif")
    return elapsed, cpu


def figures_benchmarks(quick: bool = False) -> dict[str, float]:
    """Median wall times of ``bracekit run paper`` with and without figures, interleaved, and their ratio.

    Args:
        quick: 2 rounds instead of 4 (each round runs both commands once, after one warm-up pair).

    Returns:
        ``run_no_figures_s`` and ``run_figures_s`` (wall, s, start-up included), ``figures_overhead_ratio``
        (run_figures_s / run_no_figures_s; the target is ≤ :data:`TARGET_FIGURES_OVERHEAD_RATIO`), and the
        median CPU seconds of each (``run_no_figures_cpu_s``, ``run_figures_cpu_s``: the process and the child
        that draws the animation; on a loaded machine the wall times follow the CPU times).
    """
    rounds = 2 if quick else 4
    times: dict[bool, list[float]] = {True: [], False: []}
    cpu: dict[bool, list[float]] = {True: [], False: []}
    with tempfile.TemporaryDirectory(prefix="bracekit-bench-figures-") as tmp:
        folder = Path(tmp)
        _run(folder / "warm-figures", True)  # file caches (fonts, numba's kernel cache) as in everyday use
        _run(folder / "warm-plain", False)
        for i in range(rounds):
            order = (True, False) if i % 2 == 0 else (False, True)
            for figures in order:
                wall, used = _run(folder / f"run{i}-{'figures' if figures else 'plain'}", figures)
                times[figures].append(wall)
                cpu[figures].append(used)
    plain = statistics.median(times[False])
    full = statistics.median(times[True])
    return {
        "run_no_figures_s": plain,
        "run_figures_s": full,
        "figures_overhead_ratio": full / plain,
        "run_no_figures_cpu_s": statistics.median(cpu[False]),
        "run_figures_cpu_s": statistics.median(cpu[True]),
    }


if __name__ == "__main__":
    import argparse
    import json

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    ap.add_argument("--quick", action="store_true", help="2 rounds instead of 4")
    args = ap.parse_args()
    print(json.dumps(figures_benchmarks(args.quick), indent=2))
