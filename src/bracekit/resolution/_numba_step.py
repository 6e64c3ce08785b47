"""numba kernel of the fused braced gradient-projection step (internal; ``pip install bracekit[fast]``).

:class:`bracekit.resolution.GradientProjectionStep` with ``backend="numba"`` imports this module on first use.
Pinocchio still computes the placements, Jacobians and kinematic Hessians; :func:`gp_step` does all the
linear algebra of eq:grad_proj after them in one compiled call, with the formulas, shortcuts and
certificates of the NumPy backend (``bracekit/resolution/fused.py``):

* dq1/db̃ = J1⁻¹ H (eq:q1) by LU with partial pivoting when n1 = 6, certified by ‖J1‖²_F ‖J1⁻¹‖²_F <
  CERTIFIED_COND²; for any other n1, an orthonormal basis of the null space of Xᵀ J1 by Householder QR, certified
  to have the rank ``contact_null_space`` finds (q̇ does not depend on the choice of orthonormal basis);
* A⁺ = Q R⁻ᵀ and A⁺A = Q Qᵀ from a Householder QR Aᵀ = QR (eq:braced_kin), certified by
  ‖A‖²_F ‖R⁻¹‖²_F < CERTIFIED_COND² (the NumPy backend's bound, the same quantity);
* ∂g/∂q of the four terms of eq:objective (k, C_i in either compliance model, θ_z, d) contracted with the
  Hessians once per frame, C_e = Ĵ K⁻¹ Ĵᵀ applied to vectors (eq:Ce).

The kernel never raises or warns: where a shortcut is not certified, the contact is (nearly) unloaded or
the bracing point is outside its region, it returns a non-zero status and the caller takes the NumPy
backend's path, which raises, warns or falls back to the reference exactly as without numba.
Every function is compiled on first call and cached on disk (``cache=True``): later processes load it.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

from bracekit.resolution._numba_linalg import (
    _frobenius2,
    _lu,
    _lu_solve,
    _mm,
    _null_space,
    _region_pull,
    _row_basis,
    _spd_inverse,
    _tmm,
)

#: Status codes of :func:`gp_step`.
OK, NOT_CERTIFIED, UNLOADED, BARRIER = 0, 1, 2, 3

Array = NDArray[np.float64]

_jit = njit(cache=True, error_model="numpy", nogil=True)


@_jit
def _weighted_columns(m: Array, v: Array, kinv: Array, count: int) -> Array:
    """(Σ_r m[r, i] v[r]) · kinv[i] for the first `count` columns i of m (6×≥count): K⁻¹ mᵀ v, (count,)."""
    out = np.empty(count)
    for i in range(count):
        s = 0.0
        for r in range(6):
            s += m[r, i] * v[r]
        out[i] = s * kinv[i]
    return out


@_jit
def _split_map(g1: Array, v: Array, out: Array, transpose: bool) -> None:
    """Out = blkdiag(G1, I) v, or blkdiag(G1ᵀ, I) v with `transpose`: G1 = dq1/db̃ (n1×l), eq:q1 and eq:grad_g."""
    n1, l_ = g1.shape
    rows, cols = (l_, n1) if transpose else (n1, l_)
    for a in range(rows):
        s = 0.0
        for b in range(cols):
            s += (g1[b, a] if transpose else g1[a, b]) * v[b]
        out[a] = s
    for c in range(v.shape[0] - cols):
        out[rows + c] = v[cols + c]


@_jit
def chain1(
    jb: Array, d0: float, d1: float, d2: float, h: Array, x: Array, n1: int, cert2: float, null_rtol: float
) -> tuple[bool, Array, Array, Array, Array]:  # pragma: no cover - compiled
    """(ok, S_t1, J1, dq1/db̃, S_t1 J1 dq1/db̃) of one brace from J_b (6×n) and b − e = (d0, d1, d2).

    S_t1 = [[I, [b − e]×], [0, I]] (eq:twists); dq1/db̃ = J1⁻¹ H (eq:q1) by LU when n1 = 6, certified by
    ‖J1‖²_F ‖J1⁻¹‖²_F < cert2 (then S_t1 J1 dq1/db̃ = S_t1 H), else an orthonormal basis of the null space of
    Xᵀ J1 (:func:`~bracekit.resolution._numba_linalg._null_space`); ok False where not certified.
    """
    s1 = np.eye(6)
    s1[0, 4], s1[0, 5], s1[1, 3], s1[1, 5], s1[2, 3], s1[2, 4] = -d2, d1, d2, -d0, -d1, d0
    j1 = np.empty((6, n1))
    for r in range(6):
        for i in range(n1):
            j1[r, i] = jb[r, i]
    if n1 == 6:  # dq1/db̃ = J1⁻¹ H (eq:q1), and S_t1 J1 dq1/db̃ = S_t1 H
        lu, piv, ok = _lu(j1)
        if not ok:
            return False, s1, j1, j1, j1
        j1inv = _lu_solve(lu, piv, np.eye(6))
        if not _frobenius2(j1) * _frobenius2(j1inv) < cert2:
            return False, s1, j1, j1, j1
        return True, s1, j1, _mm(j1inv, h), _mm(s1, h)
    g1, ok = _null_space(_tmm(x, j1), cert2, null_rtol)  # dq1/db̃: the null space of Xᵀ J1
    if not ok:
        return False, s1, j1, j1, j1
    return True, s1, j1, g1, _mm(s1, _mm(j1, g1))


@_jit
def gp_step(
    je: Array,
    jb: Array,
    he: Array,
    hb: Array,
    mb: Array,
    me: Array,
    xd: Array,
    h: Array,
    x: Array,
    t_proj: Array,
    kinv: Array,
    ci: Array,
    reg: Array,
    normal: Array,
    par: Array,
    n1: int,
) -> tuple[int, Array]:  # pragma: no cover - compiled
    """(status, q̇) of one braced gradient-projection step (eq:grad_proj) with the analytic ∇g, any n1 ≥ 1.

    Args:
        je: the frame Jacobian of {e} (6×n, world axes, LOCAL_WORLD_ALIGNED).
        jb: the frame Jacobian of {b} (6×n, world axes).
        he: the kinematic Hessian of {e} as (n, 6n) rows, ``he[k, r + 6 i] = ∂J_e[r, i]/∂q_k``.
        hb: the same for {b}.
        mb: ⁰M_b (4×4).
        me: ⁰M_e (4×4).
        xd: the tip twist ẋ (6,).
        h: H (6×l) of the contact.
        x: X (6×(6−l)) of the contact.
        t_proj: I − P (6×6).
        kinv: 1/K (n,).
        ci: one row per compliance-index term: β_x (6), weight, 1.0 for the projection model else 0.0.
        reg: one row per region-barrier term: centre (3), r_max, weight.
        normal: the surface normal n̂ (3,).
        par: [α, CERTIFIED_COND², UNLOADED_TOL, weight of k, weight of θ_z, NULL_SPACE_RTOL].
        n1: joints of chain 1 (1 ≤ n1 ≤ n). dq1/db̃ is J1⁻¹ H (eq:q1) when n1 = 6, else an orthonormal basis
            of the null space of Xᵀ J1 (as ``BracedState.chain1_map``).
    """
    n = je.shape[1]
    n2 = n - n1
    out = np.zeros(n)
    alpha, cert2, unloaded_tol, w_k, w_theta = par[0], par[1], par[2], par[3], par[4]
    null_rtol = par[5]
    nc = x.shape[1]
    if n1 < 1 or n2 < 0 or nc < 1:
        return NOT_CERTIFIED, out
    l_ = h.shape[1] if n1 == 6 else max(n1 - nc, 0)
    kk = l_ + n2
    if kk < 6:  # fewer braced coordinates than twist components: no null space (as the NumPy code)
        return NOT_CERTIFIED, out
    d0, d1, d2 = mb[0, 3] - me[0, 3], mb[1, 3] - me[1, 3], mb[2, 3] - me[2, 3]
    ok, s1, j1, g1, first = chain1(jb, d0, d1, d2, h, x, n1, cert2, null_rtol)
    if not ok:
        return NOT_CERTIFIED, out
    # Aᵀ = [S_t1 J1 dq1/db̃, J_e[:, n1:]]ᵀ (eq:braced_kin) and its QR
    at = np.empty((kk, 6))
    for c in range(l_):
        for r in range(6):
            at[c, r] = first[r, c]
    for c in range(n2):
        for r in range(6):
            at[l_ + c, r] = je[r, n1 + c]
    q, rinv, ok = _row_basis(at)
    if not ok or not _frobenius2(at) * _frobenius2(rinv) < cert2:
        return NOT_CERTIFIED, out

    # --- ∂g/∂q: coefficients ue (of ∂J_e), ub (of ∂J_b, chain 1) and y (grad += J_bᵀ y[:6] + J_e[:3]ᵀ y[6:])
    ue = np.zeros((6, n))
    ub = np.zeros((6, n1))
    y = np.zeros(9)
    if w_k != 0.0:  # ConditionNumber.gradient: (b da + a db) / (72 k)
        mm = np.empty((6, 6))
        for r in range(6):
            for c in range(6):
                s = 0.0
                for i in range(n):
                    s += je[r, i] * je[c, i]
                mm[r, c] = s
        lu, piv, ok = _lu(mm)
        if not ok:
            return NOT_CERTIFIED, out
        yy = _lu_solve(lu, piv, je)
        zz = _lu_solve(lu, piv, yy)
        a = _frobenius2(je)
        bb = _frobenius2(yy)
        if not a * bb < cert2:
            return NOT_CERTIFIED, out
        cst = w_k / (6.0 * math.sqrt(a * bb))
        for r in range(6):
            for i in range(n):
                ue[r, i] += je[r, i] * (cst * bb) - zz[r, i] * (cst * a)
    if ci.shape[0] > 0:  # ComplianceIndex.gradient
        t_con = np.zeros((6, 6))
        constrained_done = False
        for term in range(ci.shape[0]):
            weight = ci[term, 6]
            if ci[term, 7] != 0.0:
                t = t_proj
            else:
                if not constrained_done:  # T = I − C1 X G Xᵀ, G = (Xᵀ C1 X)⁻¹
                    nc = x.shape[1]
                    cx = np.zeros((6, nc))
                    tr = 0.0
                    for r in range(6):
                        for i in range(n1):
                            tr += jb[r, i] * jb[r, i] * kinv[i]
                    for c in range(nc):
                        jx = _weighted_columns(jb, x[:, c], kinv, n1)  # K1⁻¹ J1ᵀ X[:, c]
                        for r in range(6):
                            s = 0.0
                            for i in range(n1):
                                s += jb[r, i] * jx[i]
                            cx[r, c] = s
                    m = _tmm(x, cx)
                    # loaded with a margin: every eigenvalue of m above 2 · UNLOADED_TOL · tr(C1)
                    g, ok = _spd_inverse(m, 2.0 * unloaded_tol * max(tr, 1e-300))
                    if not ok:
                        return UNLOADED, out
                    cg = _mm(cx, g)
                    for r in range(6):
                        for c in range(6):
                            s = 0.0
                            for p in range(nc):
                                s += cg[r, p] * x[c, p]
                            t_con[r, c] = (1.0 if r == c else 0.0) - s
                    constrained_done = True
                t = t_con
            s1t = _mm(s1, t)
            tj1 = _mm(t, j1)
            jh = np.empty((6, n))  # Ĵ = [S_t1 T J1, J_e2]
            for r in range(6):
                for i in range(n1):
                    s = 0.0
                    for p in range(6):
                        s += s1t[r, p] * j1[p, i]
                    jh[r, i] = s
                for i in range(n1, n):
                    jh[r, i] = je[r, i]
            uk = _weighted_columns(jh, ci[term, :6], kinv, n)  # K⁻¹ Ĵᵀ β
            v = np.zeros(6)  # C_e β
            for r in range(6):
                s = 0.0
                for i in range(n):
                    s += jh[r, i] * uk[i]
                v[r] = s
            cval = math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2] + v[3] * v[3] + v[4] * v[4] + v[5] * v[5])
            if cval == 0.0:
                continue
            f = weight / cval
            wu0 = np.empty(n)
            wu1 = np.empty(n)
            for i in range(n):
                s = 0.0
                for r in range(6):
                    s += v[r] * jh[r, i]
                wu0[i] = s * kinv[i] * f
                wu1[i] = uk[i] * f
            # β ⊗ wu0 + v ⊗ wu1: chain 2 against ∂J_e, chain 1 through (S_t1 T)ᵀ against ∂J_b
            for r in range(6):
                for i in range(n1, n):
                    ue[r, i] += ci[term, r] * wu0[i] + v[r] * wu1[i]
            pb1 = np.empty((6, n1))
            for r in range(6):
                for i in range(n1):
                    pb1[r, i] = ci[term, r] * wu0[i] + v[r] * wu1[i]
            for r in range(6):
                for i in range(n1):
                    s = 0.0
                    for p in range(6):
                        s += s1t[p, r] * pb1[p, i]
                    ub[r, i] += s
            # S_t1 depends on b − e: (J_b[:3] − J_e[:3])ᵀ ((C̃1 S_t1ᵀ v)_ω × β_v + (C̃1 S_t1ᵀ β)_ω × v_v)
            cv = np.zeros(3)
            cb = np.zeros(3)
            for r in range(3):
                s0 = 0.0
                s1_ = 0.0
                for i in range(n1):
                    s0 += wu0[i] * tj1[3 + r, i]
                    s1_ += wu1[i] * tj1[3 + r, i]
                cv[r] = s0
                cb[r] = s1_
            b0, b1, b2 = ci[term, 0], ci[term, 1], ci[term, 2]
            w0 = cv[1] * b2 - cv[2] * b1 + cb[1] * v[2] - cb[2] * v[1]
            w1 = cv[2] * b0 - cv[0] * b2 + cb[2] * v[0] - cb[0] * v[2]
            w2 = cv[0] * b1 - cv[1] * b0 + cb[0] * v[1] - cb[1] * v[0]
            y[0] += w0
            y[1] += w1
            y[2] += w2
            y[6] -= w0
            y[7] -= w1
            y[8] -= w2
    if w_theta != 0.0:  # BraceAngle.gradient: J_b[3:]ᵀ (n̂ × ẑ_b) / ‖n̂ × ẑ_b‖
        z0, z1, z2 = mb[0, 2], mb[1, 2], mb[2, 2]
        u0 = normal[1] * z2 - normal[2] * z1
        u1 = normal[2] * z0 - normal[0] * z2
        u2 = normal[0] * z1 - normal[1] * z0
        s = math.sqrt(u0 * u0 + u1 * u1 + u2 * u2)
        if s >= 1e-12:
            y[3] += w_theta * u0 / s
            y[4] += w_theta * u1 / s
            y[5] += w_theta * u2 / s
    for term in range(reg.shape[0]):  # RegionBarrier.gradient
        inside, p0, p1, p2 = _region_pull(mb, reg[term])
        if not inside:
            return BARRIER, out
        y[0] += p0
        y[1] += p1
        y[2] += p2
    dg = np.zeros(n)
    for k in range(n):
        s = 0.0
        for r in range(6):
            s += jb[r, k] * y[r]
        for r in range(3):
            s += je[r, k] * y[6 + r]
        for i in range(n):  # Σ_{r,i} ue[r, i] ∂J_e[r, i]/∂q_k
            for r in range(6):
                s += he[k, r + 6 * i] * ue[r, i]
        for i in range(n1):
            for r in range(6):
                s += hb[k, r + 6 * i] * ub[r, i]
        dg[k] = s

    # --- ∇g = [(dq1/db̃)ᵀ ∂g/∂q1; ∂g/∂q2] (eq:grad_g) and A⁺ẋ + (I − A⁺A) α ∇g (eq:grad_proj)
    grad = np.empty(kk)
    _split_map(g1, dg, grad, True)
    z = np.zeros(6)  # R⁻ᵀ ẋ − α Qᵀ ∇g
    for c in range(6):
        s = 0.0
        for r in range(6):
            s += rinv[r, c] * xd[r]
        s2 = 0.0
        for i in range(kk):
            s2 += q[i, c] * grad[i]
        z[c] = s - alpha * s2
    yv = np.empty(kk)
    for i in range(kk):
        s = 0.0
        for c in range(6):
            s += q[i, c] * z[c]
        yv[i] = s + alpha * grad[i]
    _split_map(g1, yv, out, False)  # q̇1 = dq1/db̃ ḃ (eq:q1), q̇2
    return OK, out
