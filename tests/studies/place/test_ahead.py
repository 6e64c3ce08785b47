"""The work run ahead: a check started at a batch's tail is the one its row gets, never one beside a busy worker.

Reference: a fake Dask client that records what is submitted (no computation); the rows and places are made up
with the columns :func:`bracekit.studies.sweep.refine.usable` reads.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from bracekit.studies.place.ahead import RunAhead, TaskInputs
from bracekit.studies.place.inner import InnerResult
from bracekit.studies.place.outer import settle_place
from bracekit.studies.place.scenario import Place


class _Future:
    def __init__(self, key: int, fn: Any, args: tuple[Any, ...]) -> None:
        self.key, self.fn, self.args = key, fn, args
        self.finished = False
        self.status = "pending"

    def done(self) -> bool:
        return self.finished

    def result(self) -> Any:
        return None


class _Client:
    def __init__(self) -> None:
        self.submitted: list[_Future] = []
        self.cancelled: list[_Future] = []

    def submit(self, fn: Any, *args: Any, pure: bool = True, priority: int = 0) -> _Future:
        fut = _Future(len(self.submitted), fn, args)
        self.submitted.append(fut)
        return fut

    def cancel(self, futures: list[_Future]) -> None:
        self.cancelled += futures


def _trial(seed: int, angle: float) -> tuple[Place, InnerResult]:
    place = Place("link4", 0.4, angle)
    start = InnerResult(seed, place, np.zeros(11), 0.006, 3.0, 0.0, 0.0, True, "", 10, 0.01, 0.3)
    return place, start


def _row(ci: float) -> dict[str, Any]:
    return {"stage": "refine", "completed": True, "feasible": True, "Ci_mean_gp": ci, "mujoco_settles": None}


def _ahead(client: _Client, workers: int) -> RunAhead:
    return RunAhead(client, TaskInputs(object(), object(), "capsule"), workers, True, [])  # type: ignore[arg-type]


def test_a_tail_check_is_its_rows_check() -> None:
    client = _Client()
    ahead = _ahead(client, 2)
    a, b = _trial(0, 0.1), _trial(0, 0.2)
    ahead.idle([a, b], 2)  # both workers busy with the batch's last two calls: nothing started
    assert client.submitted == []
    ahead.idle([b], 1)  # one call left on one worker: the other checks its place
    (tail,) = client.submitted
    assert tail.fn is settle_place and tail.args[1] == b[0] and tail.args[2] is b[1].q
    ahead.idle([b], 1)  # one check at a time
    assert len(client.submitted) == 1
    row_b = _row(0.005)
    ahead.came_back(row_b, b)
    assert ahead.check(row_b, b) is tail  # the row takes the tail's check: no second check
    assert len(client.submitted) == 1


def test_a_tail_check_waits_for_a_free_worker() -> None:
    client = _Client()
    ahead = _ahead(client, 1)  # one worker: room in a window of two is not a free worker
    ahead.idle([_trial(0, 0.3)], 1)
    assert client.submitted == []
    ahead = _ahead(client, 2)
    early = client.submit(settle_place)  # a check run ahead still running holds the other worker
    ahead.checks[0] = early
    ahead.idle([_trial(0, 0.3)], 1)
    assert client.submitted == [early]


def test_an_unused_tail_check_is_cancelled() -> None:
    client = _Client()
    ahead = _ahead(client, 2)
    c = _trial(1, 0.4)
    ahead.idle([c], 1)
    (tail,) = client.submitted
    ahead.finish()
    assert tail in client.cancelled
