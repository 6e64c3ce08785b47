"""The compiled helpers of the batch kernel (internal, numba).

k from a Cholesky factor (the factor and the inverse of a shifted symmetric matrix: :mod:`bracekit._cholesky`),
cyclic Jacobi, the constrained model's loaded gain, the shift of wrench rows and the
per-row finish of :mod:`bracekit.compliance._numba_batch`.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

from bracekit._cholesky import cholesky_inverse

Array = NDArray[np.float64]

_jit = njit(cache=True, fastmath=False, error_model="numpy", nogil=True)


@_jit
def _k2(m: Array, lo: Array, col: Array) -> float:  # pragma: no cover - compiled
    """tr(M) tr(M⁻¹) = 36 k² of a symmetric 6×6 M = JJᵀ by Cholesky (‖L⁻¹‖²_F); inf if not positive definite.

    `lo` (6×6) and `col` (6,) are scratch space.
    """
    for j in range(6):
        s = m[j, j]
        for p in range(j):
            s -= lo[j, p] * lo[j, p]
        if not s > 0.0:
            return math.inf
        lo[j, j] = math.sqrt(s)
        for i in range(j + 1, 6):
            t = m[i, j]
            for p in range(j):
                t -= lo[i, p] * lo[j, p]
            lo[i, j] = t / lo[j, j]
    bb = 0.0
    for c in range(6):  # column c of L⁻¹ by forward substitution
        col[c] = 1.0 / lo[c, c]
        bb += col[c] * col[c]
        for i in range(c + 1, 6):
            s = 0.0
            for p in range(c, i):
                s -= lo[i, p] * col[p]
            col[i] = s / lo[i, i]
            bb += col[i] * col[i]
    a = 0.0
    for i in range(6):
        a += m[i, i]
    return a * bb


@_jit
def _jacobi(m: Array) -> tuple[Array, Array]:  # pragma: no cover - compiled
    """Eigenvalues w and eigenvectors V (columns) of a small symmetric matrix by cyclic Jacobi rotations."""
    c = m.shape[0]
    a = m.copy()
    v = np.eye(c)
    for _ in range(60):
        off = 0.0
        diag = 0.0
        for i in range(c):
            diag += a[i, i] * a[i, i]
            for j in range(i + 1, c):
                off += a[i, j] * a[i, j]
        if not off > 1e-36 * diag:  # converged (or nan)
            break
        for p in range(c - 1):
            for q in range(p + 1, c):
                apq = a[p, q]
                if apq == 0.0:
                    continue
                theta = (a[q, q] - a[p, p]) / (2.0 * apq)
                t = (1.0 if theta >= 0.0 else -1.0) / (abs(theta) + math.sqrt(theta * theta + 1.0))
                cs = 1.0 / math.sqrt(t * t + 1.0)
                sn = t * cs
                for k in range(c):
                    akp, akq = a[k, p], a[k, q]
                    a[k, p] = cs * akp - sn * akq
                    a[k, q] = sn * akp + cs * akq
                for k in range(c):
                    apk, aqk = a[p, k], a[q, k]
                    a[p, k] = cs * apk - sn * aqk
                    a[q, k] = sn * apk + cs * aqk
                for k in range(c):
                    vkp, vkq = v[k, p], v[k, q]
                    v[k, p] = cs * vkp - sn * vkq
                    v[k, q] = sn * vkp + cs * vkq
    w = np.empty(c)
    for i in range(c):
        w[i] = a[i, i]
    return w, v


@_jit
def _gain(
    m: Array, tr: float, env_inv: float, unloaded_tol: float, g: Array
) -> tuple[int, bool]:  # pragma: no cover - compiled
    """G of ``compliance.loaded_gain`` into g (c×c); returns (unloaded directions, ok)."""
    c = m.shape[0]
    if env_inv > 0.0:  # (m + I/k_env)⁻¹ by Cholesky (symmetric positive definite)
        return 0, cholesky_inverse(m, env_inv, g)
    limit = unloaded_tol * max(tr, 1e-300)
    if c == 1:  # one constraint direction: m is its own eigenvalue
        if m[0, 0] > limit:
            g[0, 0] = 1.0 / m[0, 0]
            return 0, True
        g[0, 0] = 0.0
        return 1, True
    w, v = _jacobi(m)
    dropped = 0
    for i in range(c):
        for j in range(c):
            g[i, j] = 0.0
    for k in range(c):
        if w[k] > limit:
            inv = 1.0 / w[k]
            for i in range(c):
                f = v[i, k] * inv
                for j in range(c):
                    g[i, j] += f * v[j, k]
        else:
            dropped += 1
    return dropped, True


@_jit
def _shift_rows(a: Array, d0: float, d1: float, d2: float) -> None:  # pragma: no cover - compiled
    """S_t1 A in place for A (6×m): v += d × ω column by column (eq:twists)."""
    for i in range(a.shape[1]):
        w0, w1, w2 = a[3, i], a[4, i], a[5, i]
        a[0, i] += d1 * w2 - d2 * w1
        a[1, i] += d2 * w0 - d0 * w2
        a[2, i] += d0 * w1 - d1 * w0


@_jit
def _finish(
    ce: Array, c2: Array, out: Array, beta: Array, i: int, bi: int
) -> tuple[float, bool]:  # pragma: no cover - compiled
    """C_e = sym(ce + c2) into out[i]; returns (C_i along beta[bi], finite)."""
    ok = True
    for r in range(6):
        for c in range(6):
            x = 0.5 * ((ce[r, c] + c2[r, c]) + (ce[c, r] + c2[c, r]))
            out[i, r, c] = x
            if not math.isfinite(x):
                ok = False
    s = 0.0
    for c in range(6):
        v = 0.0
        for r in range(6):
            v += beta[bi, r] * out[i, r, c]
        s += v * v
    ci = math.sqrt(s)
    return ci, ok and math.isfinite(ci)
