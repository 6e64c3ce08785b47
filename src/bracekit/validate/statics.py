"""Static references for the braced compliance models (docs/model.md, "The exact constrained compliance").

Two independent references, both on a plain Pinocchio model whose joints are all 1-DoF revolute
(nq == nv == n, joint order = chain order base→tip):

* :func:`lagrange_compliance` — the first-order equilibrium compliance of the spring-jointed chain with a
  bilateral constraint, from the bordered (KKT) system, not from the closed formula.
* :func:`solve_static_equilibrium` — the nonlinear static equilibrium of the chain under a dead tip wrench
  with a frictionless point contact of the brace point {b} on a plane (Newton on the KKT system with the
  analytic derivative of the Jacobians).

Conventions (SI): wrench w = [f; m] at the tip point e in world axes (N, N·m); deflection
Δx = [Δp; Δθ] with Δp the change of the tip position (m, world) and Δθ = log3(R_e(q) R_e(q0)ᵀ)
(rad, world axes). Jacobians are Pinocchio's ``LOCAL_WORLD_ALIGNED`` ones (= the paper's J).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from bracekit.errors import InputError, StaticSolveError

__all__ = [
    "StaticResult",
    "StaticSolveError",
    "frame_jacobian_derivative",
    "lagrange_compliance",
    "preload_rest_configuration",
    "solve_static_equilibrium",
]

_LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED




@dataclass(frozen=True, eq=False)
class StaticResult:
    """Result of :func:`solve_static_equilibrium`.

    Attributes:
        q: equilibrium configuration (n,), rad.
        deflection: Δx = [Δp; Δθ] (6,) of the tip relative to q0 (m, rad; world axes).
        contact_force: normal force the surface pushes on b (N, ≥ 0 when pressing; 0 if the contact opened).
        converged: True when the scaled residual reached ``tol``.
        iterations: Newton iterations used (summed over the bilateral and the opened solve).
        residual: final scaled residual: max of |torque residual|/k_i (rad) and |gap| (m).
        contact_opened: True when ``bilateral=False`` and the contact would have pulled, so it opened.
    """

    q: np.ndarray
    deflection: np.ndarray
    contact_force: float
    converged: bool
    iterations: int
    residual: float
    contact_opened: bool = False


# --------------------------------------------------------------------------------------------------
# First-order reference
# --------------------------------------------------------------------------------------------------
def lagrange_compliance(J: np.ndarray, K: np.ndarray, a: np.ndarray) -> np.ndarray:
    """First-order tip compliance of a spring-jointed chain under bilateral constraints aᵀΔq = 0.

    Solves the bordered KKT system [[K, −a], [−aᵀ, 0]] [Δq; λ] = [Jᵀ w; 0] for the six unit wrenches w
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


def _tip_deflection(
    model: pin.Model, data: pin.Data, q: np.ndarray, q_ref: np.ndarray, tip_frame_id: int
) -> np.ndarray:
    """Δx = [p_e(q) − p_e(q_ref); log3(R_e(q) R_e(q_ref)ᵀ)] (6,), m and rad, world axes."""
    pin.framesForwardKinematics(model, data, q_ref)
    M0 = data.oMf[tip_frame_id].copy()
    pin.framesForwardKinematics(model, data, q)
    M1 = data.oMf[tip_frame_id]
    dp = M1.translation - M0.translation
    dth = pin.log3(M1.rotation @ M0.rotation.T)
    return np.concatenate([dp, dth])


def _unit(v: np.ndarray, name: str) -> np.ndarray:
    v = np.asarray(v, dtype=float).reshape(3)
    nrm = np.linalg.norm(v)
    if not np.isfinite(nrm) or nrm < 1e-12:
        raise InputError(f"{name} must be a finite non-zero 3-vector")
    if abs(nrm - 1.0) > 1e-6:
        raise InputError(f"{name} must be a unit vector (norm {nrm:.6g})")
    return v / nrm


def preload_rest_configuration(
    model: pin.Model,
    q0: np.ndarray,
    stiffness: np.ndarray,
    brace_frame_id: int,
    surface_normal: np.ndarray,
    preload: float,
) -> np.ndarray:
    """Spring rest configuration that makes q0 the equilibrium under a contact force ``preload`` (N) along n̂.

    rest = q0 − K⁻¹ J_b,v(q0)ᵀ n̂ P (rad, shape (n,)).
    """
    data = model.createData()
    pin.computeJointJacobians(model, data, q0)
    pin.updateFramePlacements(model, data)
    Jb = pin.getFrameJacobian(model, data, brace_frame_id, _LWA)[:3, :]
    return np.asarray(q0, dtype=float) - (Jb.T @ surface_normal) * preload / stiffness


# --------------------------------------------------------------------------------------------------
# Nonlinear static equilibrium
# --------------------------------------------------------------------------------------------------
def _newton(
    model: pin.Model,
    data: pin.Data,
    x0: np.ndarray,
    rest: np.ndarray,
    K: np.ndarray,
    brace_frame_id: int,
    tip_frame_id: int,
    s: np.ndarray,
    nhat: np.ndarray,
    w: np.ndarray,
    contact: bool,
    tol: float,
    max_iter: int,
) -> tuple[np.ndarray, int, float]:
    """Damped Newton on the (scaled) KKT residual. Returns (x, iterations, residual)."""
    n = model.nv

    def residual_and_tangent(x: np.ndarray, need_tangent: bool) -> tuple[np.ndarray, np.ndarray | None]:
        q = x[:n]
        _kinematics(model, data, q)
        Je = pin.getFrameJacobian(model, data, tip_frame_id, _LWA)
        F = np.empty(x.size)
        F[:n] = K * (q - rest) - Je.T @ w
        T = None
        if need_tangent:
            dJe = frame_jacobian_derivative(model, data, tip_frame_id)
            T = np.zeros((x.size, x.size))
            T[:n, :n] = np.diag(K) - np.einsum("r,rik->ik", w, dJe)
        if contact:
            lam = x[n]
            Jb = pin.getFrameJacobian(model, data, brace_frame_id, _LWA)[:3, :]
            a = Jb.T @ nhat
            F[:n] -= a * lam
            F[n] = -(nhat @ (data.oMf[brace_frame_id].translation - s))
            if need_tangent:
                assert T is not None
                dJb = frame_jacobian_derivative(model, data, brace_frame_id)[:3]
                T[:n, :n] -= lam * np.einsum("r,rik->ik", nhat, dJb)
                T[:n, n] = -a
                T[n, :n] = -a
        # scale: torque rows by 1/k (→ rad), gap row stays in metres
        F[:n] /= K
        if T is not None:
            T[:n, :] /= K[:, None]
        return F, T

    x = x0.copy()
    F, T = residual_and_tangent(x, True)
    res = float(np.max(np.abs(F)))
    it = 0
    while res > tol and it < max_iter:
        it += 1
        assert T is not None
        try:
            dx = np.linalg.solve(T, -F)
        except np.linalg.LinAlgError as exc:
            raise StaticSolveError(
                f"singular equilibrium tangent at Newton iteration {it} (contact direction not controllable?)"
            ) from exc
        if not np.all(np.isfinite(dx)):
            raise StaticSolveError(f"non-finite Newton step at iteration {it}")
        step = 1.0
        while True:  # backtracking on the scaled residual
            x_try = x + step * dx
            F_try, _ = residual_and_tangent(x_try, False)
            res_try = float(np.max(np.abs(F_try)))
            if res_try < res or step < 1e-4:
                break
            step *= 0.5
        x = x_try
        F, T = residual_and_tangent(x, True)
        res = float(np.max(np.abs(F)))
        if not np.isfinite(res):
            raise StaticSolveError(f"static equilibrium diverged (non-finite residual at iteration {it})")
    return x, it, res


def solve_static_equilibrium(
    model: pin.Model,
    q0: np.ndarray,
    stiffness: np.ndarray,
    brace_frame_id: int,
    tip_frame_id: int,
    surface_point: np.ndarray,
    surface_normal: np.ndarray,
    wrench: np.ndarray,
    *,
    bilateral: bool = True,
    preload: float = 0.0,
    tol: float = 1e-12,
    max_iter: int = 50,
) -> StaticResult:
    """Nonlinear static equilibrium of the spring-jointed chain, brace point b on a frictionless plane.

    Solves for (q, λ): K (q − rest) = J_e(q)ᵀ w + J_b,v(q)ᵀ n̂ λ and n̂ᵀ(p_b(q) − surface_point) = 0, with
    rest = q0 − K⁻¹ J_b,v(q0)ᵀ n̂ P (the springs are set so that q0 is the equilibrium under the preload P
    and no wrench). The wrench is a dead load: a constant world wrench at the moving tip point.

    Args:
        model: Pinocchio model of a serial chain of 1-DoF revolute joints (nq == nv == n).
        q0: (n,) rad, preloaded equilibrium; b must lie on the plane at q0.
        stiffness: (n,) joint stiffnesses, N·m/rad, > 0.
        brace_frame_id: Pinocchio frame id of {b}.
        tip_frame_id: Pinocchio frame id of {e}.
        surface_point: (3,) m, a point of the plane (world).
        surface_normal: (3,) unit normal, pointing out of the surface toward the robot.
        wrench: (6,) [f; m] at e, world axes (N, N·m).
        bilateral: keep the contact even if it pulls (λ < 0). With False, a pulling contact opens and
            the free-chain equilibrium is returned with ``contact_opened=True``.
        preload: contact force P ≥ 0 (N) at q0 before the wrench is applied.
        tol: convergence tolerance on the scaled residual (rad for torques/k_i, m for the gap).
        max_iter: Newton iteration limit (per solve).

    Returns:
        :class:`StaticResult` (deflection relative to q0).

    Raises:
        InputError: bad inputs (shapes, non-revolute joints, b not on the plane at q0, negative preload).
        StaticSolveError: no convergence within ``max_iter``, a singular KKT system (the contact carries
            no load from the chain), or an opened contact whose free solution would penetrate the plane.
    """
    _check_model(model)
    n = model.nv
    q0 = np.asarray(q0, dtype=float).reshape(-1)
    K = np.asarray(stiffness, dtype=float).reshape(-1)
    w = np.asarray(wrench, dtype=float).reshape(-1)
    s = np.asarray(surface_point, dtype=float).reshape(3)
    nhat = _unit(surface_normal, "surface_normal")
    if q0.size != n or K.size != n:
        raise InputError(f"q0 and stiffness must have shape ({n},), got {q0.shape} and {K.shape}")
    if w.size != 6:
        raise InputError(f"wrench must have shape (6,), got {w.shape}")
    if not np.all(np.isfinite(K)) or np.any(K <= 0.0):
        raise InputError("joint stiffnesses must be finite and > 0")
    if not (np.isfinite(preload) and preload >= 0.0):
        raise InputError(f"preload must be a finite force >= 0 N, got {preload}")
    for fid in (brace_frame_id, tip_frame_id):
        if not 0 <= fid < model.nframes:
            raise InputError(f"frame id {fid} out of range (model has {model.nframes} frames)")

    data = model.createData()
    _kinematics(model, data, q0)
    gap0 = float(nhat @ (data.oMf[brace_frame_id].translation - s))
    if abs(gap0) > 1e-8:
        raise InputError(f"brace point is not on the surface at q0 (gap {gap0:.3e} m)")
    Jb0 = pin.getFrameJacobian(model, data, brace_frame_id, _LWA)[:3, :]
    a0 = Jb0.T @ nhat
    Je0 = pin.getFrameJacobian(model, data, tip_frame_id, _LWA)
    if float(np.linalg.norm(a0 / np.sqrt(K))) <= 1e-12 * max(float(np.linalg.norm(Je0 / np.sqrt(K))), 1.0):
        raise StaticSolveError(
            "the joints cannot move the brace point along the surface normal (J_b,vᵀ n̂ = 0): "
            "the contact carries no load and the constrained equilibrium is undefined"
        )
    rest = q0 - a0 * preload / K

    x0 = np.concatenate([q0, [preload]])
    x, it, res = _newton(model, data, x0, rest, K, brace_frame_id, tip_frame_id, s, nhat, w, True, tol, max_iter)
    if res > tol:
        raise StaticSolveError(
            f"static equilibrium did not converge in {max_iter} Newton iterations "
            f"(scaled residual {res:.3e} > tol {tol:.1e}); the load may be too large"
        )
    q, lam = x[:n], float(x[n])
    opened = False
    if not bilateral and lam < 0.0:
        xf, it2, res = _newton(
            model, data, q.copy(), rest, K, brace_frame_id, tip_frame_id, s, nhat, w, False, tol, max_iter
        )
        it += it2
        if res > tol:
            raise StaticSolveError(
                f"free (opened-contact) equilibrium did not converge in {max_iter} Newton iterations "
                f"(scaled residual {res:.3e} > tol {tol:.1e})"
            )
        q = xf
        _kinematics(model, data, q)
        gap = float(nhat @ (data.oMf[brace_frame_id].translation - s))
        if gap < -tol:
            raise StaticSolveError(
                f"unilateral contact is inconsistent: the bilateral solution pulls (λ = {lam:.3e} N) but "
                f"the opened solution penetrates the surface (gap {gap:.3e} m)"
            )
        lam, opened = 0.0, True
    return StaticResult(
        q=q,
        deflection=_tip_deflection(model, data, q, q0, tip_frame_id),
        contact_force=lam,
        converged=True,
        iterations=it,
        residual=res,
        contact_opened=opened,
    )
