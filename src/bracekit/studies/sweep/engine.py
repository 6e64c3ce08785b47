"""Running a sweep on Dask distributed: a local cluster of worker processes, or an existing scheduler.

The steps: the task contexts (a reference start, then one free-space run per task), the batch screening (one
task per context), the candidates that pass (one task each, run from the reference start its worker solves
once per task, while the free-space runs are under way; as they finish, their rows get the free-space columns
and are saved), then the refinement
of the best feasible candidates, and the final tables. Rows are sorted by candidate order, so the tables are
the same whatever the number of workers or the order in which they finish.
"""

from __future__ import annotations

import logging
import sys
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from bracekit._linalg import show
from bracekit.errors import InputError
from bracekit.studies.sweep.candidates import Candidate, expand
from bracekit.studies.sweep.context import TaskContext, context_inputs, task_context
from bracekit.studies.sweep.evaluate import (
    RESULT_COLUMNS,
    empty_row,
    evaluate_held,
    input_columns,
    judge,
    with_free_space,
)
from bracekit.studies.sweep.rows import row_problem
from bracekit.studies.sweep.screen import Screened, screen_context, select
from bracekit.studies.sweep.spec import SweepSpec
from bracekit.studies.sweep.store import UNREADABLE, RowStore

#: Environment of local worker processes: one thread for numba and BLAS (one candidate per worker at a time).
WORKER_ENV = {"NUMBA_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
#: Dask's setting of local workers: no statistical profiler (every 10 ms it samples the task's stack for a
#: dashboard a local cluster does not serve; ≈ 4 % of a worker's time).
NO_PROFILER = {"distributed.worker.profile.enabled": False}
#: The only address a local cluster listens on (scheduler, workers, nannies and the scheduler's HTTP routes).
LOOPBACK = "127.0.0.1"
#: Seconds to wait for a scheduler to answer.
CONNECT_TIMEOUT = 10.0
#: Candidates screened by one task (a candidate takes ≈ 10 ms): the screening of a context spread over the workers.
SCREEN_CHUNK = 16
#: Seconds allowed beyond CONNECT_TIMEOUT for the whole check of the address before giving up.
GRACE = 2.0


@dataclass
class SweepRun:
    """What a sweep run did. ``rows``: one per candidate run (or screened), in candidate order."""

    spec: SweepSpec
    rows: list[dict[str, Any]]
    refined: list[dict[str, Any]] = field(default_factory=list)
    evaluated: int = 0
    reused: int = 0
    screened_out: int = 0
    rerun: int = 0
    timings: dict[str, float] = field(default_factory=dict)
    workers: int = 0


def probe(scheduler: str, timeout: float) -> str | None:
    """Ask the address for its identity in Dask's protocol, within `timeout` s overall; why not, or None if it is one.

    Runs its own event loop in a daemon thread and cancels the attempt at the deadline, so something that is not
    a Dask scheduler (an HTTP server such as the dashboard, which may answer garbage or nothing) leaves nothing
    running behind.
    """
    import asyncio

    from distributed import Security
    from distributed.comm.core import connect as comm_connect

    async def ask() -> Any:  # with the client's connection arguments (TLS from the Dask config), as Client() does
        comm = await comm_connect(scheduler, timeout=timeout, **Security().get_connection_args("client"))
        try:
            await comm.write({"op": "identity", "reply": True})
            return await comm.read()
        finally:
            comm.abort()

    box: dict[str, Any] = {}

    def attempt() -> None:
        try:
            box["answer"] = asyncio.run(asyncio.wait_for(ask(), timeout))
        except Exception as exc:  # any failure (even a MemoryError on garbage) is one line below
            box["error"] = exc

    thread = threading.Thread(target=attempt, name="bracekit-dask-probe", daemon=True)
    thread.start()
    thread.join(timeout + GRACE)
    if thread.is_alive():
        return f"no answer within {timeout + GRACE:g} s"
    if "error" in box:
        exc = box["error"]
        if isinstance(exc, TimeoutError):
            return f"no answer in Dask's protocol within {timeout:g} s"
        return " ".join(f"{type(exc).__name__}: {exc}".split())[:200]
    answer = box.get("answer")
    if not isinstance(answer, dict) or answer.get("type") != "Scheduler":
        kind = answer.get("type") if isinstance(answer, dict) else None
        return f"a {kind}, not a Dask scheduler" if isinstance(kind, str) else "not a Dask scheduler"
    return None


def connect(scheduler: str, timeout: float) -> Any:
    """A ``distributed.Client`` of the Dask scheduler at `scheduler`, checked to be one within `timeout` s first.

    Raises:
        InputError: no Dask scheduler answered at the address in time, or connecting failed in any way.
    """
    from distributed import Client

    hint = "give a running Dask scheduler's address, e.g. tcp://HOST:8786 (the scheduler port, not the dashboard's)"
    where = f"cannot connect to the Dask scheduler at {show(scheduler, 200)}"
    why = probe(scheduler, timeout)
    if why is not None:
        raise InputError(f"{where} ({why}); {hint}")
    try:
        return Client(scheduler, timeout=timeout)
    except Exception as exc:  # it answered the probe: a failure now is reported the same way
        text = " ".join(f"{type(exc).__name__}: {exc}".split())[:200]
        raise InputError(f"{where} ({text}); {hint}") from None


@contextmanager
def dask_client(
    workers: int | None = None, scheduler: str | None = None, *, connect_timeout: float | None = None
) -> Iterator[Any]:
    """A Dask client: of a new LocalCluster (`workers` processes, one thread each) or of the scheduler at an address.

    `connect_timeout` (s, default CONNECT_TIMEOUT) bounds the wait for a scheduler to answer.

    Raises:
        InputError: both or neither given, a bad worker count, or no scheduler answers at the address.
    """
    from distributed import Client, LocalCluster

    if (workers is None) == (scheduler is None):
        raise InputError("give a number of local workers or a scheduler address, not both")
    if scheduler is not None:
        client = connect(scheduler, CONNECT_TIMEOUT if connect_timeout is None else connect_timeout)
        try:
            yield client
        finally:
            client.close()
        return
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise InputError(f"--workers must be a whole number ≥ 1, got {workers!r}")
    cluster = LocalCluster(
        n_workers=workers,
        threads_per_worker=1,
        processes=True,
        host=LOOPBACK,
        dashboard_address=None,  # no dashboard; the scheduler's HTTP routes on a free port of loopback only
        scheduler_kwargs={"dashboard": False, "dashboard_address": f"{LOOPBACK}:0"},
        worker_dashboard_address=None,
        silence_logs=logging.ERROR,
        env=WORKER_ENV,
        config=NO_PROFILER,
    )
    try:
        client = Client(cluster)
        try:
            yield client
        finally:
            client.close()
    finally:
        cluster.close()


def chunks(candidates: list[Candidate], size: int) -> list[list[Candidate]]:
    """The candidates in consecutive chunks of at most `size`, in order."""
    return [candidates[i : i + size] for i in range(0, len(candidates), size)]


def _contexts(candidates: list[Candidate]) -> dict[str, dict[str, Any]]:
    """Context key → its inputs, in candidate order."""
    out: dict[str, dict[str, Any]] = {}
    for c in candidates:
        if c.context_key not in out:
            out[c.context_key] = context_inputs(c.inputs)
    return out


def _reusable(
    spec: SweepSpec, candidates: list[Candidate], saved: dict[str, Any]
) -> tuple[dict[str, dict[str, Any]], set[str]]:
    """The saved rows that pass :func:`row_problem` (id → row), and the ids of those that do not (run again)."""
    done: dict[str, dict[str, Any]] = {}
    rerun: set[str] = set()
    for c in candidates:
        if c.id not in saved:
            continue
        row = saved[c.id]
        if row is not UNREADABLE and row_problem(spec, c, row) is None:
            done[c.id] = row
        else:
            rerun.add(c.id)
    return done, rerun


def run_sweep(
    spec: SweepSpec,
    out: Path,
    client: Any,
    *,
    limit: int | None = None,
    screen: bool | None = None,
    refine: bool = True,
    progress: bool = False,
    on_row: Callable[[dict[str, Any]], None] | None = None,
) -> SweepRun:
    """Run the candidates of `spec` not finished in `out` on the Dask `client`; save each row as it finishes.

    Args:
        spec: the sweep spec.
        out: the output folder (its ``.sweep`` work folder holds the finished rows).
        client: a ``distributed.Client`` (see :func:`dask_client`).
        limit: run the first `limit` candidates only (the screening still ranks all of them).
        screen: screen before simulating (default: the spec's ``screen.enabled``).
        refine: refine the best feasible candidates (the spec's ``[refine]``).
        progress: show a progress bar on stderr.
        on_row: called with each row as it is saved (in the order they finish).

    On KeyboardInterrupt the futures in flight are cancelled; the rows saved so far stay.
    """
    began = time.perf_counter()
    store = RowStore(out, spec)
    everything = expand(spec)
    chosen = everything if limit is None else everything[:limit]
    screening = spec.screening.enabled if screen is None else screen
    done, rerun = _reusable(spec, everything, store.finished())
    timings: dict[str, float] = {}
    futures: list[Any] = []
    try:
        spec_f = client.scatter(spec, broadcast=True, hash=False)
        needed = everything if screening else chosen
        keys = _contexts(needed)
        t0 = time.perf_counter()
        # the candidates need the reference start only, which each worker solves once per task (evaluate_held):
        # they depend on no task, so they run while the free-space runs are under way, on whichever worker is free
        ctx_f = {k: client.submit(task_context, spec_f, inputs, k, pure=False) for k, inputs in keys.items()}
        futures += list(ctx_f.values())
        verdicts: dict[str, str | None] = {}
        screened: dict[str, Screened] = {}
        if screening:
            groups: dict[str, list[Candidate]] = {}
            for c in everything:
                groups.setdefault(c.context_key, []).append(c)
            # each candidate is screened on its own: a context's candidates in chunks, so every worker screens
            scr_f = {
                k: [
                    client.submit(screen_context, spec_f, ctx_f[k], part, pure=False)
                    for part in chunks(cs, SCREEN_CHUNK)
                ]
                for k, cs in groups.items()
            }
            futures += [f for fs in scr_f.values() for f in fs]
            for fs in scr_f.values():
                part = [s for chunk in client.gather(fs) for s in chunk]
                screened |= {s.candidate: s for s in part}
                verdicts |= select(spec, part)
        timings["contexts_and_screening_s"] = time.perf_counter() - t0
        todo = [c for c in chosen if c.id not in done and verdicts.get(c.id) is None]
        t1 = time.perf_counter()
        # one graph for all of them (one message to the scheduler, not one per candidate)
        ev_f = dict(zip(client.map(evaluate_held, [spec_f] * len(todo), todo, pure=False), todo, strict=True))
        futures += list(ev_f)
        contexts: dict[str, TaskContext] = {}

        def context(key: str) -> TaskContext:
            if key not in contexts:
                contexts[key] = ctx_f[key].result()
            return contexts[key]

        bar = None
        if progress and todo:
            from tqdm import tqdm

            bar = tqdm(total=len(todo), desc=f"{spec.name}: candidates", unit="cand", file=sys.stderr)
        from distributed import as_completed

        try:
            for fut in as_completed(list(ev_f)):
                c = ev_f[fut]
                row = with_free_space(spec, c, fut.result(), context(c.context_key))
                store.save(row)
                done[row["candidate"]] = row
                if bar is not None:
                    bar.update(1)
                if on_row is not None:
                    on_row(row)
        finally:
            if bar is not None:
                bar.close()
        for key in ctx_f:
            context(key)
        timings["simulation_s"] = time.perf_counter() - t1
        rows = []
        order = ["candidate", "index", *input_columns(spec), *RESULT_COLUMNS]
        screened_out = 0
        for c in chosen:
            if c.id in done:  # judged by this spec's feasibility bounds, whatever the run that saved it
                row = judge(spec, done[c.id])
            else:
                row = empty_row(spec, c)
                row["Ci_mean_free_space"] = contexts[c.context_key].free.get("Ci_mean")
                row["screened_out"] = True
                row["failure"] = verdicts[c.id]
                screened_out += 1
            s = screened.get(c.id)
            row["screen_clearance_m"] = None if s is None else s.clearance
            row["screen_Ci_mean"] = None if s is None else s.Ci_mean
            row["screen_k_max"] = None if s is None else s.k_max
            rows.append({k: row.get(k) for k in order})
        refined: list[dict[str, Any]] = []
        if refine and spec.refinement.top > 0 and spec.axis("fraction") is not None:
            from bracekit.studies.sweep.refine import refine_best

            t2 = time.perf_counter()
            refined = refine_best(spec, rows, chosen, ctx_f, client, store, futures, shared_spec=spec_f)
            timings["refinement_s"] = time.perf_counter() - t2
    except BaseException:
        client.cancel(futures)
        raise
    timings["total_s"] = time.perf_counter() - began
    workers = len(client.scheduler_info(n_workers=-1).get("workers", {})) if hasattr(client, "scheduler_info") else 0
    return SweepRun(
        spec,
        rows,
        refined,
        evaluated=len(todo),
        reused=len(chosen) - len(todo) - screened_out,
        screened_out=screened_out,
        rerun=len([c for c in todo if c.id in rerun]),
        timings=timings,
        workers=workers,
    )
