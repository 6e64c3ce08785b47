"""Measure checkouts of bracekit with the whole-run benchmarks, for ``bracekit bench --compare``.

    python tools/bench_baseline.py CHECKOUT --out benchmarks/baseline-COMMIT.json [--quick] [--no-sweep]
    python tools/bench_baseline.py OLD NEW --out old.json --out new.json --rounds 2   # side by side

CHECKOUT is a source tree of any bracekit version (e.g. ``git worktree add /tmp/base e6bc01a``): a fresh Python
process imports bracekit from CHECKOUT/src (PYTHONPATH) and runs benchmarks/bench_runs.py of *this* clone on
it, so the calls are the ones ``bracekit bench`` makes on the current version. With several checkouts and
``--rounds N``, the checkouts take turns N times (OLD, NEW, OLD, NEW …) so that they see the same load, and each
key is the median over its rounds. Each JSON holds the medians and the machine (cores, load before and after,
CPU model, UTC date, the checkout's commit). Ratios between machines or loads mean little: measure on the
machine and in the session of the comparison.
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


def merge(rounds: list[dict]) -> dict:
    """One result from several rounds of one checkout: the median of every number, the first machine."""
    import statistics

    out = dict(rounds[0])
    for key, value in rounds[0].items():
        if isinstance(value, int | float) and not isinstance(value, bool):
            out[key] = statistics.median(r[key] for r in rounds if isinstance(r.get(key), int | float))
    out["machine"] = dict(rounds[0]["machine"], load_average_after=rounds[-1]["machine"]["load_average_after"])
    out["rounds"] = len(rounds)
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("checkout", type=Path, nargs="+", help="bracekit source trees, e.g. git worktrees of two commits")
    ap.add_argument("--out", type=Path, action="append", required=True, help="the JSON file of each checkout")
    ap.add_argument("--rounds", type=int, default=1, help="turns of every checkout (medians over them; default 1)")
    ap.add_argument("--quick", action="store_true", help="fewer rounds, 4 sweep candidates")
    ap.add_argument("--no-sweep", action="store_true", help="leave out the Dask sweep")
    args = ap.parse_args()
    if len(args.out) != len(args.checkout):
        ap.error(f"give one --out per checkout ({len(args.checkout)} checkouts, {len(args.out)} --out)")
    if args.rounds < 1:
        ap.error("--rounds must be at least 1")
    results: list[list[dict]] = [[] for _ in args.checkout]
    for _ in range(args.rounds):
        for i, checkout in enumerate(args.checkout):
            results[i].append(measure(checkout, quick=args.quick, sweep=not args.no_sweep))
    for out, rounds in zip(args.out, results, strict=True):
        res = merge(rounds)
        res["measured_by"] = "tools/bench_baseline.py"
        out.write_text(json.dumps(res, indent=2, sort_keys=True) + "\n", encoding="utf-8")
        print(out, json.dumps({k: v for k, v in res.items() if not isinstance(v, dict | list)}, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
