"""Measure a checkout of bracekit with the whole-run benchmarks, for ``bracekit bench --compare``.

    python tools/bench_baseline.py CHECKOUT --out benchmarks/baseline-COMMIT.json [--quick] [--no-sweep]

CHECKOUT is a source tree of any bracekit version (e.g. ``git worktree add /tmp/base e6bc01a``): a fresh Python
process imports bracekit from CHECKOUT/src (PYTHONPATH) and runs benchmarks/bench_runs.py of *this* clone on
it, so the calls are the ones ``bracekit bench`` makes on the current version. The JSON holds the medians and
the machine (cores, load before and after, CPU model, UTC date, the checkout's commit). Run it on the machine
and in the session of the comparison: ratios between machines or loads mean little.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
BENCHMARKS = HERE.parent / "benchmarks"

_CHILD = """
import json, sys
from pathlib import Path
sys.path.insert(0, sys.argv[1])
import bracekit
source = Path(bracekit.__file__).resolve().parent
if source != Path(sys.argv[2]).resolve():
    sys.exit(f"imported bracekit from {source}, not from {sys.argv[2]}")
import bench_runs
res = bench_runs.whole_runs(quick=sys.argv[3] == "quick", sweep=sys.argv[4] == "sweep")
print(json.dumps(res))
"""


def measure(checkout: Path, quick: bool = False, sweep: bool = True) -> dict:
    """The whole-run measurements of bracekit at `checkout` (a source tree with src/bracekit), in a new process."""
    src = checkout.resolve() / "src"
    if not (src / "bracekit" / "__init__.py").is_file():
        raise SystemExit(f"{checkout} holds no src/bracekit: give a bracekit source tree (a git worktree)")
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(src), *filter(None, [env.get("PYTHONPATH")])])
    cmd = [sys.executable, "-c", _CHILD, str(BENCHMARKS), str(src / "bracekit"), "quick" if quick else "full"]
    cmd.append("sweep" if sweep else "no-sweep")
    proc = subprocess.run(cmd, stdout=subprocess.PIPE, text=True, env=env, check=False)
    if proc.returncode != 0:
        raise SystemExit(f"the benchmark of {checkout} failed (exit {proc.returncode})")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("checkout", type=Path, help="a bracekit source tree, e.g. a git worktree of the baseline commit")
    ap.add_argument("--out", type=Path, required=True, help="the JSON file to write")
    ap.add_argument("--quick", action="store_true", help="fewer rounds, 4 sweep candidates")
    ap.add_argument("--no-sweep", action="store_true", help="leave out the Dask sweep")
    args = ap.parse_args()
    res = measure(args.checkout, quick=args.quick, sweep=not args.no_sweep)
    res["measured_by"] = "tools/bench_baseline.py"
    args.out.write_text(json.dumps(res, indent=2, sort_keys=True) + "\n", encoding="utf-8")
    print(json.dumps({k: v for k, v in res.items() if not isinstance(v, dict | list)}, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
