"""Work the placement starts before its plain order asks for it, on workers that would otherwise wait.

Two kinds (:class:`RunAhead`, used by :func:`bracekit.studies.place.engine.run_place`):

- **The early whole-task run**: once fewer inner optimisations are left than there are workers, the best
  successful optimum so far is run over the task on the idle worker. When the inner level ends and that place
  is among the chosen, its batch takes the row instead of running it again; else it is discarded.
- **Early MuJoCo checks**: a feasible row that comes back with the least mean C_i so far has MuJoCo's static
  check started at once, ahead of the queued runs (a Dask priority). The engine takes it when it checks that
  row; a check it never asks for is discarded. A compass trial that comes back while the early whole-task run
  is still running is not checked early: the trials run gradient projection only and come back sooner, and
  the early run's place, their centre, is the likely best, whose check the plain order needs first (the
  compass starts from a place MuJoCo settles on). At a batch's tail, a worker with nothing left to run checks
  the place of a run still in flight (:meth:`RunAhead.idle`: the check needs the place and its start posture,
  not the run), kept for its row should that row need a check.

Either way each row and the best place are the ones the plain order gives: the early run is the same
computation on the same inputs, run without MuJoCo's check, which is added (early or not) where the plain
order runs it with the row (:meth:`RunAhead.completed`).
"""

from __future__ import annotations

from typing import Any, NamedTuple

from bracekit.studies.place.inner import InnerResult
from bracekit.studies.place.outer import evaluate_place, settle_place
from bracekit.studies.place.scenario import Place
from bracekit.studies.place.surface import SurfaceKind
from bracekit.studies.sweep.refine import usable
from bracekit.studies.sweep.spec import SweepSpec

#: A place and the inner optimum whose start posture it is run from.
Trial = tuple[Place, InnerResult]

#: Dask priority of an early MuJoCo check: before the runs already queued.
CHECK_PRIORITY = 10


class TaskInputs(NamedTuple):
    """What every whole-task run and MuJoCo check of a placement takes.

    The spec, the task context (a :class:`~bracekit.studies.sweep.context.TaskContext`, or the future of the
    task that computes it on a worker) and the surface the pad is placed on.
    """

    spec: SweepSpec
    context: Any
    kind: SurfaceKind


class RunAhead:
    """The early run and early checks of one placement (see the module).

    Args:
        client: the Dask client. inputs: the spec, the task context and the surface kind.
        workers: the number of workers. enabled: False runs nothing ahead (the plain order).
        futures: the engine's list of futures in flight (cancelled on an interrupt); this object adds its own.
    """

    def __init__(self, client: Any, inputs: TaskInputs, workers: int, enabled: bool, futures: list[Any]) -> None:
        self.client, self.workers, self.enabled, self.futures = client, workers, enabled, futures
        self.inputs = inputs
        self.early: dict[tuple[Place, int], tuple[Any, InnerResult]] = {}
        self.checks: dict[int, Any] = {}  # id of a row (kept alive in `seen`) → its early check
        self.tail: dict[tuple[Place, int], Any] = {}  # a place whose run was in flight → its check (:meth:`idle`)
        self.seen: list[dict[str, Any]] = []
        self._rows: dict[tuple[Place, int], dict[str, Any]] = {}  # early rows back (one object each: see `checks`)
        self._started = False

    def inner_done(self, found: list[InnerResult], waiting: int) -> None:
        """After each inner result (`found` so far, `waiting` not yet back): the early run, once, when due."""
        if not self.enabled or self._started or waiting >= self.workers:
            return
        good = [r for r in found if r.success]
        if not good:
            return
        r = min(good, key=lambda x: (x.value, x.place.link))
        spec, context, kind = self.inputs
        fut = self._submit(evaluate_place, spec, r.place, r.q, context, "task", kind, False)
        self.early[r.place, r.seed] = (fut, r)
        self._started = True

    def has(self, trial: Trial) -> bool:
        """Whether the trial's whole-task row was started early."""
        return (trial[0], trial[1].seed) in self.early

    def back(self, trial: Trial) -> dict[str, Any] | None:
        """The trial's early row if it is back (None if not started early, or still running)."""
        key = (trial[0], trial[1].seed)
        if key not in self._rows and key in self.early and self.early[key][0].done():
            self._rows[key] = self.early[key][0].result()
            self.came_back(self._rows[key], trial)
        return self._rows.get(key)

    def take(self, trial: Trial) -> dict[str, Any]:
        """The early row of the trial (waits for it)."""
        key = (trial[0], trial[1].seed)
        fut, _ = self.early.pop(key)
        if key not in self._rows:
            self._rows[key] = fut.result()
            self.came_back(self._rows[key], trial)
        self.futures.remove(fut)
        return self._rows.pop(key)

    def came_back(self, row: dict[str, Any], trial: Trial) -> None:
        """Note a row that came back; start its MuJoCo check if it is feasible with the least mean C_i so far."""
        self.seen.append(row)
        started = self.tail.pop((trial[0], trial[1].seed), None)
        if started is not None:  # checked while its run was in flight: the row's check
            self.checks[id(row)] = started
        for key, (fut, r) in list(self.early.items()):  # an early row counts once it is back (an error: when taken)
            if fut.done() and fut.status == "finished" and key not in self._rows:
                self._rows[key] = fut.result()
                self.came_back(self._rows[key], (key[0], r))
        if not self.enabled or not usable(row) or row.get("mujoco_settles") is not None or id(row) in self.checks:
            return
        if row.get("stage") == "refine" and any(not fut.done() for fut, _ in self.early.values()):
            return  # a compass trial: its centre's early run, the likely best and checked first, is still running
        least = min(r["Ci_mean_gp"] for r in self.seen if usable(r) and r.get("mujoco_settles") is not False)
        if row["Ci_mean_gp"] <= least:
            self.checks[id(row)] = self._submit(
                settle_place, self.inputs.spec, trial[0], trial[1].q, self.inputs.kind, priority=CHECK_PRIORITY
            )

    def check(self, row: dict[str, Any], trial: Trial) -> Any:
        """The future of the row's MuJoCo check: the early one, else one submitted now."""
        fut = self.checks.pop(id(row), None)
        if fut is None:
            fut = self._submit(settle_place, self.inputs.spec, trial[0], trial[1].q, self.inputs.kind)
        return fut

    def completed(self, row: dict[str, Any], trial: Trial) -> None:
        """An early row completed as the plain order's run with MuJoCo's check after it would be (in place)."""
        if usable(row) and row.get("mujoco_settles") is None:
            fut = self.check(row, trial)
            row["mujoco_settles"], row["mujoco_message"] = fut.result()
            self.futures.remove(fut)

    def idle(self, running: list[Trial], calls: int) -> None:
        """Room in a batch's window at its tail: check the first of the `running` places not checked yet.

        `calls`: the batch's calls still running (`running` may leave out places checked in their own task).
        Only when a worker is free (fewer calls and futures run ahead in flight than workers: with one worker,
        room in the window is not a free worker) and no check is in flight; the check is the row's once it comes
        back (:meth:`came_back`), else discarded.
        """
        if not self.enabled or calls + len(self.in_flight()) >= self.workers:
            return
        if any(not fut.done() for fut in [*self.checks.values(), *self.tail.values()]):
            return
        for place, start in running:
            if (place, start.seed) not in self.tail:
                spec, _, kind = self.inputs
                self.tail[place, start.seed] = self._submit(settle_place, spec, place, start.q, kind)
                return

    def in_flight(self) -> list[Any]:
        """The early runs' and early checks' futures not yet finished (they hold a worker, or will)."""
        running = [fut for fut, _ in self.early.values()] + list(self.checks.values()) + list(self.tail.values())
        return [fut for fut in running if not fut.done()]

    def finish(self) -> int:
        """Cancel what was run ahead and not taken; the number of early runs discarded."""
        left = [fut for fut, _ in self.early.values()] + list(self.checks.values()) + list(self.tail.values())
        if left:
            self.client.cancel(left)
        return len(self.early)

    def _submit(self, fn: Any, *args: Any, priority: int = 0) -> Any:
        fut = self.client.submit(fn, *args, pure=False, priority=priority)
        self.futures.append(fut)
        return fut
