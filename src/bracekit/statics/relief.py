"""Actuator relief: how much constant brace preloads lower the peak actuator load along configurations.

Conventions as in :mod:`bracekit.statics.equilibrium`. In free space the actuators hold τ = g(q) − J_eᵀ w.
Braced, the surface of brace i pushes on b_i with the constant normal force P_i n̂_i (P_i ≥ 0 N, no tangential
force, no moment), so τ = g(q) − J_eᵀ w − Σ_i P_i J_b_i,vᵀ n̂_i. The peak load is max |τ_j| / effort_j over the
configurations, the listed tool wrenches and the limited joints (effort 0 or inf in the URDF: unlimited, left
out). The preloads that minimise the braced peak solve the linear program (N ≥ 1 braces)

    min t  s.t.  −t ≤ τ_j(P) / effort_j ≤ t  (every configuration, wrench and limited joint),  P_i ≥ 0,

with SciPy's HiGHS; a second LP picks the least total preload Σ_i P_i that attains the optimal peak (the least
pressing braces).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import linprog

from bracekit._linalg import as_number, finite_math, show
from bracekit.errors import InputError, NumericalError
from bracekit.kinematics import BracedRobot
from bracekit.statics.capacity import effort_limits, peak_ratio
from bracekit.statics.equilibrium import _check_size, configurations, wrench_list

Array = NDArray[np.float64]

#: The second LP picks the smallest P whose peak is within this fraction of the optimum (a flat optimum would
#: otherwise return a large preload for a negligible gain).
PEAK_RTOL = 1e-3


@dataclass(frozen=True, eq=False)
class Relief:
    """Peak actuator loads (max |τ_i| / effort_i, dimensionless) in free space and braced.

    Attributes:
        free_peak: peak in free space over every configuration and wrench.
        braced_peak_unloaded: braced peak at P = 0 (the contacts then carry nothing: equals free_peak).
        preloads: the optimal constant preload P_i of each brace (B,), N: the least total that attains the
            optimal peak.
        braced_peak: braced peak at those preloads.
        ratio: braced_peak / free_peak (1 when free_peak is 0: nothing to relieve).
        free_peaks: peak per configuration in free space (N,).
        braced_peaks: peak per configuration braced at the optimal preload (N,).
    """

    free_peak: float
    braced_peak_unloaded: float
    preloads: Array
    braced_peak: float
    ratio: float
    free_peaks: Array
    braced_peaks: Array


def actuator_torques(
    braced: BracedRobot, qs: ArrayLike, wrenches: ArrayLike | None = None, *, gravity: bool = False
) -> tuple[Array, Array]:
    """Free-space torques τ_free = g(q) − J_eᵀ w (N×m×n, N·m) and a_i = J_b_i,vᵀ n̂_i of each brace (N×B×n).

    Braced, τ = τ_free − Σ_i P_i a_i.

    `wrenches` (m×6, [f; m] at e, world axes) None means the unloaded robot (one zero wrench).
    """
    if not isinstance(braced, BracedRobot):
        raise InputError(f"expected a BracedRobot, got {type(braced).__name__}")
    if not isinstance(gravity, bool):
        raise InputError(f"gravity must be True or False, got {show(gravity)}")
    robot = braced.robot
    q_all = configurations(robot, qs)
    ws = np.zeros((1, 6)) if wrenches is None else wrench_list(wrenches)
    normals = [brace.surface.normal for brace in braced.braces]
    count, n = q_all.shape
    tau = np.empty((count, ws.shape[0], n))
    a = np.empty((count, len(normals), n))
    if gravity:
        _check_size(robot, "gravity torques")
    data = robot.model.createData() if gravity else None
    with finite_math("the actuator torques"):
        for i, q in enumerate(q_all):
            st = braced.state(q)
            g = np.zeros(n) if data is None else pin.computeGeneralizedGravity(robot.model, data, q)
            tau[i] = g - ws @ st.J_e
            for b, (j_b, nhat) in enumerate(zip(st.J_b_i, normals, strict=True)):
                a[i, b] = j_b[:3].T @ nhat
    return tau, a


def actuator_relief(
    braced: BracedRobot,
    qs: ArrayLike,
    wrenches: ArrayLike | None = None,
    *,
    gravity: bool = False,
    effort: ArrayLike | None = None,
    max_preload: float | None = None,
) -> Relief:
    """Peak actuator load along `qs` (N×n) in free space and braced with the best constant preloads.

    Args:
        braced: the braced robot, N ≥ 1 braces (each surface normal n̂_i gives its preload's direction).
        qs: configurations (N×n, rad), {b} on the surface at each.
        wrenches: tool wrenches (m×6, N and N·m, at e, world axes); None: no tool load.
        gravity: include gravity torques g(q).
        effort: actuator limits (n,) instead of the URDF's (capacity.effort_limits).
        max_preload: an upper bound on every P_i (N); None: unbounded.

    Raises:
        InputError: bad inputs, or no joint has an effort limit.
        NumericalError: the LP solver fails.
    """
    if not isinstance(braced, BracedRobot):
        raise InputError(f"expected a BracedRobot, got {type(braced).__name__}")
    e = effort_limits(braced.robot, effort)
    cap = None if max_preload is None else as_number(max_preload, "max_preload", nonnegative=True, unit="N")
    tau, a = actuator_torques(braced, qs, wrenches, gravity=gravity)
    return relief_of(tau, a, e, cap)


def relief_of(tau: Array, a: Array, effort: Array, max_preload: float | None = None) -> Relief:
    """The relief LP of torques already computed (:func:`actuator_torques`: τ_free N×m×n, a N×B×n)."""
    limited = np.isfinite(effort)
    if not np.any(limited):
        raise InputError("no joint has an effort limit (URDF effort 0 or inf): give effort=[...] (N·m per joint)")
    t = tau[..., limited] / effort[limited]  # (N, m, k): load per unit limit
    s = np.broadcast_to((a[..., limited] / effort[limited])[:, None, :, :], (*t.shape[:2], a.shape[1], t.shape[2]))
    rows = np.moveaxis(s, 2, -1).reshape(-1, a.shape[1])  # (N·m·k, B): the load per unit P_i
    preloads, optimum = _solve_lp(t.reshape(-1), rows, max_preload)
    relieved = t - np.einsum("nmbk,b->nmk", s, preloads)
    free_peaks = np.max(np.abs(t), axis=(1, 2))
    braced_peaks = np.max(np.abs(relieved), axis=(1, 2))
    free_peak, braced_peak = float(np.max(free_peaks)), float(np.max(braced_peaks))
    if braced_peak > optimum * (1.0 + PEAK_RTOL) * (1.0 + 1e-6) + 1e-12:
        raise NumericalError(
            f"the LP's optimal peak {optimum:.6g} disagrees with the peak {braced_peak:.6g} at its preloads"
        )
    return Relief(
        free_peak=free_peak,
        braced_peak_unloaded=float(peak_ratio(tau, effort).max()),
        preloads=preloads,
        braced_peak=braced_peak,
        ratio=braced_peak / free_peak if free_peak > 0.0 else 1.0,
        free_peaks=free_peaks,
        braced_peaks=braced_peaks,
    )


def _solve_lp(t: Array, s: Array, cap: float | None) -> tuple[Array, float]:
    """(least total optimal P (B,), optimal peak) of min max_r |t_r − s_r · P| over P in [0, cap]^B (HiGHS)."""
    ones = np.ones_like(t)
    count = s.shape[1]
    # variables (P_1 … P_B, peak): t − s P ≤ peak and −(t − s P) ≤ peak
    a_ub = np.vstack([np.column_stack([-s, -ones]), np.column_stack([s, -ones])])
    b_ub = np.concatenate([-t, t])
    bounds = [(0.0, cap)] * count + [(0.0, None)]
    first = linprog(np.r_[np.zeros(count), 1.0], A_ub=a_ub, b_ub=b_ub, bounds=bounds, method="highs")
    _check(first, "the relief LP (min peak)")
    optimum = float(first.x[-1])
    # the least total preload whose peak is within PEAK_RTOL of the optimum
    bounds2 = [(0.0, cap)] * count + [(0.0, optimum * (1.0 + PEAK_RTOL) + 1e-15)]
    second = linprog(np.r_[np.ones(count), 0.0], A_ub=a_ub, b_ub=b_ub, bounds=bounds2, method="highs")
    _check(second, "the relief LP (smallest preload)")
    return np.maximum(np.asarray(second.x[:count], dtype=float), 0.0), optimum


def _check(result: object, what: str) -> None:
    status = getattr(result, "status", -1)
    x = getattr(result, "x", None)
    if status != 0 or x is None or not np.all(np.isfinite(x)):
        raise NumericalError(f"{what} failed (HiGHS status {status}: {getattr(result, 'message', '')})")
