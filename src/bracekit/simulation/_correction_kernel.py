"""One point of the Gauss–Newton correction, compiled: its residual, stopping test, rows and minimum-norm step.

:func:`evaluate` takes the frames' kinematics that one Pinocchio pass gives (⁰M (4×4) and the
LOCAL_WORLD_ALIGNED J (6×n) of the tip, then of each brace) and does the rest of an iteration of
:class:`bracekit.simulation.correction.Correction`:

* the residual (m and rad, world axes): the task rows (the pose [p_d − e; log3(R_d R_eᵀ)], the position
  p_d − e, or the position and the tool axis [p_d − e; U ω], :mod:`bracekit.resolution.task_space`), then
  −X_iᵀ [b_i − b0_i; log3(R_b_i R_b0_iᵀ)] of each brace (eq:constraint's rows, docs/model.md);
* its scaled size max|r_j / s_j| and norm ‖r / s‖, and the stopping test of the correction;
* the rows (the residual's Jacobian, sign as the correction takes it): S J_e, then
  X_iᵀ [J_b_i,v; Jlog3(R) Rᵀ J_b_i,ω] of each brace (R = R_b_i R_b0_iᵀ), and their round-off floor;
* the minimum-norm step rowsᵀ (rows rowsᵀ)⁺ r with the semantics of LAPACK's gelsd and NumPy's default cutoff
  (σ ≤ eps · k · σ_max counts as zero), so dependent rows (two braces constraining the same motion) are harmless:
  by Cholesky where rows rowsᵀ is certified well conditioned (no σ is cut; the same step to rounding), by gelsd
  itself elsewhere (:func:`min_norm_step`).

log3 and Jlog3 are Pinocchio's (``pinocchio/src/spatial/log.hxx``: the rotation renormalised, its Taylor
expansions below eps^(1/3) and eps^(1/4), the branch near π from the largest diagonal), so the values are
``pin.log3`` / ``pin.Jlog3``'s to rounding. One code path for any number of braces: the per-brace arrays are
stacked, X_i padded with zero columns to the widest brace.

Compiled with numba where it is installed (:mod:`bracekit._compiled`), else the same functions run as Python
(:data:`COMPILED` is False) and a run's notes say so. log3, Jlog3, the perpendicular basis and the solve are
compiled once and called, the small helpers inlined (the first compilation, once per machine, about 7 s of CPU).
This module imports numba: the correction imports it when a correction is first built, so that ``import bracekit``
does not.
"""

from __future__ import annotations

import math

import numpy as np

from bracekit._cholesky import cholesky, lower_inverse
from bracekit._compiled import COMPILED, F64, I64
from bracekit._compiled import inline as _inline
from bracekit._compiled import jit as _jit

__all__ = [
    "COMPILED",
    "DONE",
    "FLOOR",
    "POSE",
    "POSITION",
    "POSITION_AXIS",
    "STEP",
    "WELL_CONDITIONED",
    "evaluate",
    "jlog3",
    "log3",
    "min_norm_step",
]

#: Task-space codes of :func:`evaluate` (``TaskSpace.kind``).
POSE, POSITION, POSITION_AXIS = 0, 1, 2
#: What :func:`evaluate` found: a step to take, or the point is accepted: below the tolerance or stalled (DONE,
#: before its rows), or below its round-off floor (FLOOR, after its rows).
STEP, DONE, FLOOR = 0, 1, 2

_EPS = float(np.finfo(np.float64).eps)
#: Pinocchio's Taylor thresholds: eps^(1/3) (log3, degree 2) and eps^(1/4) (Jlog3, degree 3).
_PREC2 = _EPS ** (1.0 / 3.0)
_PREC3 = _EPS ** (1.0 / 4.0)


@_inline
def _renormalised(r: F64) -> F64:
    """Pinocchio's renormalize_rotation_matrix: columns 0, 1 normalised, 2 = 0 × 1, then 0 = 1 × 2."""
    out = np.empty((3, 3))
    n0 = math.sqrt(r[0, 0] * r[0, 0] + r[1, 0] * r[1, 0] + r[2, 0] * r[2, 0])
    n1 = math.sqrt(r[0, 1] * r[0, 1] + r[1, 1] * r[1, 1] + r[2, 1] * r[2, 1])
    a0, a1, a2 = r[0, 0] / n0, r[1, 0] / n0, r[2, 0] / n0
    b0, b1, b2 = r[0, 1] / n1, r[1, 1] / n1, r[2, 1] / n1
    c0, c1, c2 = a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0
    out[0, 0], out[1, 0], out[2, 0] = b1 * c2 - b2 * c1, b2 * c0 - b0 * c2, b0 * c1 - b1 * c0
    out[0, 1], out[1, 1], out[2, 1] = b0, b1, b2
    out[0, 2], out[1, 2], out[2, 2] = c0, c1, c2
    return out


@_jit
def log3(r: F64) -> tuple[float, float, float, float]:
    """(θ, ω) = Pinocchio's log3 of a rotation r (3×3): ω (3,) rad with exp(ω̂) = r, θ = |ω| ∈ [0, π]."""
    rn = _renormalised(r)
    tr = rn[0, 0] + rn[1, 1] + rn[2, 2]
    cos_value = (tr - 1.0) / 2.0
    if cos_value >= -1.0 + _PREC2:
        expansion = math.sqrt(2.0 * (1.0 - cos_value) + _EPS * _EPS)
        if tr <= 3.0 - _PREC2:
            theta = math.acos(cos_value) if tr >= -1.0 + _PREC2 else math.pi - expansion
        else:
            theta = expansion
        v0 = 0.5 * (rn[2, 1] - rn[1, 2])
        v1 = 0.5 * (rn[0, 2] - rn[2, 0])
        v2 = 0.5 * (rn[1, 0] - rn[0, 1])
        if theta >= _PREC2:
            t = theta / math.sin(theta)
        else:
            sq = v0 * v0 + v1 * v1 + v2 * v2
            t = 1.0 + sq / 6.0 + sq * sq * 3.0 / 40.0
        return theta, t * v0, t * v1, t * v2
    # near π: the axis from the largest of 2 r_ii − tr + 1 (Pinocchio's compute_theta_axis)
    d0, d1, d2 = 2.0 * rn[0, 0] - tr + 1.0, 2.0 * rn[1, 1] - tr + 1.0, 2.0 * rn[2, 2] - tr + 1.0
    if d0 >= d1:
        i0, val = (0, d0) if d0 >= d2 else (2, d2)
    else:
        i0, val = (1, d1) if d1 >= d2 else (2, d2)
    i1, i2 = (i0 + 1) % 3, (i0 + 2) % 3
    s = math.sqrt(val + _EPS + _EPS * _EPS) * (1.0 if rn[i2, i1] >= rn[i1, i2] else -1.0)
    axis = np.empty(3)
    axis[i0] = s / 2.0
    axis[i1] = 1.0 / (2.0 * s) * (rn[i1, i0] + rn[i0, i1])
    axis[i2] = 1.0 / (2.0 * s) * (rn[i2, i0] + rn[i0, i2])
    w = 1.0 / (2.0 * s) * (rn[i2, i1] - rn[i1, i2])
    length = math.sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2])
    theta = 2.0 * math.atan2(length, w)
    return theta, theta * (axis[0] / length), theta * (axis[1] / length), theta * (axis[2] / length)


@_jit
def jlog3(theta: float, w0: float, w1: float, w2: float) -> F64:
    """Pinocchio's Jlog3 (3×3) at the log3 (θ, ω) of a rotation: d log3 against a right perturbation."""
    if theta < _PREC3:
        alpha = 1.0 / 12.0 + theta * theta / 720.0
        diag = 0.5 * (2.0 - theta * theta / 6.0)
    else:
        st_1mct = math.sin(theta) / (1.0 - math.cos(theta))
        alpha = 1.0 / (theta * theta) - st_1mct / (2.0 * theta)
        diag = 0.5 * (theta * st_1mct)
    w = (w0, w1, w2)
    out = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            out[i, j] = alpha * w[i] * w[j]
        out[i, i] += diag
    out[0, 1] -= 0.5 * w2
    out[0, 2] += 0.5 * w1
    out[1, 0] += 0.5 * w2
    out[1, 2] -= 0.5 * w0
    out[2, 0] -= 0.5 * w1
    out[2, 1] += 0.5 * w0
    return out


@_inline
def _relative(r: F64, r0: F64) -> F64:
    """The product r r0ᵀ (3×3) of two rotations (3×3 blocks)."""
    out = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            out[i, j] = r[i, 0] * r0[j, 0] + r[i, 1] * r0[j, 1] + r[i, 2] * r0[j, 2]
    return out


@_inline
def _cross(a: F64, b: F64) -> F64:
    """The cross product a × b (3,)."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


@_inline
def _turned(r: F64, v: F64) -> F64:
    """The turned vector r v (3,) of a rotation block r (3×3)."""
    out = np.empty(3)
    for i in range(3):
        out[i] = r[i, 0] * v[0] + r[i, 1] * v[1] + r[i, 2] * v[2]
    return out


@_jit
def _perpendicular(a: F64) -> F64:
    """:func:`bracekit.resolution.task_space.perpendicular_basis`: rows u₁, u₂ (2×3) ⟂ the unit vector a."""
    helper = np.zeros(3)
    least = 0
    for i in range(1, 3):
        if abs(a[i]) < abs(a[least]):
            least = i
    helper[least] = 1.0
    u1 = _cross(a, helper)
    u1 = u1 / math.sqrt(u1[0] * u1[0] + u1[1] * u1[1] + u1[2] * u1[2])
    out = np.empty((2, 3))
    out[0] = u1
    out[1] = _cross(a, u1)
    return out


@_inline
def _task_residual(tip: F64, position: F64, target: F64, kind: int, axis: F64, res: F64) -> int:
    """The task rows of the residual into res[:rows]; their count (6, 3 or 5)."""
    for i in range(3):
        res[i] = position[i] - tip[i, 3]
    if kind == POSITION:
        return 3
    if kind == POSE:
        _, res[3], res[4], res[5] = log3(_relative(target, tip))
        return 6
    a, a_d = _turned(tip, axis), _turned(target, axis)  # the tool axis and its desired direction
    k = _cross(a, a_d)
    s = math.sqrt(k[0] * k[0] + k[1] * k[1] + k[2] * k[2])
    omega = k * (math.atan2(s, a[0] * a_d[0] + a[1] * a_d[1] + a[2] * a_d[2]) / s) if s > 0.0 else np.zeros(3)
    u = _perpendicular(a)
    for r in range(2):
        res[3 + r] = u[r, 0] * omega[0] + u[r, 1] * omega[1] + u[r, 2] * omega[2]
    return 5


@_inline
def _task_rows(tip: F64, j_e: F64, kind: int, axis: F64, rows: F64) -> None:
    """The task rows S J_e into rows[:6], rows[:3] or rows[:5]."""
    n = j_e.shape[1]
    top = 6 if kind == POSE else 3
    for i in range(top):
        for c in range(n):
            rows[i, c] = j_e[i, c]
    if kind == POSITION_AXIS:
        u = _perpendicular(_turned(tip, axis))
        for r in range(2):
            for c in range(n):
                rows[3 + r, c] = u[r, 0] * j_e[3, c] + u[r, 1] * j_e[4, c] + u[r, 2] * j_e[5, c]


@_inline
def _moment(x: F64, width: int) -> bool:
    """Whether X_i (6×width) has constraint moments (rows 3–5 not all zero)."""
    for i in range(3, 6):
        for c in range(width):
            if x[i, c] != 0.0:
                return True
    return False


@_inline
def _contact_residual(m: F64, anchor: F64, x: F64, width: int, res: F64, start: int) -> None:
    """−X_iᵀ [b_i − b0_i; log3(R_b_i R_b0_iᵀ)] of one brace into res[start : start + width]."""
    d = np.empty(6)
    for i in range(3):
        d[i] = m[i, 3] - anchor[i, 3]
    d[3] = d[4] = d[5] = 0.0
    if _moment(x, width):
        _, d[3], d[4], d[5] = log3(_relative(m, anchor))
    for c in range(width):
        total = 0.0
        for i in range(6):
            total += x[i, c] * d[i]
        res[start + c] = -total


@_inline
def _contact_rows(m: F64, j_b: F64, anchor: F64, x: F64, width: int, rows: F64, start: int) -> None:
    """X_iᵀ [J_b_i,v; Jlog3(R) Rᵀ J_b_i,ω] of one brace into rows[start : start + width].

    Without constraint moments: X_iᵀ J_b_i.
    """
    n = j_b.shape[1]
    turn = np.zeros((3, n))  # Jlog3(R) Rᵀ J_b_i,ω: the log's rate
    if _moment(x, width):
        r = _relative(m, anchor)
        theta, w0, w1, w2 = log3(r)
        g = jlog3(theta, w0, w1, w2)
        gr = np.empty((3, 3))  # Jlog3(R) Rᵀ
        for i in range(3):
            for j in range(3):
                gr[i, j] = g[i, 0] * r[j, 0] + g[i, 1] * r[j, 1] + g[i, 2] * r[j, 2]
        for i in range(3):
            for c in range(n):
                turn[i, c] = gr[i, 0] * j_b[3, c] + gr[i, 1] * j_b[4, c] + gr[i, 2] * j_b[5, c]
    for k in range(width):
        for c in range(n):
            total = 0.0
            for i in range(3):
                total += x[i, k] * j_b[i, c]
            for i in range(3):
                total += x[3 + i, k] * turn[i, c]
            rows[start + k, c] = total


@_jit
def evaluate(
    mats: F64,
    jacs: F64,
    q: F64,
    position: F64,
    target: F64,
    anchors: F64,
    xs: F64,
    widths: I64,
    scale: F64,
    kind: int,
    axis: F64,
    accept: float,
    roundoff: float,
    tol: float,
    previous: float,
    res: F64,
    rows: F64,
    step: F64,
) -> tuple[int, float, float]:
    """One point of the correction: (status, size, norm); its residual, rows and step into `res`, `rows`, `step`.

    Outputs: `res` (m,), `rows` (m×n), `step` (n,), written as far as the status needs them.
    Inputs: `mats` (k, 4, 4) ⁰M and `jacs` (k, 6, n) J of the tip then each brace; q (n,) rad; the tip's target
    `position` (3,) m and `target` ⁰R_d (3×3); each brace's anchor [⁰R_b0_i b0_i] (B, 4, 4) (B = 0: contacts
    free), X_i padded to (B, 6, w) and its width (B,); `scale` (m,) of the rows (m for positions, 1 rad);
    the task space `kind` (:data:`POSE`, :data:`POSITION`, :data:`POSITION_AXIS`) and tool `axis` (3,, tip
    coordinates); ACCEPT_TOL, the round-off factor CORRECTION_ROUNDOFF · eps · √n, the tolerance `tol` and
    the previous point's size (inf at the start).

    size = max|r_j / s_j|, norm = ‖r / s‖. :data:`DONE` where size < tol or size < `accept` and above half the
    previous size (stalled): only the residual is written; :data:`FLOOR` where size is below the round-off floor
    `roundoff` · max(1, ‖q‖∞) · ‖rows / s‖_F: the residual and rows; else :data:`STEP` with the step
    rowsᵀ (rows rowsᵀ)⁺ r as well.
    """
    n = q.shape[0]
    m = scale.shape[0]
    start = _task_residual(mats[0], position, target, kind, axis, res)
    task = start
    for i in range(anchors.shape[0]):
        _contact_residual(mats[1 + i], anchors[i], xs[i], widths[i], res, start)
        start += widths[i]
    size = 0.0
    total = 0.0
    for j in range(m):
        v = abs(res[j]) / scale[j]
        size = max(size, v)
        total += (res[j] / scale[j]) ** 2
    norm = math.sqrt(total)
    if size < tol or (size < accept and size > 0.5 * previous):
        return DONE, size, norm
    _task_rows(mats[0], jacs[0], kind, axis, rows)
    start = task
    for i in range(anchors.shape[0]):
        _contact_rows(mats[1 + i], jacs[1 + i], anchors[i], xs[i], widths[i], rows, start)
        start += widths[i]
    frobenius = 0.0
    big = 1.0
    for c in range(n):
        big = max(big, abs(q[c]))
    for j in range(m):
        for c in range(n):
            frobenius += (rows[j, c] / scale[j]) ** 2
    if size < roundoff * big * math.sqrt(frobenius):
        return FLOOR, size, norm
    min_norm_step(rows, res, step)
    return STEP, size, norm


@_jit
def min_norm_step(rows: F64, res: F64, step: F64) -> None:
    """The minimum-norm step rowsᵀ (rows rowsᵀ)⁺ res (n,) of rows (m×n) and res (m,), into `step`.

    ``rows.T @ np.linalg.lstsq(rows @ rows.T, res, rcond=None)[0]``: LAPACK's gelsd, eigenvalues of
    G = rows rowsᵀ below eps · m · λ_max dropped (dependent rows give the least-squares compromise, not a blow-up).
    Where G is certified well conditioned, none is dropped and the step is G⁻¹ res by Cholesky (the same step to
    rounding, without gelsd's cost): G = L Lᵀ with λ_min ≥ 1 / ‖L⁻¹‖_F² and λ_max ≤ tr G, and
    λ_min / λ_max ≥ :data:`WELL_CONDITIONED`. Elsewhere gelsd itself.
    """
    m, n = rows.shape
    gram = np.empty((m, m))
    for i in range(m):
        for j in range(i + 1):
            acc = 0.0
            for c in range(n):
                acc += rows[i, c] * rows[j, c]
            gram[i, j] = gram[j, i] = acc
    y = _cholesky_solve(gram, res)
    if y.shape[0] != m:  # not certified: gelsd
        y = np.linalg.lstsq(gram, res, _EPS * m)[0].astype(np.float64)
    for c in range(n):
        step[c] = 0.0
    for j in range(m):
        for c in range(n):
            step[c] += rows[j, c] * y[j]


#: The least certified λ_min / λ_max of rows rowsᵀ solved by Cholesky (far above gelsd's cutoff eps · m).
WELL_CONDITIONED = 1e-8


@_jit
def _cholesky_solve(gram: F64, res: F64) -> F64:
    """G⁻¹ res of a symmetric G (m×m) certified to λ_min / λ_max ≥ WELL_CONDITIONED, else an empty array."""
    m = gram.shape[0]
    low, ok = cholesky(gram, 0.0)
    if not ok:
        return np.empty(0)
    inverse = lower_inverse(low)
    trace = 0.0
    frobenius = 0.0
    for j in range(m):
        trace += gram[j, j]
        for i in range(j, m):
            frobenius += inverse[i, j] * inverse[i, j]
    if not 1.0 >= WELL_CONDITIONED * trace * frobenius:
        return np.empty(0)
    z = np.empty(m)  # L z = res, then Lᵀ y = z
    for i in range(m):
        acc = res[i]
        for k in range(i):
            acc -= low[i, k] * z[k]
        z[i] = acc / low[i, i]
    y = np.empty(m)
    for i in range(m - 1, -1, -1):
        acc = z[i]
        for k in range(i + 1, m):
            acc -= low[k, i] * y[k]
        y[i] = acc / low[i, i]
    return y
