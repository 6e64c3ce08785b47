"""numba's ``njit`` where numba is installed (the ``[fast]`` extra), else kernels that run as plain Python.

A module of kernels decorates them with :data:`jit` (or :data:`inline` for the small functions they call) and
says whether they run compiled with :data:`COMPILED`; without numba the same loops run as Python, and the
caller says so in its output (a fallback is never silent). Compiled kernels are cached on disk (``cache=True``,
in numba's cache directory: :mod:`bracekit._numba_cache`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray

try:
    from numba import config, njit

    #: Whether the kernels run compiled (numba) or as Python (numba absent, or NUMBA_DISABLE_JIT set).
    COMPILED = not getattr(config, "DISABLE_JIT", False)
except ImportError:  # pragma: no cover - numba is in the test extras
    COMPILED = False

    def njit(**_: Any) -> Callable[[Callable[..., Any]], Callable[..., Any]]:  # type: ignore[no-redef]
        """Without numba: the decorated loops run as Python."""
        return lambda f: f


#: Array types of the kernels' annotations.
F64 = NDArray[np.float64]
I64 = NDArray[np.int64]

#: A compiled kernel (no fast math, NumPy's error model, without the GIL) and a function inlined into kernels.
jit = njit(cache=True, fastmath=False, error_model="numpy", nogil=True)
inline = njit(cache=True, fastmath=False, error_model="numpy", nogil=True, inline="always")
