"""The bounded submission of the placement's tasks: every result, in the calls' order, few tasks in flight."""

from __future__ import annotations

import threading
import time
from typing import Any

from bracekit.studies.place.engine import bounded_map

_lock = threading.Lock()
_running = [0, 0]  # now, most at once


def _slow_square(x: int, delay: float) -> int:
    with _lock:
        _running[0] += 1
        _running[1] = max(_running)
    time.sleep(delay)
    with _lock:
        _running[0] -= 1
    return x * x


class _Counted(list[Any]):
    """A list that remembers its greatest length (the futures in flight)."""

    most = 0

    def append(self, item: Any) -> None:
        super().append(item)
        self.most = max(self.most, len(self))


def test_bounded_map_keeps_order_and_window() -> None:
    from distributed import Client

    with Client(processes=False, n_workers=1, threads_per_worker=4, dashboard_address=None) as client:
        futures = _Counted()
        # later calls finish first (shorter delays): the results still come in the calls' order
        calls = [(i, 0.05 * (12 - i) / 12) for i in range(12)]
        got = bounded_map(client, _slow_square, calls, 3, futures)
    assert got == [i * i for i in range(12)]
    assert futures.most == 3 and _running[1] <= 3  # never more than the window submitted, nor running
    assert futures == []  # the finished ones are dropped: an interrupt cancels only what is in flight


def test_occupying_futures_count_in_the_window() -> None:
    """Other work on the workers (an early run, a MuJoCo check) holds a place in the window until it ends.

    Reference: the tasks found running at once by the function itself (the other work is the same function).
    """
    from distributed import Client

    _running[:] = [0, 0]
    with Client(processes=False, n_workers=1, threads_per_worker=4, dashboard_address=None) as client:
        other = client.submit(_slow_square, 100, 1.0, pure=False)
        while _running[0] == 0:  # the other work has started
            time.sleep(0.01)
        futures = _Counted()
        calls = [(i, 0.02) for i in range(8)]
        got = bounded_map(client, _slow_square, calls, 3, futures, occupying=lambda: [other])
        assert not other.done()  # the calls ran beside it, two at a time
        assert other.result() == 10000
    assert got == [i * i for i in range(8)]
    assert futures.most == 2 and _running[1] == 3


def test_the_window_opens_when_the_occupying_future_ends() -> None:
    """A window full of other work: the first call is submitted only once that work ends."""
    from distributed import Client

    with Client(processes=False, n_workers=1, threads_per_worker=2, dashboard_address=None) as client:
        other = client.submit(_slow_square, 3, 0.3, pure=False)
        began = time.perf_counter()
        got = bounded_map(client, _stamp, [(1,), (2,)], 1, [], occupying=lambda: [other])
        assert other.done() and got[0][0] == 1 and got[1][0] == 2
    assert min(t for _, t in got) - began >= 0.25  # the calls started after the other work's 0.3 s


def _stamp(x: int) -> tuple[int, float]:
    return x, time.perf_counter()


def test_idle_is_told_the_running_calls_once_all_are_submitted() -> None:
    """Room in the window after the last call is submitted is an idle worker: `idle` gets the calls in flight.

    Reference: the calls' own order and delays (a long last call, short ones before it, a window of 2): once every
    call is submitted and a short one ends, the long one is the only one running; the work `idle` starts counts
    in the window (no call submitted beside it: there are none left) and the results keep their order.
    """
    from distributed import Client

    told: list[list[int]] = []
    started: list[Any] = []

    with Client(processes=False, n_workers=1, threads_per_worker=3, dashboard_address=None) as client:

        def idle(running: list[int]) -> None:
            told.append(running)
            if not started:
                started.append(client.submit(_slow_square, 7, 0.05, pure=False))

        calls = [(0, 0.01), (1, 0.01), (2, 0.4)]
        got = bounded_map(client, _slow_square, calls, 2, [], occupying=lambda: started, idle=idle)
        assert got == [0, 1, 4]
        assert started and started[0].result() == 49
    assert told and all(running == [2] for running in told)  # only the long last call was in flight
