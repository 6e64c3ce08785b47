"""`bracekit validate`: the compliance models against MuJoCo and a nonlinear static solve."""

from __future__ import annotations

import argparse
import sys
from contextlib import ExitStack
from pathlib import Path
from typing import Any

from bracekit.cli.common import OUT_HELP, OVERWRITE_HELP, CountFlag, needs, sigterm_as_interrupt

VALIDATION_FILES = ("validation.json", "validation.png")
#: The count flags, in the order of --help.
COUNTS = (
    CountFlag("--configs", 3, 1, None, "number of configurations along the path (default 3)"),
    CountFlag(
        "--tracking-points",
        5,
        0,
        None,
        "check points per strategy of the dynamic tracking check in MuJoCo (default 5; 0: skip it)",
    ),
)


def add_parser(sub: Any) -> None:
    """Add the command to the subparsers of ``bracekit``."""
    va = sub.add_parser("validate", help="check the compliance models against MuJoCo and a nonlinear static solve")
    va.add_argument("scenario", nargs="?", default="paper", help="scenario file or shipped name (default paper)")
    for count in COUNTS:
        count.add(va)
    va.add_argument("--json", action="store_true", help="print one JSON object")
    va.add_argument(
        "--out", type=Path, help=f"also write validation.json and validation.png into this folder; {OUT_HELP}"
    )
    va.add_argument("--overwrite", action="store_true", help=OVERWRITE_HELP)


def run(args: argparse.Namespace) -> int:
    """`bracekit validate`: run the checks, print them, 1 when a case failed (the rule: ``Verdict``); the exit code."""
    from bracekit.report.output import atomic_directory, prepare_output, to_json
    from bracekit.simulation.scenario import load_scenario

    needs("mujoco", "validate", "bracekit validate")
    needs("matplotlib", "viz", "bracekit validate")
    from bracekit.report.validation_figures import figure_validation
    from bracekit.validate.runner import DEFAULT_DIRECTIONS
    from bracekit.validate.suite import run_checks

    for count in COUNTS:
        count.check(args)
    scenario = load_scenario(args.scenario)
    with ExitStack() as stack:
        stack.enter_context(sigterm_as_interrupt())
        plan = None
        if args.out is not None:
            command = f"bracekit validate {args.scenario}"
            plan = stack.enter_context(
                prepare_output(args.out, overwrite=args.overwrite, files=VALIDATION_FILES, command=command)
            )
        bar = None
        if not args.json:
            from tqdm import tqdm

            total = args.configs * len(DEFAULT_DIRECTIONS)
            bar = tqdm(total=total, desc=f"{scenario.name}: validating", unit="case", file=sys.stderr)
        try:
            suite = run_checks(
                scenario, args.configs, tracking_points=args.tracking_points,
                progress=None if bar is None else bar.update,
            )  # fmt: skip
        finally:
            if bar is not None:
                bar.close()
        data = suite.to_json()
        if plan is not None:
            with atomic_directory(plan) as tmp:
                (tmp / "validation.json").write_text(to_json(data) + "\n", encoding="utf-8")
                figure_validation(suite.compliance, tmp / "validation.png")
    print(to_json(data) if args.json else suite.table_text())
    verdict = suite.verdict()
    if not verdict.passed:
        print(f"bracekit: error: {verdict.message()}", file=sys.stderr)
        return 1
    return 0
