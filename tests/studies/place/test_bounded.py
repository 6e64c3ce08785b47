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
