"""`bracekit sweep`: a design study of where to brace, whole-task runs of many candidates on Dask distributed."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from bracekit.cli.common import needs, sigterm_as_interrupt
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


def _foreign(out: Path) -> list[str]:
    """Entries of OUT that neither a bracekit output manifest lists nor are the sweep's work folder."""
    from bracekit.report.output import MANIFEST
    from bracekit.studies.sweep.store import WORK

    if not out.is_dir():
        return []
    ours = {MANIFEST, WORK}
    try:
        data = json.loads((out / MANIFEST).read_text(encoding="utf-8"))
        if isinstance(data, dict) and data.get("written_by") == "bracekit" and isinstance(data.get("files"), list):
            ours |= {str(n) for n in data["files"]}
    except (OSError, ValueError):
        pass
    return sorted(n.name for n in out.iterdir() if n.name not in ours)


def run(args: argparse.Namespace) -> int:
    """Run `bracekit sweep`; the exit code (0 when the sweep finished, whatever its candidates' feasibility)."""
    needs("distributed", "sweep", "bracekit sweep")
    needs("pyarrow", "sweep", "bracekit sweep")
    figures = not args.no_figures
    if figures:
        needs("matplotlib", "sweep", "bracekit sweep with figures (or pass --no-figures)")
    if args.limit is not None and args.limit < 1:
        raise InputError(f"--limit must be at least 1, got {args.limit}")
    if args.workers is not None and args.workers < 1:
        raise InputError(f"--workers must be at least 1, got {args.workers}")
    from bracekit.report.output import atomic_directory, prepare_output
    from bracekit.studies.sweep.engine import dask_client, run_sweep
    from bracekit.studies.sweep.report import FILES, summary, table_markdown, write_outputs
    from bracekit.studies.sweep.spec import load_spec
    from bracekit.studies.sweep.store import check_state

    spec = load_spec(args.spec)
    out: Path = args.out
    foreign = _foreign(out)
    if foreign and not args.overwrite:
        raise InputError(
            f"{out} holds files bracekit did not write: {', '.join(foreign[:5])}; choose another --out or pass "
            "--overwrite (they are kept)"
        )
    check_state(out, spec)  # refuses another spec's partial results before any cluster starts
    workers = None if args.scheduler is not None else (args.workers or 1)
    # OUT is checked and locked first; it is made only once the cluster answers, so a scheduler that cannot be
    # reached leaves nothing behind
    with (
        sigterm_as_interrupt(),
        prepare_output(out, overwrite=True, files=FILES, command=f"bracekit sweep {args.spec}") as plan,
        dask_client(workers, args.scheduler) as client,
    ):
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
    print(
        f"{s['simulated_now']} simulated now, {s['reused_from_earlier_runs']} reused, "
        f"{s['screened_out']} screened out; "
        f"wrote {', '.join(names)} to {out}/",
        file=sys.stderr,
    )
    if not any(r["completed"] for r in result.rows):
        print(
            f"warning: no candidate completed a run ({len(result.rows)} screened out or failed); the tables list "
            "them with their reasons (try --no-screen or another --limit)",
            file=sys.stderr,
        )
    return 0
