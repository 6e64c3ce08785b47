"""Pinocchio-side references shared by the static checks (docs/model.md, "The exact constrained compliance").

* :func:`lagrange_compliance` — the first-order equilibrium compliance of the spring-jointed chain with
  bilateral constraints, from the bordered (KKT) system, not from the closed formula;
* :func:`frame_jacobian_derivative` — ∂J/∂q of a frame's Jacobian from the Lie brackets of the joint twists,
  used by the nonlinear static solve (:mod:`bracekit.validate.statics`).

Plain Pinocchio models whose joints are all 1-DoF revolute (nq == nv == n, joint order = chain order). Jacobians
are Pinocchio's ``LOCAL_WORLD_ALIGNED`` ones (= the paper's J); wrench w = [f; m] (N, N·m), world axes.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from bracekit.errors import InputError, StaticSolveError

__all__ = ["frame_jacobian_derivative", "lagrange_compliance"]


# --------------------------------------------------------------------------------------------------
# First-order reference
# --------------------------------------------------------------------------------------------------
def lagrange_compliance(J: np.ndarray, K: np.ndarray, a: np.ndarray) -> np.ndarray:
    """First-order tip compliance of a spring-jointed chain under bilateral constraints aᵀΔq = 0.

    Solves the bordered KKT system ``[[K, −a], [−aᵀ, 0]] [Δq; λ] = [Jᵀ w; 0]`` for the six unit wrenches w
    (one ``np.linalg.solve`` with six right-hand sides), then C = J Δq. This equals
    C_true = J K⁻¹Jᵀ − J K⁻¹ a (aᵀK⁻¹a)⁻¹ aᵀ K⁻¹ Jᵀ but does not use that formula.

    Args:
        J: (6, n) tip Jacobian (LOCAL_WORLD_ALIGNED), maps q̇ to [v_e; ω].
        K: (n,) joint stiffnesses, N·m/rad, all > 0.
        a: (n, m) or (n,) constraint gradients (e.g. a = J_b,vᵀ n̂ for a frictionless point contact).

    Returns:
        (6, 6) compliance C (m/N, m/(N·m), rad/N, rad/(N·m) blocks), Δx = C w.

    Raises:
        InputError: bad shapes or non-positive stiffness.
        StaticSolveError: the constraints are (near) dependent or carry no load (aᵀK⁻¹a singular).
    """
    J = np.asarray(J, dtype=float)
    K = np.asarray(K, dtype=float).reshape(-1)
    a = np.asarray(a, dtype=float)
    if a.ndim == 1:
        a = a[:, None]
    n = K.size
    if J.shape != (6, n):
        raise InputError(f"J must have shape (6, {n}), got {J.shape}")
    if a.ndim != 2 or a.shape[0] != n:
        raise InputError(f"a must have shape ({n}, m), got {a.shape}")
    if not np.all(np.isfinite(K)) or np.any(K <= 0.0):
        raise InputError("joint stiffnesses must be finite and > 0")
    m = a.shape[1]
    # Guard: the weighted constraint matrix K^-1/2 a must have full column rank, else the multiplier
    # is undetermined (the contact carries no load); never return NaN silently.
    sv = np.linalg.svd(a / np.sqrt(K)[:, None], compute_uv=False)
    scale = float(np.linalg.norm(J / np.sqrt(K)[None, :], 2))
    if m > 0 and (sv.size == 0 or sv[-1] <= 1e-12 * max(scale, 1.0)):
        raise StaticSolveError(
            "constraint gradients a are (near) zero or dependent (aᵀK⁻¹a singular): the contact carries "
            "no load from the chain, so the constrained compliance is undefined"
        )
    bordered = np.zeros((n + m, n + m))
    bordered[:n, :n] = np.diag(K)
    bordered[:n, n:] = -a
    bordered[n:, :n] = -a.T
    rhs = np.zeros((n + m, 6))
    rhs[:n, :] = J.T
    sol = np.linalg.solve(bordered, rhs)  # column j: response to the unit wrench e_j
    return J @ sol[:n, :]


# --------------------------------------------------------------------------------------------------
# Kinematics helpers
# --------------------------------------------------------------------------------------------------
def _check_model(model: pin.Model) -> None:
    if model.nq != model.nv:
        raise InputError(f"model must have nq == nv (1-DoF revolute joints), got nq={model.nq}, nv={model.nv}")
    for jid in range(1, model.njoints):
        jm = model.joints[jid]
        if jm.nq != 1 or jm.nv != 1:
            raise InputError(f"joint {model.names[jid]!r} ({jm.shortname()}) is not a 1-DoF joint")
        jd = jm.createData()
        jm.calc(jd, np.zeros(1))
        S = np.asarray(jd.S).reshape(6)
        if np.linalg.norm(S[:3]) > 1e-12 or abs(np.linalg.norm(S[3:]) - 1.0) > 1e-9:
            raise InputError(f"joint {model.names[jid]!r} ({jm.shortname()}) is not a revolute joint")


def _kinematics(model: pin.Model, data: pin.Data, q: np.ndarray) -> None:
    """Forward kinematics, frame placements and world joint Jacobians (data.J) at q."""
    pin.computeJointJacobians(model, data, q)  # also runs forwardKinematics
    pin.updateFramePlacements(model, data)


def frame_jacobian_derivative(model: pin.Model, data: pin.Data, frame_id: int) -> np.ndarray:
    """Derivative of a frame's LOCAL_WORLD_ALIGNED Jacobian with respect to q (revolute serial chains).

    Requires ``pin.computeJointJacobians`` and ``pin.updateFramePlacements`` at the current q.
    Uses the Lie bracket of the world joint twists: ∂S_i/∂q_k = ad(S_k) S_i for k ≤ i, and the motion of
    the reference point ∂p/∂q_k = v_k + ω_k × p. No kinematic Hessian of Pinocchio is used (its 4.1.0
    memory layout is unusual, see docs/model.md).

    Returns:
        dJ (6, n, n) with dJ[:, i, k] = ∂J[:, i]/∂q_k (rows [v; ω], world axes, reference point = frame).
    """
    n = model.nv
    p = data.oMf[frame_id].translation
    jid = model.frames[frame_id].parentJoint
    dJ = np.zeros((6, n, n))
    Jw = np.asarray(data.J)  # WORLD convention: [v at world origin; ω]
    support = [j for j in model.supports[jid] if j > 0]
    cols = {j: model.joints[j].idx_v for j in support}
    dp = {j: Jw[:3, cols[j]] + np.cross(Jw[3:, cols[j]], p) for j in support}
    for i in support:
        ci = cols[i]
        v_i, w_i = Jw[:3, ci], Jw[3:, ci]
        sup_i = set(model.supports[i])
        for k in support:
            ck = cols[k]
            if k in sup_i and k != i:
                v_k, w_k = Jw[:3, ck], Jw[3:, ck]
                dw = np.cross(w_k, w_i)
                dv0 = np.cross(w_k, v_i) + np.cross(v_k, w_i)
            else:
                dw = np.zeros(3)
                dv0 = np.zeros(3)
            dJ[:3, ci, ck] = dv0 + np.cross(dw, p) + np.cross(w_i, dp[k])
            dJ[3:, ci, ck] = dw
    return dJ
