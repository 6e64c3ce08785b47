"""`bracekit sweep`: a design study of where to brace, whole-task runs of many candidates on Dask distributed."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from bracekit._linalg import show
from bracekit.cli.common import MAX_WORKERS, check_count, needs_sweep_extra, sigterm_as_interrupt
from bracekit.errors import InputError

SWEEP_FILES_HELP = (
    "output folder: the finished candidates are kept in OUT/.sweep as they finish (a re-run skips them) and the "
    "tables and figures are written whole at the end"
)


def add_parser(subparsers: Any) -> None:
    """Add the `sweep` command to the CLI's subparsers."""
    sw = subparsers.add_parser("sweep", help="design study: where to brace, whole-task runs of many candidates (Dask)")
    sw.add_argument("spec", help="a sweep spec TOML file or a shipped spec name (paper-links)")
    sw.add_argument("--out", type=Path, required=True, help=SWEEP_FILES_HELP)
    where = sw.add_mutually_exclusive_group()
    where.add_argument("--workers", type=int, help="start a local Dask cluster of N worker processes (default 1)")
    where.add_argument("--scheduler", help="use an existing Dask scheduler, e.g. tcp://HOST:8786")
    sw.add_argument("--limit", type=int, help="run only the first N candidates (a later run continues)")
    sw.add_argument("--no-screen", action="store_true", help="simulate every candidate (no batch screening)")
    sw.add_argument("--no-refine", action="store_true", help="skip the refinement of the best candidates")
    sw.add_argument("--no-figures", action="store_true", help="write the tables and summary only")
    sw.add_argument(
        "--overwrite",
        action="store_true",
        help="write into an --out that holds files bracekit did not write (they are kept, never replaced)",
    )
    sw.add_argument("--quiet", action="store_true", help="no progress bar")


def run(args: argparse.Namespace) -> int:
    """Run `bracekit sweep`; the exit code (0 when the sweep finished, whatever its candidates' feasibility)."""
    figures = not args.no_figures
    needs_sweep_extra("bracekit sweep", figures)
    if args.limit is not None:
        check_count("--limit", args.limit, 1)
    if args.workers is not None:
        check_count("--workers", args.workers, 1, MAX_WORKERS)
    if args.scheduler is not None:
        check_address(args.scheduler)
    from bracekit.report.output import prepare_output
    from bracekit.studies.sweep.engine import dask_client
    from bracekit.studies.sweep.report import FILES
    from bracekit.studies.sweep.spec import load_spec
    from bracekit.studies.sweep.store import WORK, check_state

    spec = load_spec(args.spec)
    workers = None if args.scheduler is not None else (args.workers or 1)
    # OUT is checked and locked first (its work folder .sweep too: no symbolic link, and another spec's partial
    # results are refused) before any cluster starts; OUT is made only once the cluster answers, so a scheduler
    # that cannot be reached leaves nothing behind
    command = f"bracekit sweep {args.spec}"
    with (
        sigterm_as_interrupt(),
        prepare_output(args.out, overwrite=args.overwrite, files=FILES, command=command, keep=(WORK,)) as plan,
    ):
        check_state(plan.path, spec)
        with dask_client(workers, args.scheduler) as client:
            _sweep(args, spec, plan, client, figures)
    return 0


def _sweep(args: argparse.Namespace, spec: Any, plan: Any, client: Any, figures: bool) -> None:
    """The sweep in the checked, locked OUT: rows saved in OUT/.sweep, the tables and figures written whole."""
    from bracekit.report.output import atomic_directory
    from bracekit.studies.sweep.engine import run_sweep
    from bracekit.studies.sweep.report import summary, table_markdown, write_outputs
    from bracekit.studies.sweep.store import import_writers

    out: Path = args.out
    import_writers()  # while the candidates run
    try:
        plan.path.mkdir(exist_ok=True)
    except OSError as exc:
        raise InputError(f"cannot make {out}: {exc.strerror or exc}") from None
    result = run_sweep(
        spec,
        plan.path,
        client,
        limit=args.limit,
        screen=False if args.no_screen else None,
        refine=not args.no_refine,
        progress=not args.quiet,
    )
    with atomic_directory(plan) as tmp:
        names = write_outputs(result, tmp, figures=figures)
    print(table_markdown(result), end="")
    s = summary(result)
    rerun = f"{s['rerun_invalid_rows']} saved rows invalid and run again, " if s["rerun_invalid_rows"] else ""
    print(
        f"{s['simulated_now']} simulated now, {s['reused_from_earlier_runs']} reused, {rerun}"
        f"{s['screened_out']} screened out; wrote {', '.join(names)} to {out}/",
        file=sys.stderr,
    )
    if not any(r["completed"] for r in result.rows):
        print(
            f"warning: no candidate completed a run ({len(result.rows)} screened out or failed); the tables list "
            "them with their reasons (try --no-screen or another --limit)",
            file=sys.stderr,
        )


def check_address(address: str) -> None:
    """InputError at once for a scheduler address whose port is not a number from 1 to 65535."""
    from urllib.parse import urlsplit

    text = address if "://" in address else f"tcp://{address}"
    try:
        port = urlsplit(text).port
    except ValueError:
        raise InputError(
            f"--scheduler {show(address, 200)} has no valid port (a number from 1 to 65535); give e.g. tcp://HOST:8786"
        ) from None
    if port == 0:
        raise InputError(
            f"--scheduler {show(address, 200)}: port 0 is not a scheduler's port; give e.g. tcp://HOST:8786"
        )
