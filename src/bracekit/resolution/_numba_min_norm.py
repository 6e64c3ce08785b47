"""numba kernel of the minimum-norm steps (internal; ``pip install bracekit[fast]``).

:class:`bracekit.resolution.min_norm.MinNormStep` imports this module on first use. :func:`min_norm_step` takes
the state's J_e, J_b and the points b, e and gives, in one compiled call, the q̇ of
:class:`~bracekit.resolution.FreeSpaceMinNorm` (J⁺ ẋ) or of :class:`~bracekit.resolution.BracedMinNorm` with one
brace ([ḃ; q̇2] = A⁺ ẋ, eq:general_inv with η = 0, q̇1 = dq1/db̃ ḃ, eq:q1) for the full pose or the position
(S = [I 0]: the first three rows of J, A and ẋ), with the formulas,
shortcuts and certificates of the NumPy code of :mod:`bracekit.resolution.min_norm` and of the fused
gradient-projection kernel (:mod:`bracekit.resolution._numba_step`): dq1/db̃ = J1⁻¹ H by LU when n1 = 6, else an
orthonormal basis of the null space of Xᵀ J1 (q̇ does not depend on the choice of basis); M⁺ = Q R⁻ᵀ from a
Householder QR Mᵀ = QR, certified by ‖M‖²_F ‖R⁻¹‖²_F < CERTIFIED_COND². Where a certificate fails it returns a
non-zero status and the caller takes the strategy's own velocity. Compiled on first call, cached on disk.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numpy.typing import NDArray

from bracekit.resolution._numba_linalg import _frobenius2, _row_basis
from bracekit.resolution._numba_step import _split_map, chain1

#: Status codes of :func:`min_norm_step`.
OK, NOT_CERTIFIED = 0, 1

Array = NDArray[np.float64]

_jit = njit(cache=True, error_model="numpy", nogil=True)


@_jit
def _pinv_times(at: Array, xd: Array, cert2: float) -> tuple[bool, Array]:  # pragma: no cover - compiled
    """(ok, M⁺ ẋ) from Mᵀ = at (k×m, k ≥ m) = QR: Q R⁻ᵀ ẋ[:m], ok where ‖M‖²_F ‖R⁻¹‖²_F < cert2."""
    k, m = at.shape
    y = np.zeros(k)
    if k < m:
        return False, y
    q, rinv, ok = _row_basis(at)
    if not ok or not _frobenius2(at) * _frobenius2(rinv) < cert2:
        return False, y
    z = np.zeros(m)  # R⁻ᵀ ẋ
    for c in range(m):
        s = 0.0
        for r in range(m):
            s += rinv[r, c] * xd[r]
        z[c] = s
    for i in range(k):
        s = 0.0
        for c in range(m):
            s += q[i, c] * z[c]
        y[i] = s
    return True, y


@_jit
def min_norm_step(
    je: Array,
    jb: Array,
    b: Array,
    e: Array,
    xd: Array,
    h: Array,
    x: Array,
    n1: int,
    braced: bool,
    rows: int,
    cert2: float,
    null_rtol: float,
) -> tuple[int, Array]:  # pragma: no cover - compiled
    """(status, q̇) of a minimum-norm step: (S J)⁺ S ẋ, or with `braced` eq:general_inv and eq:q1 in S's rows.

    Args:
        je: the frame Jacobian of {e} (6×n, world axes, LOCAL_WORLD_ALIGNED).
        jb: the frame Jacobian of {b} (6×n, world axes); unused without `braced`.
        b: the point b (3,), m.
        e: the point e (3,), m.
        xd: the tip twist ẋ (6,).
        h: H (6×l) of the contact.
        x: X (6×(6−l)) of the contact.
        n1: joints of chain 1 (1 ≤ n1 < n).
        braced: BracedMinNorm (else FreeSpaceMinNorm).
        rows: 6 for the full pose, 3 for the position (S = [I 0]).
        cert2: CERTIFIED_COND².
        null_rtol: NULL_SPACE_RTOL.
    """
    n = je.shape[1]
    out = np.zeros(n)
    if not braced:
        at = np.empty((n, rows))
        for i in range(n):
            for r in range(rows):
                at[i, r] = je[r, i]
        ok, y = _pinv_times(at, xd, cert2)
        if not ok:
            return NOT_CERTIFIED, out
        return OK, y
    n2 = n - n1
    nc = x.shape[1]
    if n1 < 1 or n2 < 0 or nc < 1:
        return NOT_CERTIFIED, out
    l_ = h.shape[1] if n1 == 6 else max(n1 - nc, 0)
    kk = l_ + n2
    if kk < rows:  # fewer braced coordinates than task rows: S A has no full row rank
        return NOT_CERTIFIED, out
    ok, _, _, g1, first = chain1(jb, b[0] - e[0], b[1] - e[1], b[2] - e[2], h, x, n1, cert2, null_rtol)
    if not ok:
        return NOT_CERTIFIED, out
    at = np.empty((kk, rows))  # (S A)ᵀ, A = [S_t1 J1 dq1/db̃, J_e[:, n1:]] (eq:braced_kin)
    for c in range(l_):
        for r in range(rows):
            at[c, r] = first[r, c]
    for c in range(n2):
        for r in range(rows):
            at[l_ + c, r] = je[r, n1 + c]
    ok, y = _pinv_times(at, xd, cert2)
    if not ok:
        return NOT_CERTIFIED, out
    _split_map(g1, y, out, False)  # q̇1 = dq1/db̃ ḃ (eq:q1), q̇2
    return OK, out
