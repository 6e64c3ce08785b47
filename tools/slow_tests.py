"""Which tests of the fast group (``-m "not slow"``) take longer than a threshold: candidates for conftest's SLOW.

    python tools/slow_tests.py [--threshold 2.0] [PYTEST ARGS ...]

Runs ``python -m pytest -q -m "not slow" --durations=0`` (with the given extra arguments, e.g. a folder), adds each
test's setup, call and teardown, and prints the tests over the threshold (seconds) as lines for the ``SLOW`` tuple
of tests/conftest.py, slowest first, then the group's total. Time it on a warm numba cache and say the load:
``uptime`` is printed before and after.
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
from collections import defaultdict

LINE = re.compile(r"^([0-9.]+)s (setup|call|teardown)\s+(\S+)")


def durations(output: str) -> dict[str, float]:
    """Seconds per test (setup + call + teardown) from pytest's ``--durations=0`` report."""
    total: dict[str, float] = defaultdict(float)
    for line in output.splitlines():
        m = LINE.match(line.strip())
        if m:
            total[m.group(3)] += float(m.group(1))
    return dict(total)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--threshold", type=float, default=2.0, help="seconds (default 2)")
    args, rest = ap.parse_known_args()
    print("load before:", os.getloadavg() if hasattr(os, "getloadavg") else "?")
    cmd = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-m", "not slow", "--durations=0", *rest]
    proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
    print("load after:", os.getloadavg() if hasattr(os, "getloadavg") else "?")
    times = durations(proc.stdout)
    over = sorted(((t, name) for name, t in times.items() if t > args.threshold), reverse=True)
    for t, name in over:
        test = re.sub(r"\[.*$", "", name)  # every parameter of the test
        print(f'    "{test}",  # {t:.1f}')
    summary = [line for line in proc.stdout.splitlines() if " in " in line and ("passed" in line or "failed" in line)]
    last = summary[-1] if summary else "no summary line"
    print(f"{len(over)} tests over {args.threshold:g} s; sum of all {sum(times.values()):.0f} s; {last}")
    return proc.returncode


if __name__ == "__main__":
    sys.exit(main())
