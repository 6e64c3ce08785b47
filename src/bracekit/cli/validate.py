"""`bracekit validate`: the compliance models against MuJoCo and a nonlinear static solve."""

from __future__ import annotations

import argparse
import sys
from contextlib import ExitStack
from pathlib import Path
from typing import Any

from bracekit.cli.common import OUT_HELP, OVERWRITE_HELP, needs, sigterm_as_interrupt
from bracekit.errors import InputError

VALIDATION_FILES = ("validation.json", "validation.png")


def add_parser(sub: Any) -> None:
    """Add the command to the subparsers of ``bracekit``."""
    va = sub.add_parser("validate", help="check the compliance models against MuJoCo and a nonlinear static solve")
    va.add_argument("scenario", nargs="?", default="paper", help="scenario file or shipped name (default paper)")
    va.add_argument("--configs", type=int, default=3, help="number of configurations along the path (default 3)")
    va.add_argument(
        "--tracking-points",
        type=int,
        default=5,
        help="check points per strategy of the dynamic tracking check in MuJoCo (default 5; 0: skip it)",
    )
    va.add_argument("--json", action="store_true", help="print one JSON object")
    va.add_argument(
        "--out", type=Path, help=f"also write validation.json and validation.png into this folder; {OUT_HELP}"
    )
    va.add_argument("--overwrite", action="store_true", help=OVERWRITE_HELP)


def run(args: argparse.Namespace) -> int:
    """`bracekit validate`: run the checks, print them, 1 when a case failed; the exit code."""
    from bracekit.report.output import atomic_directory, prepare_output, to_json
    from bracekit.simulation.scenario import load_scenario

    needs("mujoco", "validate", "bracekit validate")
    needs("matplotlib", "viz", "bracekit validate")
    from bracekit.report.validation_figures import figure_validation
    from bracekit.validate import run_validation
    from bracekit.validate.runner import DEFAULT_DIRECTIONS

    if args.configs < 1:
        raise InputError(f"--configs must be at least 1, got {args.configs}")
    if args.tracking_points < 0:
        raise InputError(f"--tracking-points must be 0 (skip) or more, got {args.tracking_points}")
    scenario = load_scenario(args.scenario)
    if len(scenario.braced.braces) > 1:
        return _validate_braces(args, scenario)
    from bracekit.validate.runner import path_samples

    if args.configs > path_samples(scenario):
        raise InputError(
            f"--configs {args.configs} is more than the {path_samples(scenario)} samples of the path of scenario "
            f"'{scenario.name}'; give at most {path_samples(scenario)}"
        )
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
            report = run_validation(scenario, configs=args.configs, progress=None if bar is None else bar.update)
        finally:
            if bar is not None:
                bar.close()
        data = report.to_json()
        from bracekit.validate.runner import (
            run_capacity_validation,
            run_holding_validation,
            run_preloaded_validation,
        )

        extra: list[Any] = []  # the further checks: preloaded model, holding statics, capacity ramps
        configs = report.configurations
        pre = run_preloaded_validation(scenario, configs=configs)
        data["preloaded"] = pre.to_json()
        extra.append(pre)
        holding = None
        if scenario.holding.active:
            holding = run_holding_validation(scenario, configs=configs)
            data["holding"] = holding.to_json()
            extra.append(holding)
        tracking = None
        if args.tracking_points > 0:
            from bracekit.validate.tracking import run_tracking_validation

            tracking = run_tracking_validation(scenario, points=args.tracking_points)
            data["tracking"] = tracking.to_json()
            extra.append(tracking)
        capacity = None
        if scenario.holding.preload > 0.0 and scenario.holding.wrenches is not None:
            capacity = run_capacity_validation(scenario, configs=configs)
            data["capacity"] = capacity.to_json()
            extra.append(capacity)
        if plan is not None:
            with atomic_directory(plan) as tmp:
                (tmp / "validation.json").write_text(to_json(data) + "\n", encoding="utf-8")
                figure_validation(report, tmp / "validation.png")
    print(to_json(data) if args.json else report.table_text())
    if not args.json:
        for part in extra:
            print(part.table_text())
    counts = report.counts()
    failed = counts.get("failed", 0) + pre.counts()["failed"]
    if holding is not None:
        s = holding.summary()
        failed += s["counts"]["failed"] + len(s["margin_disagreements"])
    if capacity is not None:
        failed += capacity.counts()["failed"] + capacity.counts()["disagrees"]
    if tracking is not None:
        failed += len(tracking.disagreements())
    if failed > 0 or report.model_stats("constrained")["n_cases"] == 0:
        print(f"bracekit: error: {failed} validation case(s) failed", file=sys.stderr)
        return 1
    return 0


def _validate_braces(args: argparse.Namespace, scenario: Any) -> int:
    """``validate`` for a scenario with several braces: the stacked constrained model against MuJoCo and statics."""
    from bracekit.report.output import atomic_directory, prepare_output, to_json
    from bracekit.validate.multi_brace import run_several_braces_validation, several_braces_text

    with ExitStack() as stack:
        stack.enter_context(sigterm_as_interrupt())
        plan = None
        if args.out is not None:
            command = f"bracekit validate {args.scenario}"
            files = ("validation.json",)
            plan = stack.enter_context(prepare_output(args.out, overwrite=args.overwrite, files=files, command=command))
        data = run_several_braces_validation(scenario, configs=args.configs)
        if plan is not None:
            with atomic_directory(plan) as tmp:
                (tmp / "validation.json").write_text(to_json(data) + "\n", encoding="utf-8")
    print(to_json(data) if args.json else several_braces_text(data))
    s = data["summary"]
    median = s["constrained_vs_mujoco"]["median"]
    if s["n_failed"] or s["n_ok"] == 0 or median is None or median > 0.01:
        print(f"bracekit: error: {s['n_failed']} case(s) failed or the median error exceeds 1 %", file=sys.stderr)
        return 1
    return 0
