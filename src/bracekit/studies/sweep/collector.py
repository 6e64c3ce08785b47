"""Python's cyclic garbage collector held off during a whole-task run on a worker, one young collection after.

A run allocates hundreds of thousands of short-lived containers (states, their cached matrices, dictionaries of
measures); with the collector on, every 700 of them start a collection, and now and then one of the whole heap
of a Dask worker (distributed, pinocchio, numba: ≈ 180,000 objects), which cost 5 to 10 % of a candidate's
time. While :func:`collector_paused` holds, the collector does not run; when the last holder leaves it is
switched back on (if it was on before) and the objects the runs left in reference cycles are freed at once by
one collection of the youngest generation (where everything allocated meanwhile still is). Reference counting
frees everything else as usual, so memory stays that of one run. The numbers a run computes do not depend on
when garbage is collected.

Process-wide (the collector is): holders are counted, and the collector comes back when the last one leaves.
It is held off only while one thread's run is under way: when another thread comes while the first still holds
(a worker with several task threads whose runs overlap), the collector is switched back on at once, so that a
worker whose threads are never all idle still collects its garbage as usual.
"""

from __future__ import annotations

import gc
import threading
from collections.abc import Iterator
from contextlib import contextmanager

_lock = threading.Lock()
#: Holding threads (their ids) and how many holds each has (a thread may hold inside its own hold).
_holders: dict[int, int] = {}
#: Whether the collector was on when the first holder came.
_was_on = [False]


@contextmanager
def collector_paused() -> Iterator[None]:
    """Hold the cyclic garbage collector off inside the block; on leaving, one young-generation collection.

    Not held off while another thread holds it too (see the module). The collector's own state is restored:
    a program that had it switched off keeps it off (and nothing is collected here).
    """
    me = threading.get_ident()
    with _lock:
        if not _holders:
            _was_on[0] = gc.isenabled()
            gc.disable()
        elif me not in _holders and _was_on[0]:  # runs of two threads overlap: the collector runs meanwhile
            gc.enable()
        _holders[me] = _holders.get(me, 0) + 1
    try:
        yield
    finally:
        with _lock:
            _holders[me] -= 1
            if not _holders[me]:
                del _holders[me]
            last = not _holders and _was_on[0]
            if last:
                gc.enable()
        if last:
            gc.collect(0)
