"""Python's cyclic garbage collector held off during a whole-task run on a worker, one young collection after.

A run allocates hundreds of thousands of short-lived containers (states, their cached matrices, dictionaries of
measures); with the collector on, every 700 of them start a collection, and now and then one of the whole heap
of a Dask worker (distributed, pinocchio, numba: ≈ 180,000 objects), which cost 5 to 10 % of a candidate's
time. While :func:`collector_paused` holds, the collector does not run; when the last holder leaves it is
switched back on (if it was on before) and the objects the runs left in reference cycles are freed at once by
one collection of the youngest generation (where everything allocated meanwhile still is). Reference counting
frees everything else as usual, so memory stays that of one run. The numbers a run computes do not depend on
when garbage is collected.

Process-wide (the collector is): nested and concurrent holders (several task threads of one worker) are
counted, and the collector comes back when the last one leaves.
"""

from __future__ import annotations

import gc
import threading
from collections.abc import Iterator
from contextlib import contextmanager

_lock = threading.Lock()
#: [holders now, whether the collector was on when the first of them came]
_state: list[int | bool] = [0, False]


@contextmanager
def collector_paused() -> Iterator[None]:
    """Hold the cyclic garbage collector off inside the block; on leaving, one young-generation collection.

    The collector's own state is restored: a program that had it switched off keeps it off (and nothing is
    collected here).
    """
    with _lock:
        if _state[0] == 0:
            _state[1] = gc.isenabled()
            gc.disable()
        _state[0] = int(_state[0]) + 1
    try:
        yield
    finally:
        with _lock:
            _state[0] = int(_state[0]) - 1
            last = _state[0] == 0
            if last and _state[1]:
                gc.enable()
        if last and _state[1]:
            gc.collect(0)
