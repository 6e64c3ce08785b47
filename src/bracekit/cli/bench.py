"""`bracekit bench`: the speed of the hot paths (runs the repository's benchmarks/bench.py)."""

from __future__ import annotations

import argparse
import importlib.util
import json
import tomllib
from pathlib import Path
from typing import Any

from bracekit.errors import InputError


def add_parser(sub: Any) -> None:
    """Add the command to the subparsers of ``bracekit``."""
    be = sub.add_parser("bench", help="measure the speed of the hot paths")
    be.add_argument("--json", action="store_true", help="print one JSON object")
    be.add_argument("--quick", action="store_true", help="fewer repetitions")
    be.add_argument(
        "--only",
        action="append",
        choices=("core", "runs", "sweep", "figures", "qp"),
        help="run only this part (repeat for several; default all: core hot paths, whole runs in process, sweep "
        "throughput on 1 and 2 Dask workers, the figures' overhead)",
    )
    be.add_argument(
        "--compare",
        type=Path,
        metavar="OTHER.json",
        help="print ratios new/old against a file of bracekit bench --json (another version or machine) and the "
        "speed goals (default: the repository's benchmarks/baseline-*.json when runs or sweep are measured)",
    )


def run(args: argparse.Namespace) -> int:
    """`bracekit bench`; the exit code."""
    module = _bench_module()
    parts = tuple(args.only) if args.only else module.PARTS
    results = module.run_benchmarks(quick=args.quick, parts=parts, compare=args.compare)
    module._sibling("bench_clearance").add_to(results, args.quick, parts)  # link clearance per sample
    print(json.dumps(results, indent=2) if args.json else results.get("table", ""))
    return 0


def _is_bracekit_repository(root: Path) -> bool:
    """Whether `root` is the clone this bracekit was installed from (its pyproject names bracekit, its src holds us)."""
    try:
        meta = tomllib.loads((root / "pyproject.toml").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return False
    here = Path(__file__).resolve().parents[1]
    return meta.get("project", {}).get("name") == "bracekit" and (root / "src" / "bracekit").resolve() == here


def _bench_module() -> Any:
    """benchmarks/bench.py of the repository bracekit was installed from (the timing code is not installed)."""
    here = Path(__file__).resolve()
    for root in here.parents:
        path = root / "benchmarks" / "bench.py"
        if path.is_file() and _is_bracekit_repository(root):
            spec = importlib.util.spec_from_file_location("bracekit_benchmarks", path)
            if spec is None or spec.loader is None:
                break
            module = importlib.util.module_from_spec(spec)
            spec.loader.exec_module(module)
            return module
    raise InputError(
        "bracekit bench runs the repository's benchmarks/ folder, which an installed package does not carry: "
        "install bracekit from a clone (pip install -e .) and run it there"
    )
