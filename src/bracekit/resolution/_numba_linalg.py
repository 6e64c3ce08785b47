"""The compiled linear algebra of the fused step (internal, numba).

LU with partial pivoting, small products, the Householder row basis and null space, and the shifted SPD inverse
of :mod:`bracekit.resolution._numba_step`.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

from bracekit._cholesky import cholesky, cholesky_inverse

Array = NDArray[np.float64]
IntArray = NDArray[np.int64]


_jit = njit(cache=True, error_model="numpy", nogil=True)


@_jit
def _lu(m: Array) -> tuple[Array, IntArray, bool]:  # pragma: no cover - compiled
    """LU with partial pivoting of a square matrix, in a copy: (lu, piv, ok); ok is False on a zero pivot."""
    n = m.shape[0]
    lu = m.copy()
    piv = np.arange(n)
    for k in range(n):
        p, big = k, abs(lu[k, k])
        for i in range(k + 1, n):
            if abs(lu[i, k]) > big:
                p, big = i, abs(lu[i, k])
        if not big > 0.0:  # also nan
            return lu, piv, False
        if p != k:
            for j in range(n):
                lu[k, j], lu[p, j] = lu[p, j], lu[k, j]
            piv[k], piv[p] = piv[p], piv[k]
        d = lu[k, k]
        for i in range(k + 1, n):
            f = lu[i, k] / d
            lu[i, k] = f
            if f != 0.0:
                for j in range(k + 1, n):
                    lu[i, j] -= f * lu[k, j]
    return lu, piv, True


@_jit
def _lu_solve(lu: Array, piv: IntArray, b: Array) -> Array:  # pragma: no cover - compiled
    """M⁻¹ B for the LU factors of M and a matrix B (n×p)."""
    n, p = b.shape
    x = np.empty((n, p))
    for i in range(n):
        for c in range(p):
            x[i, c] = b[piv[i], c]
    for c in range(p):
        for i in range(n):
            s = x[i, c]
            for j in range(i):
                s -= lu[i, j] * x[j, c]
            x[i, c] = s
        for i in range(n - 1, -1, -1):
            s = x[i, c]
            for j in range(i + 1, n):
                s -= lu[i, j] * x[j, c]
            x[i, c] = s / lu[i, i]
    return x


@_jit
def _mm(a: Array, b: Array) -> Array:  # pragma: no cover - compiled
    """A B of small matrices (plain loops: no BLAS call, any layout)."""
    m, p = a.shape
    c = np.zeros((m, b.shape[1]))
    for i in range(m):
        for k in range(p):
            f = a[i, k]
            for j in range(b.shape[1]):
                c[i, j] += f * b[k, j]
    return c


@_jit
def _tmm(a: Array, b: Array) -> Array:  # pragma: no cover - compiled
    """Aᵀ B of small matrices (plain loops, any layout; each entry summed over the rows in order)."""
    out = np.empty((a.shape[1], b.shape[1]))
    for c in range(a.shape[1]):
        for i in range(b.shape[1]):
            s = 0.0
            for r in range(a.shape[0]):
                s += a[r, c] * b[r, i]
            out[c, i] = s
    return out


@_jit
def _matvec(a: Array, x: Array) -> Array:  # pragma: no cover - compiled
    """A x (plain loops, any layout)."""
    out = np.empty(a.shape[0])
    for r in range(a.shape[0]):
        s = 0.0
        for i in range(a.shape[1]):
            s += a[r, i] * x[i]
        out[r] = s
    return out


@_jit
def _tmatvec(a: Array, x: Array) -> Array:  # pragma: no cover - compiled
    """Aᵀ x (plain loops, any layout)."""
    return _matvec(a.T, x)


@_jit
def _region_pull(mb: Array, row: Array) -> tuple[bool, float, float, float]:  # pragma: no cover - compiled
    """RegionBarrier.gradient's pull on b (⁰M_b, 4×4) for a row (centre (3), r_max, weight): (inside, c · (b − p)).

    c = weight · 2 r_max² / (r_max² − r²)², the factor of J_b[:3]ᵀ (b − p) in ∂d/∂q; inside False at r ≥ r_max.
    """
    rel0, rel1, rel2 = mb[0, 3] - row[0], mb[1, 3] - row[1], mb[2, 3] - row[2]
    r2 = rel0 * rel0 + rel1 * rel1 + rel2 * rel2
    rm2 = row[3] * row[3]
    if not r2 < rm2:
        return False, 0.0, 0.0, 0.0
    c = row[4] * 2.0 * rm2 / (rm2 - r2) ** 2
    return True, c * rel0, c * rel1, c * rel2


@_jit
def _frobenius2(m: Array) -> float:  # pragma: no cover - compiled
    s = 0.0
    for i in range(m.shape[0]):
        for j in range(m.shape[1]):
            s += m[i, j] * m[i, j]
    return s


@_jit
def _householder(r: Array) -> tuple[Array, bool]:  # pragma: no cover - compiled
    """Householder QR of r (rows×cols, rows ≥ cols) in place: R in its upper triangle (zeros below).

    Returns (vs, ok): the unit reflector vectors vs[j] (H_j = I − 2 vs[j] vs[j]ᵀ, entries j… of row j), ok False
    on a zero column.
    """
    rows, cols = r.shape
    vs = np.zeros((cols, rows))
    for j in range(cols):
        norm = 0.0
        for i in range(j, rows):
            norm += r[i, j] * r[i, j]
        norm = math.sqrt(norm)
        if not norm > 0.0:
            return vs, False
        alpha = -norm if r[j, j] >= 0.0 else norm
        for i in range(j, rows):
            vs[j, i] = r[i, j]
        vs[j, j] -= alpha
        vn = 0.0
        for i in range(j, rows):
            vn += vs[j, i] * vs[j, i]
        if vn > 0.0:
            for c in range(j, cols):
                s = 0.0
                for i in range(j, rows):
                    s += vs[j, i] * r[i, c]
                s *= 2.0 / vn
                for i in range(j, rows):
                    r[i, c] -= s * vs[j, i]
            for i in range(j, rows):
                vs[j, i] /= math.sqrt(vn)  # unit: H_j = I − 2 v vᵀ
        r[j, j] = alpha
        for i in range(j + 1, rows):
            r[i, j] = 0.0
    return vs, True


@_jit
def _reflect(vs: Array, b: Array) -> None:  # pragma: no cover - compiled
    """H_0 … H_{c−1} b in place for the reflectors of :func:`_householder` (b: rows×p)."""
    for j in range(vs.shape[0] - 1, -1, -1):
        for c in range(b.shape[1]):
            s = 0.0
            for i in range(j, b.shape[0]):
                s += vs[j, i] * b[i, c]
            s *= 2.0
            for i in range(j, b.shape[0]):
                b[i, c] -= s * vs[j, i]


@_jit
def _row_basis(at: Array) -> tuple[Array, Array, bool]:  # pragma: no cover - compiled
    """Householder QR of Aᵀ (k×m, k ≥ m): (Q (k×m) orthonormal, R⁻¹ (m×m) upper, ok)."""
    k, m = at.shape
    r = at.copy()
    vs, ok = _householder(r)
    if not ok:
        return r, r, False
    q = np.zeros((k, m))  # Q = H_0 … H_{m−1} [I; 0]
    for i in range(m):
        q[i, i] = 1.0
    _reflect(vs, q)
    # R⁻¹ by back substitution
    rinv = np.zeros((m, m))
    for c in range(m):
        rinv[c, c] = 1.0 / r[c, c]
        for i in range(c - 1, -1, -1):
            s = 0.0
            for j in range(i + 1, c + 1):
                s += r[i, j] * rinv[j, c]
            rinv[i, c] = -s / r[i, i]
    return q, rinv, True


@_jit
def _spd_inverse(m: Array, shift: float) -> tuple[Array, bool]:  # pragma: no cover - compiled
    """(M⁻¹, ok) of a symmetric M by Cholesky; ok only if every eigenvalue of M exceeds `shift`.

    M − shift·I is tested positive definite by a first Cholesky (no eigen-decomposition).
    """
    c = m.shape[0]
    g = np.zeros((c, c))
    if not cholesky(m, -shift)[1]:
        return g, False
    return g, cholesky_inverse(m, 0.0, g)


@_jit
def _null_space(m: Array, cert2: float, null_rtol: float) -> tuple[Array, bool]:  # pragma: no cover - compiled
    """(N, ok): an orthonormal basis N (k×max(k − c, 0)) of the null space of M (c×k), by Householder QR.

    ok only where M has full rank min(c, k) with a margin: cond(M) ≤ ‖M‖_F ‖R⁻¹‖_F < √cert2 and
    σ_min(M) ≥ 1/‖R⁻¹‖_F > 2 · null_rtol · max(1, ‖M‖_F), so that ``contact_null_space``'s SVD finds the
    same rank (its basis may differ by a rotation within the null space, which q̇ does not depend on).
    """
    c, k = m.shape
    tall = k > c  # QR of Mᵀ (k×c); else QR of M (c×k)
    rows, cols = (k, c) if tall else (c, k)
    r = np.empty((rows, cols))
    for i in range(rows):
        for j in range(cols):
            r[i, j] = m[j, i] if tall else m[i, j]
    vs, ok = _householder(r)
    if not ok:
        return np.zeros((k, 0)), False
    # ‖R⁻¹‖²_F by back substitution (R = the upper cols×cols block)
    rinv2 = 0.0
    for cc in range(cols):
        col = np.zeros(cols)
        col[cc] = 1.0 / r[cc, cc]
        for i in range(cc - 1, -1, -1):
            t = 0.0
            for j in range(i + 1, cc + 1):
                t += r[i, j] * col[j]
            col[i] = -t / r[i, i]
        for i in range(cc + 1):
            rinv2 += col[i] * col[i]
    m2 = _frobenius2(m)
    if not (m2 * rinv2 < cert2 and 1.0 / math.sqrt(rinv2) > 2.0 * null_rtol * max(1.0, math.sqrt(m2))):
        return np.zeros((k, 0)), False
    if not tall:  # M has full column rank: no chain-1 motion keeps the contact
        return np.zeros((k, 0)), True
    # the last k − c columns of Q = H_0 … H_{c−1}
    basis = np.zeros((k, k - c))
    for i in range(k - c):
        basis[c + i, i] = 1.0
    _reflect(vs, basis)
    return basis, True
