"""`bracekit place`: where to brace, continuously — pad place and start posture optimised, then the whole task."""

from __future__ import annotations

import argparse
import gc
import math
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from bracekit.cli.common import MAX_WORKERS, CountFlag, needs, needs_sweep_extra, sigterm_as_interrupt
from bracekit.errors import InputError

#: Most seeds per link, places refined and refinement rounds (each a batch of optimisations or whole-task runs).
MAX_PLACE_COUNT = 64

#: The count flags, in the order of --help.
COUNTS = (
    CountFlag("--workers", 1, 1, MAX_WORKERS, "local Dask worker processes (default 1)"),
    CountFlag("--seeds", 1, 1, MAX_PLACE_COUNT, "inner optimisations per link (default 1)"),
    CountFlag(
        "--top",
        1,
        1,
        MAX_PLACE_COUNT,
        "places run over the whole task at once, the next while none is feasible (default 1)",
    ),
    CountFlag(
        "--refine", 1, 0, MAX_PLACE_COUNT, "compass rounds on fraction and angle, one batch of 4 runs each (default 1)"
    ),
)


def add_parser(subparsers: Any) -> None:
    """Add the `place` command to the CLI's subparsers."""
    pl = subparsers.add_parser(
        "place", help="where to brace, continuously: pad place and posture optimised, best places over the task (Dask)"
    )
    pl.add_argument("source", metavar="SCENARIO|SPEC", help="a sweep spec or scenario (TOML file or shipped name)")
    pl.add_argument("--out", type=Path, required=True, help="output folder, written whole at the end")
    for count in COUNTS:
        count.add(pl)
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
    needs("threadpoolctl", "sweep", "bracekit place")  # each forked worker's BLAS threads (WorkerThreads)
    for count in COUNTS:
        count.check(args)
    if not (math.isfinite(args.radius) and args.radius >= 0.0):
        raise InputError(f"--radius must be a finite angle >= 0 rad (0: no bound), got {args.radius}")
    from bracekit.report.output import prepare_output
    from bracekit.studies.place.engine import check_spec, prepare
    from bracekit.studies.place.report import FILES, table_markdown
    from bracekit.studies.place.spec import load_place_spec
    from bracekit.studies.sweep.engine import dask_client

    spec = load_place_spec(args.source)
    check_spec(spec)
    command = f"bracekit place {args.source}"
    settings = _settings(args, spec)
    with (
        sigterm_as_interrupt(),
        prepare_output(args.out, overwrite=args.overwrite, files=FILES, command=command) as plan,
        _forked_workers() as fork,
    ):
        # the task context (the free-space run) here, before a worker forks: they start with numba's kernels
        prepared = prepare(spec, settings, context=fork)
        if fork:
            gc.freeze()
        with dask_client(args.workers) as client:  # no thread of this process runs while a worker forks
            result, names = _run(spec, client, plan, figures, settings, prepared)
    print(table_markdown(result), end="")
    print(f"wrote {', '.join(names)} to {args.out}/", file=sys.stderr)
    if result.best is None:
        print("no feasible place found: the table lists each run's reason (try more --seeds or --top)", file=sys.stderr)
        return 1
    print(f"run the best place: bracekit run {args.out}/best.toml --out DIR", file=sys.stderr)
    return 0


def _settings(args: argparse.Namespace, spec: Any) -> Any:
    """The placement's settings from the command line."""
    from bracekit.studies.place.engine import PlaceSettings
    from bracekit.studies.place.inner import InnerSettings
    from bracekit.studies.place.spec import default_surface

    surface = args.surface or default_surface(spec)
    return PlaceSettings(
        inner=InnerSettings(measure=args.objective, posture_radius=args.radius or None, surface=surface),
        seeds=args.seeds,
        top=args.top,
        refine_rounds=args.refine,
    )


def _run(spec: Any, client: Any, plan: Any, figures: bool, settings: Any, prepared: Any) -> tuple[Any, list[str]]:
    """The placement on the cluster of `client`, its outputs written whole."""
    from bracekit.report.output import atomic_directory
    from bracekit.studies.place.engine import run_place
    from bracekit.studies.place.report import write_outputs
    from bracekit.studies.place.workers import WorkerThreads

    client.register_plugin(WorkerThreads())  # every worker, and one the nanny restarts, before its first task
    result = run_place(spec, client, settings, prepared)
    with atomic_directory(plan) as tmp:
        names = write_outputs(result, tmp, figures=figures)
    return result, names


#: What the workers run: imported here before they are forked, so none of them imports it again.
WORKER_MODULES = (
    "scipy.optimize",
    "bracekit.studies.place.inner",
    "bracekit.studies.place.outer",
    "bracekit.studies.place.workers",
    "bracekit.studies.sweep.context",
    "bracekit.validate.contacts",
    "bracekit.validate.inputs",
    "bracekit.validate.mujoco_check",
    "threadpoolctl",  # the worker plugin's (WorkerThreads), which each worker runs before its first task
)


@contextmanager
def _forked_workers() -> Iterator[bool]:
    """Local workers forked from this process (Dask's ``fork`` method), :data:`WORKER_MODULES` imported first.

    A spawned worker imports bracekit, Pinocchio, SciPy and MuJoCo again (seconds of CPU each, more than the
    placement's own work on a loaded machine); a forked one starts with them. The command starts the cluster
    before it solves anything, so no thread of its own runs while a worker is forked (Dask's loop thread forks,
    this one waits); :class:`~bracekit.studies.place.workers.WorkerThreads` then sets each worker's numba and
    BLAS threads. Not when this process already runs numba's threads (a child would inherit a thread pool
    without its threads): then spawned, as the sweep's.

    The imports run without the garbage collector, and the objects imported so far are then moved out of its
    generations (``gc.freeze``, as Python's documentation advises before a fork): the workers' collections and
    this process's collection at exit no longer traverse the libraries' objects (a tenth or two of a second
    each), nor copy their pages (:func:`bracekit.report.frozen_heap.frozen_heap`). On leaving, they are put back
    (``gc.unfreeze``); a process that had frozen objects of its own before is left as it was: a caller of
    :func:`bracekit.cli.main.main` keeps its collector as it was.
    """
    import gc
    import importlib

    from bracekit.report.frozen_heap import frozen_heap

    collecting = gc.isenabled()
    gc.disable()  # the imports create objects that all stay: no collection during them
    try:
        import dask
        import distributed  # noqa: F401  (its configuration defaults first: leaving the `set` below restores the key only)

        for name in WORKER_MODULES:
            importlib.import_module(name)
    finally:
        if collecting:
            gc.enable()
    fork = not _numba_threads_started()
    with frozen_heap(), dask.config.set({"distributed.worker.multiprocessing-method": "fork" if fork else "spawn"}):
        yield fork


def _numba_threads_started() -> bool:
    """Whether numba's thread pool was started in this process (True when it cannot tell)."""
    from bracekit.studies.place.workers import numba_threads_started

    return numba_threads_started()
