"""Cholesky factors and inverses of small symmetric matrices, shared by the compiled kernels (internal).

The batch compliance kernel (:mod:`bracekit.compliance._numba_kernels`), the fused step's linear algebra
(:mod:`bracekit.resolution._numba_linalg`) and the Gauss–Newton correction
(:mod:`bracekit.simulation._correction_kernel`) factor with these loops. Decorated with
:data:`bracekit._compiled.jit`: compiled with numba, plain Python loops without it (the correction then takes its
NumPy point instead, :mod:`bracekit.simulation._correction_numpy`).
"""

from __future__ import annotations

import math

import numpy as np

from bracekit._compiled import F64
from bracekit._compiled import jit as _jit

__all__ = ["cholesky", "cholesky_inverse", "lower_inverse"]


@_jit
def cholesky(m: F64, add: float) -> tuple[F64, bool]:  # pragma: no cover - compiled
    """(L, ok): the Cholesky factor of M + add·I (symmetric M, c×c); ok is False where it is not positive definite."""
    c = m.shape[0]
    lo = np.zeros((c, c))
    for j in range(c):
        s = m[j, j] + add
        for p in range(j):
            s -= lo[j, p] * lo[j, p]
        if not s > 0.0:
            return lo, False
        lo[j, j] = math.sqrt(s)
        for i in range(j + 1, c):
            t = m[i, j]
            for p in range(j):
                t -= lo[i, p] * lo[j, p]
            lo[i, j] = t / lo[j, j]
    return lo, True


@_jit
def lower_inverse(lo: F64) -> F64:  # pragma: no cover - compiled
    """L⁻¹ (c×c, lower triangular) of a lower-triangular L with a nonzero diagonal, by forward substitution."""
    c = lo.shape[0]
    li = np.zeros((c, c))
    for col in range(c):
        li[col, col] = 1.0 / lo[col, col]
        for i in range(col + 1, c):
            s = 0.0
            for p in range(col, i):
                s -= lo[i, p] * li[p, col]
            li[i, col] = s / lo[i, i]
    return li


@_jit
def cholesky_inverse(m: F64, add: float, out: F64) -> bool:  # pragma: no cover - compiled
    """(M + add·I)⁻¹ = L⁻ᵀ L⁻¹ into out (c×c) by Cholesky; False (out untouched) where not positive definite."""
    c = m.shape[0]
    lo, ok = cholesky(m, add)
    if not ok:
        return False
    li = lower_inverse(lo)
    for i in range(c):
        for j in range(c):
            s = 0.0
            for p in range(max(i, j), c):
                s += li[p, i] * li[p, j]
            out[i, j] = s
    return True
