"""numba kernel of the batch evaluation (internal; ``pip install bracekit[fast]``).

:class:`bracekit.compliance.batch.BatchEvaluator` imports this module on first use when numba is installed.
:func:`evaluate` computes, for every configuration and in parallel over configurations (``prange``), what the
NumPy path of :mod:`bracekit.compliance.batch` computes, with the same formulas:

* the frames of {e} and {b} by the product of exponentials of :class:`~bracekit.compliance.batch.ChainKinematics`
  (its joint placements, axes and motion, as arrays);
* C_e of both compliance models (eq:Ce), with the constrained model's loaded gain G as
  ``compliance.loaded_gain`` (eigenvalues of Xᵀ C1 X by cyclic Jacobi, unloaded directions dropped and flagged);
* C_i = ‖β_xᵀ C_e‖ (eq:compliance_index) and k of J_e (and of J̃) from a Cholesky factor of JJᵀ (eq:manip).

The kernel never raises or warns. Each row gets flags: :data:`K_UNCERTIFIED` / :data:`KB_UNCERTIFIED` where the
Cholesky shortcut of k is not certified below CERTIFIED_COND (the caller recomputes k there with
``frobenius_condition``, as the NumPy path does), :data:`UNLOADED_ROW` where a constraint direction carries no
load, and :data:`NOT_FINITE` where a compliance is not finite (the caller then runs the NumPy path, which
raises its NumericalError). Compiled on first call and cached on disk (``cache=True``).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange
from numpy.typing import NDArray

from bracekit.compliance._numba_kernels import _finish, _gain, _k2, _shift_rows

#: Row flags of :func:`evaluate`.
K_UNCERTIFIED, KB_UNCERTIFIED, NOT_FINITE, UNLOADED_ROW = 1, 2, 4, 8
#: Blocks of configurations :func:`evaluate` shares among its threads (each block allocates its scratch once).
BLOCKS = 64

Array = NDArray[np.float64]
IntArray = NDArray[np.int64]
#: The chain and contact (:class:`~bracekit.compliance.batch.BatchEvaluator`'s kernel constants, :func:`evaluate`).
Chain = tuple[
    Array,
    Array,
    IntArray,
    IntArray,
    Array,
    Array,
    IntArray,
    Array,
    IntArray,
    Array,
    int,
    Array,
    Array,
    float,
    float,
    float,
]
#: β_x and what to compute: (beta, do_con, do_proj, do_kb).
Task = tuple[Array, bool, bool, bool]
#: The outputs, written in place: (ce_con, ce_proj, ci_con, ci_proj, k, kb, flags).
Outputs = tuple[Array, Array, Array, Array, Array, Array, IntArray]

_jit = njit(cache=True, fastmath=False, error_model="numpy", nogil=True)


@_jit
def _gram(a: Array, kinv: Array, lo: int, hi: int, out: Array) -> bool:  # pragma: no cover - compiled
    """Out = A K⁻¹ Aᵀ over the columns lo … hi − 1 of A (6×·), 6×6 (the upper triangle, mirrored); all finite?"""
    finite = True
    for r in range(6):
        for c in range(r, 6):
            s = 0.0
            for p in range(lo, hi):
                s += a[r, p] * kinv[p] * a[c, p]
            out[r, c] = s
            out[c, r] = s
            if not math.isfinite(s):
                finite = False
    return finite


@_jit
def _product(a: Array, b: Array, transposed: bool, out: Array) -> bool:  # pragma: no cover - compiled
    """Out = A B (or Aᵀ B when `transposed`), each entry summed over the inner index in order; all finite?"""
    finite = True
    inner = a.shape[0] if transposed else a.shape[1]
    for r in range(out.shape[0]):
        for c in range(out.shape[1]):
            s = 0.0
            for p in range(inner):
                s += (a[p, r] if transposed else a[r, p]) * b[p, c]
            out[r, c] = s
            if not math.isfinite(s):
                finite = False
    return finite


@_jit
def _rows(
    start: int, stop: int, q: Array, chain: Chain, task: Task, out: Outputs
) -> None:  # pragma: no cover - compiled
    """Rows start … stop − 1 of :func:`evaluate` (one thread's share), with their own scratch arrays."""
    (
        speed,
        along,
        col,
        parent,
        place_r,
        place_t,
        frame_parent,
        frame_r,
        support,
        kinv,
        n1,
        x,
        t_proj,
        env_inv,
        unloaded_tol,
        cert2,
    ) = chain
    beta, do_con, do_proj, do_kb = task
    ce_con, ce_proj, ci_con, ci_proj, k, kb, flags = out
    n = q.shape[1]
    J = speed.shape[0]
    nc = x.shape[1]
    rot = np.empty((J + 1, 3, 3))
    pos = np.zeros((J + 1, 3))
    for a in range(3):
        for b in range(3):
            rot[0, a, b] = 1.0 if a == b else 0.0
    axes = np.zeros((n, 3))
    origins = np.zeros((n, 3))
    revolute = np.zeros(n, dtype=np.bool_)
    jac = np.zeros((2, 6, n))
    fp = np.zeros((2, 3))
    c2 = np.zeros((6, 6))
    tj1 = np.zeros((6, n1))
    work = np.zeros((6, 6))
    c1 = np.zeros((6, 6))
    cx = np.zeros((6, nc))
    m = np.zeros((nc, nc))
    g = np.zeros((nc, nc))
    mm = np.zeros((6, 6))
    lo = np.zeros((6, 6))
    col6 = np.zeros(6)
    for i in range(start, stop):
        flag = 0
        # --- frames: M_j = M_parent · placement_j · exp(S_j q_j), each joint about its own z axis
        for j in range(J):
            p = parent[j]
            cj = col[j]
            for a in range(3):
                for b in range(3):
                    s = 0.0
                    for c in range(3):
                        s += rot[p, a, c] * place_r[j, c, b]
                    rot[j + 1, a, b] = s
                s = pos[p, a]
                for c in range(3):
                    s += rot[p, a, c] * place_t[j, c]
                pos[j + 1, a] = s
            for a in range(3):
                origins[cj, a] = pos[j + 1, a]
            if along[j] != 0.0:
                f = along[j] * q[i, cj]
                for a in range(3):
                    pos[j + 1, a] += rot[j + 1, a, 2] * f
            if speed[j] != 0.0:
                ang = q[i, cj] * speed[j] if speed[j] != 1.0 else q[i, cj]
                co, si = math.cos(ang), math.sin(ang)
                for a in range(3):
                    x0, y0 = rot[j + 1, a, 0], rot[j + 1, a, 1]
                    rot[j + 1, a, 0] = co * x0 + si * y0
                    rot[j + 1, a, 1] = co * y0 - si * x0
                    axes[cj, a] = rot[j + 1, a, 2] * speed[j]
                revolute[cj] = True
            else:
                for a in range(3):
                    axes[cj, a] = rot[j + 1, a, 2] * along[j]
        for f in range(2):
            p = frame_parent[f]
            for a in range(3):
                s = pos[p, a]
                for c in range(3):
                    s += rot[p, a, c] * frame_r[f, c]
                fp[f, a] = s
            for cj in range(n):
                if support[f, cj] == 0:
                    for r in range(6):
                        jac[f, r, cj] = 0.0
                    continue
                z0, z1, z2 = axes[cj, 0], axes[cj, 1], axes[cj, 2]
                if revolute[cj]:
                    r0, r1, r2 = fp[f, 0] - origins[cj, 0], fp[f, 1] - origins[cj, 1], fp[f, 2] - origins[cj, 2]
                    jac[f, 0, cj] = z1 * r2 - z2 * r1
                    jac[f, 1, cj] = z2 * r0 - z0 * r2
                    jac[f, 2, cj] = z0 * r1 - z1 * r0
                    jac[f, 3, cj], jac[f, 4, cj], jac[f, 5, cj] = z0, z1, z2
                else:
                    jac[f, 0, cj], jac[f, 1, cj], jac[f, 2, cj] = z0, z1, z2
                    jac[f, 3, cj], jac[f, 4, cj], jac[f, 5, cj] = 0.0, 0.0, 0.0
        d0, d1, d2 = fp[1, 0] - fp[0, 0], fp[1, 1] - fp[0, 1], fp[1, 2] - fp[0, 2]  # b − e
        bi = i if beta.shape[0] > 1 else 0
        # --- S_t2 C2 S_t2ᵀ = J_e2 K2⁻¹ J_e2ᵀ
        _gram(jac[0], kinv, n1, n, c2)
        # --- Ĵ1 = S_t1 (I − P) J1 (projection model and J̃)
        if do_proj or do_kb:
            for r in range(6):
                for p in range(n1):
                    s = 0.0
                    for c in range(6):
                        s += t_proj[r, c] * jac[1, c, p]
                    tj1[r, p] = s
            _shift_rows(tj1, d0, d1, d2)
        if do_proj:
            _gram(tj1, kinv, 0, n1, work)
            cival, ok = _finish(work, c2, ce_proj, beta, i, bi)
            ci_proj[i] = cival
            if not ok:
                flag |= NOT_FINITE
        if do_con:  # C̃1 = C1 − C1 X G Xᵀ C1, then S_t1 C̃1 S_t1ᵀ
            if not _gram(jac[1], kinv, 0, n1, c1):
                flag |= NOT_FINITE
            tr = 0.0
            for r in range(6):
                tr += c1[r, r]
            _product(c1, x, False, cx)  # C1 X
            if not _product(x, cx, True, m):  # Xᵀ C1 X
                flag |= NOT_FINITE
            if flag & NOT_FINITE == 0:
                dropped, ok = _gain(m, tr, env_inv, unloaded_tol, g)
                if not ok:
                    flag |= NOT_FINITE
                if dropped:
                    flag |= UNLOADED_ROW
                for r in range(6):
                    for c in range(6):
                        s = 0.0
                        for a in range(nc):
                            t = 0.0
                            for b in range(nc):
                                t += g[a, b] * cx[c, b]
                            s += cx[r, a] * t
                        work[r, c] = c1[r, c] - s
                for r in range(6):
                    for c in range(r, 6):
                        v = 0.5 * (work[r, c] + work[c, r])
                        work[r, c] = v
                        work[c, r] = v
                _shift_rows(work, d0, d1, d2)  # S_t1 C̃1
                for r in range(6):  # (S_t1 (S_t1 C̃1)ᵀ)ᵀ: the same shift on each row
                    w0, w1, w2 = work[r, 3], work[r, 4], work[r, 5]
                    work[r, 0] += d1 * w2 - d2 * w1
                    work[r, 1] += d2 * w0 - d0 * w2
                    work[r, 2] += d0 * w1 - d1 * w0
                cival, ok = _finish(work, c2, ce_con, beta, i, bi)
                ci_con[i] = cival
                if not ok:
                    flag |= NOT_FINITE
        # --- k of J_e (eq:manip), and of J̃ = [Ĵ1, J_e2]
        k[i] = _certified_k(jac[0], jac[0], 0, n, mm, lo, col6, cert2)
        if not math.isfinite(k[i]):
            flag |= K_UNCERTIFIED
        if do_kb:
            kb[i] = _certified_k(tj1, jac[0], n1, n, mm, lo, col6, cert2)
            if not math.isfinite(kb[i]):
                flag |= KB_UNCERTIFIED
        flags[i] = flag


@njit(cache=True, fastmath=False, error_model="numpy", nogil=True)
def _certified_k(
    left: Array, right: Array, n1: int, n: int, mm: Array, lo: Array, col6: Array, cert2: float
) -> float:  # pragma: no cover - compiled
    """K (eq:manip) of the 6×n matrix whose first n1 columns are left's and the rest right's; NaN if uncertified.

    mm (6×6) receives the Gram matrix M Mᵀ; k² = tr(M Mᵀ) tr((M Mᵀ)⁻¹) / 36 must stay below cert2 (CERTIFIED_COND²).
    """
    for r in range(6):
        for c in range(r, 6):
            s = 0.0
            for p in range(n1):
                s += left[r, p] * left[c, p]
            for p in range(n1, n):
                s += right[r, p] * right[c, p]
            mm[r, c] = s
            mm[c, r] = s
    k2 = _k2(mm, lo, col6)
    return math.sqrt(k2) / 6.0 if k2 < cert2 else math.nan


@njit(parallel=True, cache=True, fastmath=False, error_model="numpy")
def evaluate(q: Array, chain: Chain, task: Task, out: Outputs) -> None:  # pragma: no cover - compiled
    """C_e, C_i and k of every row of q (N×n) into the output arrays; per-row flags (see the module docstring).

    Args:
        q: configurations (N×n), chain order.
        chain: the chain and contact (``BatchEvaluator``'s kernel constants), a tuple of
            speed: per joint (J,), |ω| per unit q (0 for a prismatic joint).
            along: per joint (J,), the speed along its axis per unit q (ChainKinematics' motion).
            col: per joint (J,), its column in q.
            parent: per joint (J,), its parent joint (0: the base; joint j is 1 + its index).
            place_r: per joint (J, 3, 3), the rotation of its placement in the parent's z-aligned frame.
            place_t: per joint (J, 3), the translation of that placement, m.
            frame_parent: the joint that carries {e} and {b} (2,).
            frame_r: the offsets of {e} and {b} in that joint's z-aligned frame (2, 3), m.
            support: (2, n) 1 where a column moves the frame, else 0.
            kinv: 1/K (n,).
            n1: joints of chain 1.
            x: X (6×c), the constraint wrenches.
            t_proj: I − P (6×6).
            env_inv: 1/k_env, or 0 for a rigid environment.
            unloaded_tol: UNLOADED_TOL.
            cert2: CERTIFIED_COND².
        task: the twist and what to compute, a tuple of
            beta: unit β_x, (1, 6) for every row or (N, 6).
            do_con: compute the constrained model.
            do_proj: compute the projection model.
            do_kb: compute k of J̃ too.
        out: the outputs, written in place, a tuple of
            ce_con: (N, 6, 6) output, C_e of the constrained model (or (0, 6, 6) when not computed).
            ce_proj: (N, 6, 6) output, C_e of the projection model (or (0, 6, 6)).
            ci_con: (N,) output, C_i of the constrained model (or empty).
            ci_proj: (N,) output, C_i of the projection model (or empty).
            k: (N,) output, k of J_e (NaN where flagged K_UNCERTIFIED).
            kb: (N,) output, k of J̃ (or empty; NaN where flagged KB_UNCERTIFIED).
            flags: (N,) int64 output, the row flags.
    """
    N = q.shape[0]
    block = max(1, (N + BLOCKS - 1) // BLOCKS)
    for bl in prange((N + block - 1) // block):
        start = bl * block
        _rows(start, min(N, start + block), q, chain, task, out)


@_jit
def evaluate_serial(q: Array, chain: Chain, task: Task, out: Outputs) -> None:  # pragma: no cover - compiled
    """:func:`evaluate` on the calling thread only (no threading layer: safe after a fork, no pool start-up)."""
    _rows(0, q.shape[0], q, chain, task, out)
