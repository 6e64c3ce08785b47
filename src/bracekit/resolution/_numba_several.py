"""numba kernel of the gradient-projection step with several braces (internal; ``pip install bracekit[fast]``).

:class:`bracekit.resolution.GradientProjectionStep` with ``backend="numba"`` and N ≥ 2 braces imports this
module on first use. Pinocchio computes the placements, Jacobians and kinematic Hessians of {e} and every
{b_i}; :func:`gp_step_several` does the rest of ``BracedGradientProjection.velocity`` in one compiled call
(docs/model.md, "Several braces"):

* G = [X_1ᵀ J_b1; X_2ᵀ J_b2; …] and its compliance metric M = G K⁻¹ Gᵀ, inverted by Cholesky; certified to
  keep every row (each eigenvalue of M above UNLOADED_TOL · max(‖M‖_F, max_i tr J_b_i K⁻¹ J_b_iᵀ), twice over,
  so ``stacked_constraint`` drops none);
* N, an orthonormal basis of the null space of G by Householder QR (the rank ``contact_null_space`` finds,
  certified), and B⁺ = Q R⁻ᵀ, B⁺B = Q Qᵀ of B = S J_e N by a QR Bᵀ = QR, certified by
  ‖B‖²_F ‖R⁻¹‖²_F < CERTIFIED_COND² (far from the reference's singularity threshold); q̇ does not depend on the
  choice of orthonormal basis N;
* ∂g/∂q of the terms with a compiled copy: C_i = ‖C_e β_x‖ of the constrained model (eq:Ce) through
  :func:`~bracekit.objective.compliance_gradient.bilinear_gradient`'s formula, each brace's region barrier d_i
  and the Chan–Dubey joint-limit barrier, contracted with each frame's Hessian once.

The kernel never raises or warns: where a certificate fails, a pad is outside its region or a joint at its
limit, it returns a non-zero status and the caller runs the reference step, which raises or warns.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

from bracekit.resolution._numba_linalg import (
    _frobenius2,
    _matvec,
    _null_space,
    _region_pull,
    _row_basis,
    _spd_inverse,
    _tmatvec,
)

Array = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: One Pinocchio pass: J_e, every J_b_i, the Hessian rows of {e} and of every {b_i}, every ⁰M_b_i.
Kinematics = tuple[Array, tuple[Array, ...], Array, tuple[Array, ...], tuple[Array, ...]]
#: The compiled terms' rows: compliance indices, region barriers, bounded joints of joint-limit barriers, and the
#: braced-conditioning barriers whose inactivity the kernel certifies.
Terms = tuple[Array, Array, Array, Array]

#: The braced-conditioning barrier counts as inactive where σ_min/σ_max provably exceeds its r₀ by this factor.
INACTIVE_MARGIN = 1.1

#: Status codes of :func:`gp_step_several` (those of the one-brace kernel).
OK, NOT_CERTIFIED, BARRIER = 0, 1, 3

_jit = njit(cache=True, error_model="numpy", nogil=True)


@_jit
def _constrained_deflection(
    je: Array, g: Array, minv: Array, kinv: Array, x: Array
) -> tuple[Array, Array]:  # pragma: no cover - compiled
    """(x̃, p_x) for a twist x (6,): p_x = M⁻¹ G K⁻¹ J_eᵀ x (c,), x̃ = K⁻¹ (J_eᵀ x − Gᵀ p_x) (n,)."""
    u = _tmatvec(je, x) * kinv
    p = _matvec(minv, _matvec(g, u))
    return u - kinv * _tmatvec(g, p), p


@_jit
def _conditioning_inactive(
    je: Array, g: Array, minv: Array, kinv: Array, rows: int, r0: float
) -> bool:  # pragma: no cover - compiled
    """Whether r = √(λ_min/λ_max) of S C_e Sᵀ (S the first `rows` rows of I₆) certainly exceeds INACTIVE_MARGIN · r₀.

    S C_e Sᵀ = S J_e K⁻¹ J_eᵀ Sᵀ − B M⁻¹ Bᵀ, B = S J_e K⁻¹ Gᵀ (eq:Ce, rigid braces); λ_min ≥ 1/‖(S C_e Sᵀ)⁻¹‖_F
    and λ_max ≤ ‖S C_e Sᵀ‖_F, so r² ≥ 1/(‖·‖_F ‖·⁻¹‖_F). Then the barrier and its gradient are 0 (eq:cond_barrier).
    """
    c, n = g.shape
    ms = np.empty((rows, rows))
    bs = np.empty((rows, c))
    for r in range(rows):
        for t in range(c):
            s = 0.0
            for i in range(n):
                s += je[r, i] * kinv[i] * g[t, i]
            bs[r, t] = s
    for r in range(rows):
        for t in range(rows):
            s = 0.0
            for i in range(n):
                s += je[r, i] * kinv[i] * je[t, i]
            for a in range(c):
                for b in range(c):
                    s -= bs[r, a] * minv[a, b] * bs[t, b]
            ms[r, t] = s
    inv, ok = _spd_inverse(ms, 0.0)
    return ok and 1.0 > _frobenius2(ms) * _frobenius2(inv) * (INACTIVE_MARGIN * r0) ** 4


@_jit
def _objective_gradient(
    q: Array, kin: Kinematics, g: Array, minv: Array, kinv: Array, xrows: Array, rowbrace: IntArray, terms: Terms
) -> tuple[int, Array]:  # pragma: no cover
    """(status, ∂g/∂q (n,)) of the compiled terms: C_i (constrained), region barriers d_i, joint-limit barrier."""
    je, jbs, he, hbs, mbs = kin
    ci, reg, jl, cond = terms
    for t in range(cond.shape[0]):  # a braced-conditioning barrier: zero where certified inactive, else declined
        if not _conditioning_inactive(je, g, minv, kinv, int(cond[t, 1]), cond[t, 0]):
            return NOT_CERTIFIED, np.zeros(je.shape[1])
    n = je.shape[1]
    nb = len(jbs)
    dg = np.zeros(n)
    ue = np.zeros((6, n))  # coefficients of ∂J_e
    ub = np.zeros((nb, 6, n))  # of ∂J_b_i
    yb = np.zeros((nb, 6))  # of J_b_i
    for t in range(ci.shape[0]):  # ComplianceIndex.gradient: (C_eβ)ᵀ (∂C_e/∂q) β / C_i, bilinear_gradient
        beta = ci[t, :6]
        bt, pb = _constrained_deflection(je, g, minv, kinv, beta)
        v = _matvec(je, bt)  # C_e β = J_e β̃
        civ = math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2] + v[3] * v[3] + v[4] * v[4] + v[5] * v[5])
        if not math.isfinite(civ):
            return NOT_CERTIFIED, dg
        if civ == 0.0:
            continue
        at, pa = _constrained_deflection(je, g, minv, kinv, v)
        f = ci[t, 6] / civ
        for r in range(6):
            for i in range(n):
                ue[r, i] += f * (v[r] * bt[i] + beta[r] * at[i])
        for row in range(g.shape[0]):
            b = rowbrace[row]
            for p in range(6):
                xp = xrows[row, p]
                if xp != 0.0:
                    for i in range(n):
                        ub[b, p, i] -= f * xp * (pb[row] * at[i] + pa[row] * bt[i])
    for t in range(reg.shape[0]):  # RegionBarrier.gradient of brace reg[t, 0]
        b = int(reg[t, 0])
        inside, p0, p1, p2 = _region_pull(mbs[b], reg[t, 1:])
        if not inside:
            return BARRIER, dg
        yb[b, 0] += p0
        yb[b, 1] += p1
        yb[b, 2] += p2
    for t in range(jl.shape[0]):  # JointLimitBarrier.gradient_of_q
        j = int(jl[t, 0])
        below, above = q[j] - jl[t, 1], jl[t, 2] - q[j]
        if not (below > 0.0 and above > 0.0):
            return BARRIER, dg
        span = jl[t, 2] - jl[t, 1]
        dg[j] += jl[t, 3] * (span * span * (below - above) / (4.0 * (below * above) ** 2))
    for k in range(n):
        s = dg[k]
        for b in range(nb):
            jb = jbs[b]
            hb = hbs[b]
            for p in range(6):
                s += jb[p, k] * yb[b, p]
            for i in range(n):
                for r in range(6):
                    s += hb[k, r + 6 * i] * ub[b, r, i]
        for i in range(n):
            for r in range(6):
                s += he[k, r + 6 * i] * ue[r, i]
        dg[k] = s
    return OK, dg


@_jit
def gp_step_several(
    q: Array,
    kin: Kinematics,
    sel: Array,
    xd: Array,
    xrows: Array,
    rowbrace: IntArray,
    kinv: Array,
    terms: Terms,
    par: Array,
) -> tuple[int, Array]:  # pragma: no cover
    """(status, q̇) of ``BracedGradientProjection.velocity`` with several braces and the analytic ∇g.

    q̇ = N [B⁺ S ẋ + α (I − B⁺B) Nᵀ ∂g/∂q], B = S J_e N.

    Args:
        q: the configuration (n,), rad.
        kin: one Pinocchio pass (:data:`Kinematics`): the frame Jacobian J_e of {e} (6×n, world axes,
            LOCAL_WORLD_ALIGNED), those of every {b_i} (a tuple), the kinematic Hessian of {e} as (n, 6n) rows
            (``he[k, r + 6 i] = ∂J_e[r, i]/∂q_k``), those of every {b_i}, and ⁰M_b_i (4×4) of every brace.
        sel: the task rows S(⁰R_e) (m×6).
        xd: the tip twist ẋ (6,).
        xrows: the rows of G as constraint wrenches, a column of their brace's X_i (c×6).
        rowbrace: the brace index of each row (c,).
        kinv: 1/K (n,).
        terms: the compiled terms (:data:`Terms`): one row per compliance-index term (β_x (6), weight), per
            region-barrier term (brace index, centre (3), r_max, weight) and per bounded joint of a joint-limit
            barrier (joint index, q_min, q_max, weight).
        par: [α, CERTIFIED_COND², UNLOADED_TOL, NULL_SPACE_RTOL].
    """
    je, jbs = kin[0], kin[1]
    n = je.shape[1]
    c = xrows.shape[0]
    m = sel.shape[0]
    alpha, cert2, unloaded_tol, null_rtol = par[0], par[1], par[2], par[3]
    out = np.zeros(n)
    g = np.zeros((c, n))  # G = [X_iᵀ J_b_i]
    for r in range(c):
        jb = jbs[rowbrace[r]]
        for i in range(n):
            s = 0.0
            for p in range(6):
                s += xrows[r, p] * jb[p, i]
            g[r, i] = s
    mg = np.zeros((c, c))  # G K⁻¹ Gᵀ
    for r in range(c):
        for t in range(r + 1):
            s = 0.0
            for i in range(n):
                s += g[r, i] * g[t, i] * kinv[i]
            mg[r, t] = s
            mg[t, r] = s
    trace = 0.0  # max_i tr(J_b_i K⁻¹ J_b_iᵀ) over the braces with rows
    for r in range(c):
        jb = jbs[rowbrace[r]]
        s = 0.0
        for p in range(6):
            for i in range(n):
                s += jb[p, i] * jb[p, i] * kinv[i]
        trace = max(trace, s)
    minv, ok = _spd_inverse(mg, 2.0 * unloaded_tol * max(math.sqrt(_frobenius2(mg)), trace))
    if not ok:
        return NOT_CERTIFIED, out
    basis, ok = _null_space(g, cert2, null_rtol)
    kk = basis.shape[1]
    if not ok or kk < m:
        return NOT_CERTIFIED, out
    bt = np.zeros((kk, m))  # Bᵀ = (S J_e N)ᵀ
    for r in range(m):
        sj = np.zeros(n)
        for p in range(6):
            f = sel[r, p]
            if f != 0.0:
                for i in range(n):
                    sj[i] += f * je[p, i]
        for j in range(kk):
            s = 0.0
            for i in range(n):
                s += sj[i] * basis[i, j]
            bt[j, r] = s
    qq, rinv, ok = _row_basis(bt)
    if not ok or not _frobenius2(bt) * _frobenius2(rinv) < cert2:
        return NOT_CERTIFIED, out
    status, dg = _objective_gradient(q, kin, g, minv, kinv, xrows, rowbrace, terms)
    if status != OK:
        return status, out
    grad = _tmatvec(basis, dg)  # Nᵀ ∂g/∂q
    z = _tmatvec(rinv, _matvec(sel, xd)) - alpha * _tmatvec(qq, grad)  # R⁻ᵀ S ẋ − α Qᵀ ∇g
    y = _matvec(qq, z) + alpha * grad  # B⁺S ẋ + α (I − B⁺B) ∇g
    return OK, _matvec(basis, y)  # q̇ = N y
