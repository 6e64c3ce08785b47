"""The placement's Dask workers: each one's numba settings and BLAS/OpenMP threads from its own environment.

`bracekit place` forks its local workers from its own process (the placement's modules already imported). A
forked worker inherits that process's numba settings (read at import) and the thread counts its BLAS and
OpenMP libraries were loaded with, while its environment (the cluster's,
:data:`bracekit.studies.sweep.engine.WORKER_ENV`: one thread each) says otherwise. :class:`WorkerThreads`
is registered with the client; Dask runs its :meth:`~WorkerThreads.setup` on every worker before its first task,
and on a worker the nanny restarts.
"""

from __future__ import annotations

import os
import sys
from typing import Any

from distributed.diagnostics.plugin import WorkerPlugin


def numba_threads_started() -> bool:
    """Whether numba's thread pool was started in this process (True when it cannot tell)."""
    if "numba" not in sys.modules:
        return False
    parallel = sys.modules.get("numba.np.ufunc.parallel")
    return parallel is not None and bool(getattr(parallel, "_is_initialized", True))


class WorkerThreads(WorkerPlugin):
    """Numba's settings and the BLAS/OpenMP pools of a worker set from its environment (see the module)."""

    name = "bracekit-worker-threads"

    def setup(self, worker: Any) -> None:
        """Re-read numba's settings (before its threads start); limit BLAS and OpenMP to ``OMP_NUM_THREADS``.

        Dask calls this on the worker's event-loop thread. BLAS pools are process-wide, but OpenMP's thread count
        belongs to the calling thread: it is also set on each executor's task thread (one a worker here).
        """
        numba = sys.modules.get("numba")
        if numba is not None and not numba_threads_started():
            numba.core.config.reload_config()
        threads = os.environ.get("OMP_NUM_THREADS", "")
        if threads.isdigit():
            limit_threads(int(threads))
            for executor in getattr(worker, "executors", {}).values():
                executor.submit(limit_threads, int(threads))  # queued before any task: the thread runs it first


def limit_threads(threads: int) -> None:
    """BLAS (process-wide) and OpenMP (this thread's) pools limited to `threads` (threadpoolctl)."""
    from threadpoolctl import threadpool_limits

    threadpool_limits(threads)
