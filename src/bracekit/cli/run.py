"""`bracekit run`: a scenario's Table I, figures, trajectories and scene, written whole into --out."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from bracekit.cli import view as view_cli
from bracekit.cli.common import OUT_HELP, OVERWRITE_HELP, needs, sigterm_as_interrupt


def add_parser(sub: Any) -> None:
    """Add the command to the subparsers of ``bracekit``."""
    run = sub.add_parser("run", help="run a scenario: Table I, Figures 2-4 and the animation")
    run.add_argument("scenario", help="a scenario TOML file or a shipped name (paper)")
    run.add_argument(
        "--out", type=Path, default=Path("bracekit-out"), help=f"output folder (default bracekit-out); {OUT_HELP}"
    )
    run.add_argument("--overwrite", action="store_true", help=OVERWRITE_HELP)
    run.add_argument("--gradient", choices=("analytic", "finite-difference"), help="how ∇g is computed")
    run.add_argument(
        "--compliance-model",
        choices=("constrained", "projection", "preloaded"),
        help="model of summary.json (preloaded: with gravity or a preload, C_i of the preloaded compliance)",
    )
    run.add_argument("--no-figures", action="store_true", help="write the table, summary and trajectories only")
    run.add_argument("--quiet", action="store_true", help="no progress bar")
    view_cli.add_run_flags(run)


def run(args: argparse.Namespace) -> int:
    """`bracekit run SCENARIO`: simulate, write the outputs whole into --out; 1 when a strategy failed."""
    from bracekit.report import write_run
    from bracekit.report.output import prepare_output, run_files
    from bracekit.report.table import table_markdown
    from bracekit.simulation.run import run_scenario, total_steps
    from bracekit.simulation.scenario import load_scenario
    from bracekit.viewer.link_meshes import link_meshes

    scenario = load_scenario(args.scenario)
    figures = not args.no_figures
    if figures:  # before any computation
        needs("matplotlib", "viz", "bracekit run with figures (or pass --no-figures)")
    view_cli.check_run_flags(args)
    with (
        sigterm_as_interrupt(),
        prepare_output(
            args.out,
            overwrite=args.overwrite,
            files=run_files(figures, meshes=bool(link_meshes(scenario.robot))),
            command=f"bracekit run {args.scenario}",
        ) as plan,
    ):
        bar = None
        if not args.quiet:
            from tqdm import tqdm

            bar = tqdm(total=total_steps(scenario), desc=f"{scenario.name}: simulating", unit="step", file=sys.stderr)
        try:
            result = run_scenario(
                scenario,
                gradient=args.gradient,
                compliance_model=args.compliance_model,
                progress=None if bar is None else bar.update,
            )
        finally:
            if bar is not None:
                bar.close()
        written = write_run(
            result,
            plan,
            figures=figures,
            progress=None if args.quiet else (lambda name: print(f"writing {name}", file=sys.stderr)),
        )
    print(table_markdown(result.summaries, scenario.name))
    for model, runs in result.trajectories.items():  # every model's runs: the exit code counts them all
        for name, tr in runs.items():
            if not tr.completed:
                print(f"bracekit: warning: {name} ({model} model) did not complete: {tr.failure}", file=sys.stderr)
    print(f"wrote {len(written)} files to {args.out}/: " + ", ".join(p.name for p in written))
    if args.view:
        view_cli.serve_until_stopped(args.out, port=args.view_port)
    return 0 if result.completed else 1
