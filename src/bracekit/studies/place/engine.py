"""Both levels of the placement on Dask: the seeds' inner optimisations, then the best places over the task.

1. The reference start q_ref (:func:`bracekit.studies.sweep.context.reference_start`, in this process:
   :func:`prepare`) seeds the inner level. The command line computes the task context (the free-space run)
   there too, before its workers fork, so they start with numba's kernels loaded; else a worker computes it
   while another imports the inner level's modules. The spec and the task context go with each task (tens of
   kB: no round trip to scatter them first, and no worker is preferred for holding them).
2. Inner (:mod:`.inner`): for every link of the spec's ``link`` axis, ``seeds`` starting fractions evenly spread
   over the link, each one task: SLSQP over posture, fraction and angle at the task's start.
3. Outer (:mod:`.outer`): the best successful optimum of each link, ranked by the start objective, the ``top``
   best links, each run over the whole task (one batch); a place whose run fails is optimised again within the
   posture radius over :data:`NEARER` and run, up to ``nearer`` times (the optimum on its radius R leaves the
   gradient-projection run a descent to follow past R, which on the Panda's collision surface slides the pad to
   its region's edge); while none is feasible, the next ``top`` places; then
   ``refine_rounds`` rounds of the compass search from the best feasible one (:func:`.outer.polls`, one batch
   of whole-task runs per round).

Every task goes through :func:`bounded_map`: at most two per worker in flight (inner optimisations), one per
worker and at least two (whole-task runs: a run queued behind another on a busy worker would leave an idle
one waiting), so an interrupt stops a run in seconds whatever the number of seeds. :class:`~.ahead.RunAhead`
fills the gaps: the best optimum's whole-task run once the inner level's last seeds leave a worker idle,
MuJoCo's check of a row that may be the best as soon as it is back; the rows and the best are those of the
plain order. The first compass round's trials about a centre whose row came back not feasible are not run.

The best place is the feasible whole-task evaluation with the least mean C_i of gradient projection whose
scenario MuJoCo's static check settles on (:mod:`.settle`): the check runs on a worker on the feasible rows,
least C_i first, until one settles (``mujoco_settles`` in the row: True, False, or None when not checked).
Rows are ordered by link and seed (inner) and by place and evaluation (outer), whatever the order the workers
finish in.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from bracekit.errors import BracekitError, InputError
from bracekit.studies.place.ahead import RunAhead, TaskInputs, Trial
from bracekit.studies.place.inner import InnerResult, InnerSettings, optimise_start
from bracekit.studies.place.outer import evaluate_place, polls
from bracekit.studies.place.scenario import Place
from bracekit.studies.place.surface import link_surface
from bracekit.studies.sweep.context import TaskContext, context_scenario, reference_start, task_context
from bracekit.studies.sweep.refine import usable
from bracekit.studies.sweep.spec import SweepSpec

Array = NDArray[np.float64]

#: Tasks in flight per worker (:func:`bounded_map`): enough to keep each busy, few to cancel on an interrupt.
WINDOW_PER_WORKER = 2

#: The factor the posture radius is divided by when a place's whole-task run fails (:func:`run_place`).
NEARER = 3.0


@dataclass(frozen=True)
class PlaceSettings:
    """The search's settings.

    The inner problem's, seeds per link, places run over the task, compass rounds, the compass's first steps
    (fraction, angle in rad), and how many times a place whose whole-task run fails is optimised again nearer
    the reference start (its posture radius divided by :data:`NEARER`; :func:`run_place`). ``run_ahead``: start
    the best optimum's whole-task run on a worker the inner level's tail leaves idle, and MuJoCo's check of a
    row that may be the best as soon as it comes back (the rows and the best are the same either way).
    """

    inner: InnerSettings = field(default_factory=InnerSettings)
    seeds: int = 1
    top: int = 1
    refine_rounds: int = 1
    step: tuple[float, float] = (0.05, math.radians(15.0))
    nearer: int = 2
    run_ahead: bool = True


@dataclass
class PlaceRun:
    """What a placement did: every inner result, every whole-task row, the best, the timings (s).

    ``unused``: the first compass round's trials run ahead with the task batch and discarded (their centre
    was not the best place MuJoCo settled on); ``unused_early``: the early whole-task runs discarded (their
    place was not among the chosen, :class:`~.ahead.RunAhead`). ``place``: the best's place as it was run (its
    row's angle is in degrees).
    """

    spec: SweepSpec
    settings: PlaceSettings
    q_ref: Array
    inner: list[InnerResult]
    chosen: list[InnerResult]
    evaluations: list[dict[str, Any]]
    best: dict[str, Any] | None
    best_start: InnerResult | None
    timings: dict[str, float]
    workers: int = 0
    unused: int = 0
    place: Place | None = None
    unused_early: int = 0


def check_spec(spec: SweepSpec) -> list[str]:
    """The links to place on; InputError for a spec with other axes (a task, stiffness, ...) or no link axis.

    A 'fraction' or 'angle' axis is the grid's sampling of a variable the placement optimises itself.
    """
    other = [a for a in spec.axis_names if a not in ("link", "fraction", "angle")]
    if other:
        raise InputError(
            f"bracekit place varies where the brace is only; the spec {spec.name!r} also sweeps {', '.join(other)} "
            "(remove those axes, or run bracekit sweep)"
        )
    axis = spec.axis("link")
    if axis is None:
        raise InputError(f"the spec {spec.name!r} has no 'link' axis: list the links to place the pad on")
    return [str(v) for v in axis.grid()]


def seed_fractions(count: int, bounds: tuple[float, float]) -> list[float]:
    """`count` fractions evenly spread inside `bounds`: the midpoints of equal parts."""
    lo, hi = bounds
    return [lo + (hi - lo) * (i + 0.5) / count for i in range(count)]


def _span(robot: Any, link: str, inner: InnerSettings) -> tuple[float, float]:
    """The fraction's bounds on `link`'s surface (the settings' for a link without one: its seeds fail by name)."""
    bounds = inner.fraction_bounds
    try:
        return link_surface(robot, link, inner.surface).fraction_bounds(bounds)
    except BracekitError:
        return bounds


def choose(inner: list[InnerResult], top: int) -> list[InnerResult]:
    """The best successful optimum of each link (least start objective), the `top` best links, best first."""
    best: dict[str, InnerResult] = {}
    for r in inner:
        if r.success and (r.place.link not in best or r.value < best[r.place.link].value):
            best[r.place.link] = r
    return sorted(best.values(), key=lambda r: (r.value, r.place.link))[:top]


def _best(rows: list[dict[str, Any]]) -> dict[str, Any] | None:
    """The best feasible row MuJoCo's static check settled on, or None.

    Best: the least mean C_i of gradient projection (the earliest of equals).
    """
    good = [r for r in rows if usable(r) and r.get("mujoco_settles") is True]
    return min(good, key=lambda r: (r["Ci_mean_gp"], r["evaluation"])) if good else None


def _unchecked(rows: list[dict[str, Any]]) -> dict[str, Any] | None:
    """The feasible row the best must be compared with next: the least mean C_i among those not yet rejected."""
    good = [r for r in rows if usable(r) and r.get("mujoco_settles") is not False]
    best = min(good, key=lambda r: (r["Ci_mean_gp"], r["evaluation"])) if good else None
    return None if best is None or best.get("mujoco_settles") is True else best


def _warm() -> None:
    """Import the inner level's modules (SciPy's optimiser, the clearance) on a worker."""
    import scipy.optimize  # noqa: F401

    import bracekit.studies.place.inner  # noqa: F401


def bounded_map(
    client: Any,
    fn: Any,
    calls: list[tuple[Any, ...]],
    window: int,
    futures: list[Any],
    on_result: Callable[[int, Any, int], None] | None = None,
    skip: Callable[[int], bool] | None = None,
    occupying: Callable[[], list[Any]] | None = None,
    idle: Callable[[list[int]], None] | None = None,
) -> list[Any]:
    """fn(*call) for every call on the Dask `client`, results in the calls' order, at most `window` submitted at once.

    Each finished task lets the next one in, so the workers never wait for a batch, and an interrupt (Ctrl-C,
    SIGTERM) leaves at most `window` tasks to cancel: closing the cluster then takes seconds whatever the number
    of calls. The submitted futures are appended to `futures` (the caller cancels them on an interrupt).
    `on_result(i, result, waiting)`, when given, is called as each result comes back (call i; `waiting`: the
    calls not yet finished), before the next call is submitted: it may submit work of its own. A call for which
    `skip(i)` is True when its turn comes is not run (its result None). `occupying()`, when given, returns other
    futures on the same workers (work run ahead, MuJoCo's checks): those not finished count in the window, so
    that a call is not queued on a busy worker (Dask assigns a task to a worker when it is submitted) while the
    other becomes idle. `idle(running)`, when given, is called when every call is submitted and the window has
    room (a worker is idle), with the calls still running: it may submit work of its own (an occupying future).
    """
    from distributed import as_completed

    results: list[Any] = [None] * len(calls)
    index: dict[Any, int] = {}
    pending = iter(enumerate(calls))
    waiting = [len(calls)]
    watched: set[Any] = set()

    def others(queue: Any) -> int:
        """The occupying futures not finished (each added to the queue once: its end lets the next call in)."""
        busy = [f for f in (occupying() if occupying is not None else []) if not f.done()]
        for f in busy:
            if f.key not in watched:
                watched.add(f.key)
                queue.add(f)
        return len(busy)

    def submit(queue: Any) -> None:
        while len(index) + others(queue) < window:
            if (nxt := next(pending, None)) is None:  # every call submitted: room in the window is an idle worker
                if idle is not None and index:
                    idle(sorted(index.values()))
                    others(queue)  # what it started counts in the window, and its end wakes this loop
                return
            if skip is not None and skip(nxt[0]):
                waiting[0] -= 1
                continue
            fut = client.submit(fn, *nxt[1], pure=False)
            index[fut.key] = nxt[0]
            futures.append(fut)
            queue.add(fut)

    queue = as_completed([])
    submit(queue)
    while waiting[0]:  # not until the occupying futures end: they are the caller's
        fut = next(queue)
        if fut.key not in index:  # an occupying future ended
            submit(queue)
            continue
        i = index.pop(fut.key)
        results[i] = fut.result()
        futures.remove(fut)
        waiting[0] -= 1
        if on_result is not None:
            on_result(i, results[i], waiting[0])
        submit(queue)
    return results


class Prepared(NamedTuple):
    """What the inner level needs before any worker.

    The links, the reference start q_ref (n,), each link's fraction bounds; the task context when computed here
    (None: a worker computes it).
    """

    links: list[str]
    q_ref: Array
    spans: dict[str, tuple[float, float]]
    context: TaskContext | None = None


def prepare(spec: SweepSpec, settings: PlaceSettings, context: bool = False) -> Prepared:
    """The links, q_ref (:func:`bracekit.studies.sweep.context.reference_start`) and spans, in this process.

    With `context`, the task context too (:func:`~bracekit.studies.sweep.context.task_context`: the free-space
    run). The command line computes it before its workers fork, so that they start with numba's kernels loaded
    (numba's start and the kernels' loading cost each process 0.2–0.3 s of CPU at its first compiled call).
    """
    links = check_spec(spec)
    ctx = task_context(spec, {}, "{}") if context else None
    q_ref = reference_start(context_scenario(spec, {})) if ctx is None or ctx.q_ref is None else ctx.q_ref
    robot = spec.base_scenario().robot
    return Prepared(links, q_ref, {link: _span(robot, link, settings.inner) for link in links}, ctx)


def run_place(spec: SweepSpec, client: Any, settings: PlaceSettings, prepared: Prepared | None = None) -> PlaceRun:
    """Run both levels on the Dask `client` (see the module); `prepared`: :func:`prepare`'s, computed when None."""
    began = time.perf_counter()
    check_spec(spec)
    timings: dict[str, float] = {}
    futures: list[Any] = []
    try:
        # the spec (a few kB) and the task context (tens of kB) go with each task: no round trip to scatter them
        # first, and no worker is preferred for holding them
        context: Any = None if prepared is None else prepared.context
        if context is None:
            context = client.submit(task_context, spec, {}, "{}", pure=False)
            futures += [context, client.submit(_warm, pure=False)]  # an idle worker imports while q_ref is solved
        links, q_ref, spans, _ = prepare(spec, settings) if prepared is None else prepared
        workers = max(1, _workers(client))
        window = WINDOW_PER_WORKER * workers
        kind = settings.inner.surface
        seeds = [(link, f) for link in links for f in seed_fractions(settings.seeds, spans[link])]
        calls = [(spec, link, f, q_ref, settings.inner, i) for i, (link, f) in enumerate(seeds)]
        found: list[InnerResult] = []
        ahead = RunAhead(client, TaskInputs(spec, context, kind), workers, settings.run_ahead, futures)

        def inner_done(_: int, result: InnerResult, waiting: int) -> None:
            found.append(result)
            ahead.inner_done(found, waiting)

        inner: list[InnerResult] = bounded_map(client, optimise_start, calls, window, futures, inner_done)
        timings["inner_s"] = time.perf_counter() - began
        ranking = choose(inner, len(links))
        chosen = ranking[: settings.top]
        t1 = time.perf_counter()
        evaluations: list[dict[str, Any]] = []
        starts: dict[int, Trial] = {}  # evaluation → its place (as run: no angle through degrees) and start
        raw: dict[int, dict[str, Any]] = {}  # evaluation → the row as it came back (:class:`RunAhead` knows it)

        spare: dict[tuple[Place, int], dict[str, Any]] = {}  # the compass's first trials, run ahead

        def batch(places: list[Trial], stage: str, ahead_trials: int = 0, check: int = 0) -> list[dict[str, Any]]:
            """Run `places`; the last `ahead_trials` of them are the first compass round's trials, kept in `spare`.

            The first `check` places get MuJoCo's check on their worker right after their run when feasible.
            Returns the rows of the others, in order.
            """
            first = len(places) - ahead_trials
            todo = [i for i, (p, r) in enumerate(places) if (p, r.seed) not in spare and not ahead.has((p, r))]
            # submitted: the places to check, the compass's trials, then the other places (a fallback: they count
            # when the first fails), so a likely best comes back, and its MuJoCo check runs, before the batch ends
            todo.sort(key=lambda i: (0 if i < check else 1 if i >= first else 2, i))
            calls = [
                (spec, places[i][0], places[i][1].q, context, "refine" if i >= first else stage, kind, i < check)
                for i in todo
            ]
            arrived: dict[int, dict[str, Any]] = {}

            def back(j: int, row: dict[str, Any], _: int) -> None:
                arrived[todo[j]] = row
                ahead.came_back(row, places[todo[j]])

            def centre_failed(j: int) -> bool:
                """A trial about the first place (the centre) whose whole-task row is back and not feasible.

                It could never be used (the compass starts from the best feasible place): not run.
                """
                if not settings.run_ahead or not ahead_trials or first == 0 or todo[j] < first:
                    return False
                row = arrived.get(0) if 0 in todo else ahead.back(places[0])
                return row is not None and not usable(row)

            def tail(running: list[int]) -> None:  # a place checked in its own task (i < check) is not checked again
                ahead.idle([places[todo[j]] for j in running if todo[j] >= check], len(running))

            results = bounded_map(
                client, evaluate_place, calls, max(2, workers), futures, back, centre_failed, ahead.in_flight, tail
            )
            done = dict(zip(todo, results, strict=True))
            rows = []
            for i, (p, r) in enumerate(places):
                if i in done and done[i] is None:  # a trial about a centre that failed, not run
                    continue
                if i in done:
                    row = done[i]
                elif (p, r.seed) in spare:
                    row = spare.pop((p, r.seed))
                else:
                    row = ahead.take((p, r))
                    if i < check:
                        ahead.completed(row, (p, r))
                if i >= first:
                    spare[p, r.seed] = row
                    continue
                out = {"place": r.seed, "evaluation": len(evaluations), **row}
                raw[out["evaluation"]] = row
                evaluations.append(out)
                starts[out["evaluation"]] = (p, r)
                rows.append(out)
            return rows

        def nearer(tried: list[InnerResult], rows: list[dict[str, Any]]) -> None:
            """Each place of `tried` whose whole-task row failed, optimised again within R / NEARER and run.

            Up to ``settings.nearer`` times: C_i still falls along the self-motion past the inner optimum on its
            posture radius R, and the gradient-projection run follows that descent (see the module).
            """
            for _ in range(settings.nearer):
                failed = [r for r, row in zip(tried, rows, strict=True) if not usable(row) and r.radius]
                if not failed:
                    return
                calls = [
                    (
                        spec,
                        r.place.link,
                        r.place.fraction,
                        q_ref,
                        replace(settings.inner, posture_radius=r.radius / NEARER),
                        len(inner) + j,
                    )
                    for j, r in enumerate(failed)
                    if r.radius
                ]
                again: list[InnerResult] = bounded_map(client, optimise_start, calls, window, futures)
                inner.extend(again)
                tried = [r for r in again if r.success]
                rows = batch([(r.place, r) for r in tried], "task")

        def settled_best() -> dict[str, Any] | None:
            """The best row, MuJoCo's static check run on the feasible rows best first until one settles."""
            while (row := _unchecked(evaluations)) is not None:
                came = raw[row["evaluation"]]  # the row RunAhead holds: its verdict too (a rejected row is no least)
                fut = ahead.check(came, starts[row["evaluation"]])
                verdict = fut.result()
                row["mujoco_settles"], row["mujoco_message"] = came["mujoco_settles"], came["mujoco_message"] = verdict
                futures.remove(fut)
            return _best(evaluations)

        def trials(here: Place, centre: InnerResult, step: tuple[float, float]) -> list[Trial]:
            """The compass trials about `here`, at the centre's start posture."""
            return [(p, centre) for p in polls(here, step, spans[here.link])]

        # the first compass round's trials about the best inner optimum run with the task batch: they are used
        # when that place is the best feasible one MuJoCo settles on (else discarded)
        step = settings.step
        round1 = trials(chosen[0].place, chosen[0], step) if chosen and settings.refine_rounds else []
        rows = batch([(r.place, r) for r in chosen] + round1, "task", len(round1), check=1)  # the likely best: now
        nearer(list(chosen), rows)
        while settled_best() is None and len(chosen) < len(ranking):  # none usable: the next
            more = ranking[len(chosen) : len(chosen) + settings.top]
            chosen += more
            nearer(more, batch([(r.place, r) for r in more], "task"))
        for _ in range(settings.refine_rounds):
            best = settled_best()
            if best is None:
                break
            batch(trials(*starts[best["evaluation"]], step), "refine")
            if settled_best() is best:
                step = (0.5 * step[0], 0.5 * step[1])
        best = settled_best()
        timings["outer_s"] = time.perf_counter() - t1
    except BaseException:
        client.cancel(futures)
        raise
    unused, unused_early = len(spare), ahead.finish()
    place, best_start = (None, None) if best is None else starts[best["evaluation"]]
    timings["total_s"] = time.perf_counter() - began
    return PlaceRun(
        spec,
        settings,
        q_ref,
        inner,
        chosen,
        evaluations,
        best,
        best_start,
        timings,
        _workers(client),
        unused,
        place,
        unused_early,
    )


def _workers(client: Any) -> int:
    """The number of the client's workers (0 when it cannot say)."""
    return len(client.scheduler_info(n_workers=-1).get("workers", {})) if hasattr(client, "scheduler_info") else 0


def best_place(run: PlaceRun) -> tuple[Place, Array] | None:
    """The best feasible place and its start posture (the inner optimum's), or None when none is feasible."""
    if run.best is None or run.best_start is None:
        return None
    row = run.best
    place = run.place or Place(row["link"], float(row["fraction"]), float(np.radians(row["angle_deg"])))
    return place, run.best_start.q
