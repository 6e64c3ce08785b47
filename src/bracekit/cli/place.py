"""`bracekit place`: where to brace, continuously — pad place and start posture optimised, then the whole task."""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any

from bracekit.cli.common import needs_sweep_extra, sigterm_as_interrupt
from bracekit.errors import InputError

#: Most seeds per link, places refined and refinement rounds (each a batch of optimisations or whole-task runs).
MAX_PLACE_COUNT = 64

#: Most local Dask worker processes of --workers.
MAX_WORKERS = 256


def add_parser(subparsers: Any) -> None:
    """Add the `place` command to the CLI's subparsers."""
    pl = subparsers.add_parser(
        "place", help="where to brace, continuously: pad place and posture optimised, best places over the task (Dask)"
    )
    pl.add_argument("source", metavar="SCENARIO|SPEC", help="a sweep spec or scenario (TOML file or shipped name)")
    pl.add_argument("--out", type=Path, required=True, help="output folder, written whole at the end")
    pl.add_argument("--workers", type=int, default=1, help="local Dask worker processes (default 1)")
    pl.add_argument("--seeds", type=int, default=1, help="inner optimisations per link (default 1)")
    pl.add_argument("--top", type=int, default=2, help="places run over the whole task and refined (default 2)")
    pl.add_argument(
        "--refine",
        type=int,
        default=1,
        help="compass rounds on fraction and angle, one batch of 4 runs each (default 1)",
    )
    pl.add_argument(
        "--radius",
        type=float,
        default=0.3,
        help="posture radius R (rad): the start posture within R of the reference start (default 0.3; 0: no bound)",
    )
    pl.add_argument(
        "--surface",
        choices=("capsule", "collision"),
        default="capsule",
        help="the pad on the capsule about the link's joint line (default) or on its collision surface",
    )
    pl.add_argument("--objective", choices=("Ci", "ct"), default="Ci", help="inner objective: C_i or c_t (default C_i)")
    pl.add_argument("--no-figures", action="store_true", help="write the tables, summary and best.toml only")
    pl.add_argument(
        "--overwrite",
        action="store_true",
        help="write into an --out that holds files bracekit did not write (they are kept, never replaced)",
    )


def run(args: argparse.Namespace) -> int:
    """Run `bracekit place`; 0 when it finished (even with no feasible place: the table says why), 1 then too."""
    figures = not args.no_figures
    needs_sweep_extra("bracekit place", figures)
    if not 1 <= args.workers <= MAX_WORKERS:
        raise InputError(f"--workers must be from 1 to {MAX_WORKERS} (local worker processes), got {args.workers}")
    for name in ("seeds", "top"):
        if not 1 <= getattr(args, name) <= MAX_PLACE_COUNT:
            raise InputError(f"--{name} must be from 1 to {MAX_PLACE_COUNT}, got {getattr(args, name)}")
    if not (math.isfinite(args.radius) and args.radius >= 0.0):
        raise InputError(f"--radius must be a finite angle >= 0 rad (0: no bound), got {args.radius}")
    if not 0 <= args.refine <= MAX_PLACE_COUNT:
        raise InputError(f"--refine must be from 0 to {MAX_PLACE_COUNT}, got {args.refine}")
    from bracekit.report.output import atomic_directory, prepare_output
    from bracekit.studies.place.engine import PlaceSettings, check_spec, run_place
    from bracekit.studies.place.inner import InnerSettings
    from bracekit.studies.place.report import FILES, table_markdown, write_outputs
    from bracekit.studies.place.spec import load_place_spec
    from bracekit.studies.sweep.engine import dask_client

    spec = load_place_spec(args.source)
    check_spec(spec)
    settings = PlaceSettings(
        inner=InnerSettings(measure=args.objective, posture_radius=args.radius or None, surface=args.surface),
        seeds=args.seeds,
        top=args.top,
        refine_rounds=args.refine,
    )
    with (
        sigterm_as_interrupt(),
        prepare_output(
            args.out, overwrite=args.overwrite, files=FILES, command=f"bracekit place {args.source}"
        ) as plan,
    ):
        with dask_client(args.workers) as client:
            result = run_place(spec, client, settings)
        with atomic_directory(plan) as tmp:
            names = write_outputs(result, tmp, figures=figures)
    print(table_markdown(result), end="")
    print(f"wrote {', '.join(names)} to {args.out}/", file=sys.stderr)
    if result.best is None:
        print("no feasible place found: the table lists each run's reason (try more --seeds or --top)", file=sys.stderr)
        return 1
    print(f"run the best place: bracekit run {args.out}/best.toml --out DIR", file=sys.stderr)
    return 0
