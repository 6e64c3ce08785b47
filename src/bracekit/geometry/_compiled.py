"""numba's ``njit`` for the compiled geometry kernels, or plain Python where numba is not installed (internal)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray

try:
    from numba import njit

    #: Whether the broad phase runs compiled (numba, the ``[fast]`` extra) or as plain Python (same loops, slower).
    COMPILED = True
except ImportError:  # pragma: no cover - numba is in the test extras
    COMPILED = False

    def njit(**_: Any) -> Callable[[Callable[..., Any]], Callable[..., Any]]:  # type: ignore[no-redef]
        """Without numba: the loops run as Python (the geometry's description says so)."""
        return lambda f: f


F64 = NDArray[np.float64]
I64 = NDArray[np.int64]

#: A compiled function (cached on disk, IEEE arithmetic, NumPy's error model).
jit = njit(cache=True, fastmath=False, error_model="numpy", nogil=True)
#: The same, inlined into its callers.
inline = njit(cache=True, fastmath=False, error_model="numpy", nogil=True, inline="always")
