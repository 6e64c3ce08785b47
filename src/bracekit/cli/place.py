"""`bracekit place`: where to brace, continuously — pad place and start posture optimised, then the whole task."""

from __future__ import annotations

import argparse
import math
import os
import sys
from collections.abc import Iterator
from concurrent.futures import Future, ThreadPoolExecutor
from contextlib import AbstractContextManager, contextmanager
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
        default=None,
        help="the pad on the capsule about the link's joint line or on its collision surface (default: the "
        "collision surface when the spec has an 'angle' axis, as the sweep's candidates, else the capsule)",
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
    from bracekit.report.output import prepare_output
    from bracekit.studies.place.engine import check_spec
    from bracekit.studies.place.report import FILES, table_markdown
    from bracekit.studies.place.spec import load_place_spec
    from bracekit.studies.sweep.engine import dask_client

    spec = load_place_spec(args.source)
    check_spec(spec)
    command = f"bracekit place {args.source}"
    with (
        sigterm_as_interrupt(),
        prepare_output(args.out, overwrite=args.overwrite, files=FILES, command=command) as plan,
        _forked_workers(),
        _background(dask_client(args.workers)) as client_future,  # the cluster starts while q_ref is solved here
    ):
        result, names = _run(args, spec, client_future, plan, figures)
    print(table_markdown(result), end="")
    print(f"wrote {', '.join(names)} to {args.out}/", file=sys.stderr)
    if result.best is None:
        print("no feasible place found: the table lists each run's reason (try more --seeds or --top)", file=sys.stderr)
        return 1
    print(f"run the best place: bracekit run {args.out}/best.toml --out DIR", file=sys.stderr)
    return 0


def _run(
    args: argparse.Namespace, spec: Any, client_future: Future[Any], plan: Any, figures: bool
) -> tuple[Any, list[str]]:
    """The placement once the cluster is starting (`client_future`: its client), its outputs written whole."""
    from bracekit.report.output import atomic_directory
    from bracekit.studies.place.engine import PlaceSettings, prepare, run_place
    from bracekit.studies.place.inner import InnerSettings
    from bracekit.studies.place.report import write_outputs
    from bracekit.studies.place.spec import default_surface

    surface = args.surface or default_surface(spec)
    settings = PlaceSettings(
        inner=InnerSettings(measure=args.objective, posture_radius=args.radius or None, surface=surface),
        seeds=args.seeds,
        top=args.top,
        refine_rounds=args.refine,
    )
    prepared = prepare(spec, settings)
    client = client_future.result()
    result = run_place(spec, client, settings, prepared)
    with atomic_directory(plan) as tmp:
        names = write_outputs(result, tmp, figures=figures)
    return result, names


#: What the workers run: imported by the fork server before it forks them, so none of them imports it again.
WORKER_MODULES = (
    "distributed",
    "scipy.optimize",
    "bracekit.studies.place.inner",
    "bracekit.studies.place.outer",
    "bracekit.studies.sweep.context",
    "bracekit.validate.contacts",
    "bracekit.validate.inputs",
    "bracekit.validate.mujoco_check",
)


@contextmanager
def _forked_workers() -> Iterator[None]:
    """Local workers forked from a fork server (Dask's ``forkserver`` method) that imported :data:`WORKER_MODULES`.

    The server starts here, on this thread, before the cluster's thread exists: a fresh process, one thread, in
    the workers' environment (:data:`bracekit.studies.sweep.engine.WORKER_ENV`: one numba, OpenMP and BLAS
    thread), that imports the placement's modules (Pinocchio, SciPy, MuJoCo's check) while this process solves
    the reference start. Every worker, and one the nanny restarts, is forked from that server: it starts with
    the modules imported, numba's and BLAS's settings its environment's, and no lock another thread held (a
    worker forked from this process could inherit a lock the solving thread held at that moment, and this
    process's numba and BLAS settings). A spawned worker would import everything again, each (seconds under load).
    """
    import multiprocessing.forkserver

    import dask
    import distributed.utils

    from bracekit.studies.sweep.engine import WORKER_ENV

    with dask.config.set({"distributed.worker.multiprocessing-method": "forkserver"}):
        context = distributed.utils.get_mp_context()  # Dask's own preload list set first, replaced below
        context.set_forkserver_preload(list(WORKER_MODULES))
        saved = {k: os.environ.get(k) for k in WORKER_ENV}
        os.environ.update(WORKER_ENV)
        try:
            multiprocessing.forkserver.ensure_running()  # the server's environment: this one, now
        finally:
            for key, value in saved.items():
                if value is None:
                    os.environ.pop(key, None)
                else:
                    os.environ[key] = value
        yield


@contextmanager
def _background(manager: AbstractContextManager[Any]) -> Iterator[Future[Any]]:
    """`manager` entered on a thread (its value as a Future) and exited here, with this block's exception if any.

    On an error in the block (bad input, Ctrl-C) it waits for the entry to finish, then exits the manager.
    """
    pool = ThreadPoolExecutor(1)
    entered = pool.submit(manager.__enter__)
    pool.shutdown(wait=False)
    try:
        yield entered
    except BaseException as exc:
        if entered.exception() is None and manager.__exit__(type(exc), exc, exc.__traceback__):
            return
        raise
    manager.__exit__(None, None, None)
