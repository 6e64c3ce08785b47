"""The objects alive before the figures are drawn, kept out of the garbage collector's passes while they are drawn.

Drawing with matplotlib allocates many short-lived objects, so the collector runs often, and each of its full
passes walks every object of the process: after a run, the whole heap of numba, SciPy and the trajectories,
none of which the drawing frees. :func:`frozen_heap` moves those objects out of the collector's sight
(``gc.freeze``) for the drawing and back afterwards (``gc.unfreeze``); what the drawing itself leaves behind
is collected as before. A child forked meanwhile (:mod:`bracekit.report.forked`) then also leaves the parent's
pages unwritten (copy-on-write), as the documentation of ``gc.freeze`` advises before a fork.
"""

from __future__ import annotations

import gc
from collections.abc import Iterator
from contextlib import contextmanager


@contextmanager
def frozen_heap() -> Iterator[None]:
    """Freeze the objects alive now for the duration of the block (a no-op when some are frozen already).

    When the process has frozen objects itself (``gc.get_freeze_count() > 0``), nothing is frozen here and
    nothing is unfrozen afterwards: its frozen objects stay frozen.
    """
    if gc.get_freeze_count() > 0:
        yield
        return
    gc.freeze()
    try:
        yield
    finally:
        gc.unfreeze()
