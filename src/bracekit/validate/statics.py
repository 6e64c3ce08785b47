"""Static references for the braced compliance models (docs/model.md, "The exact constrained compliance").

Two independent references, both on a plain Pinocchio model whose joints are all 1-DoF revolute
(nq == nv == n, joint order = chain order base→tip):

* :func:`lagrange_compliance` — the first-order equilibrium compliance of the spring-jointed chain with a
  bilateral constraint, from the bordered (KKT) system, not from the closed formula.
* :func:`solve_static_equilibrium` — the nonlinear static equilibrium of the chain under a dead tip wrench
  with a contact of the brace point {b} on a plane (frictionless point by default, any constraint wrenches X;
  rigid or a penalty spring), optionally with gravity and a base tip wrench (Newton on the KKT system with
  the analytic derivatives of the Jacobians and of the gravity torque).

Conventions (SI): wrench w = [f; m] at the tip point e in world axes (N, N·m); deflection
Δx = [Δp; Δθ] with Δp the change of the tip position (m, world) and Δθ = log3(R_e(q) R_e(q0)ᵀ)
(rad, world axes). Jacobians are Pinocchio's ``LOCAL_WORLD_ALIGNED`` ones (= the paper's J).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
import pinocchio as pin

from bracekit.errors import InputError, StaticSolveError

__all__ = [
    "MultiStaticResult",
    "StaticResult",
    "StaticSolveError",
    "frame_jacobian_derivative",
    "lagrange_compliance",
    "multi_preload_set_points",
    "preload_rest_configuration",
    "solve_static_equilibrium",
    "solve_static_equilibrium_multi",
]

_LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED


@dataclass(frozen=True, eq=False)
class StaticResult:
    """Result of :func:`solve_static_equilibrium`.

    Attributes:
        q: equilibrium configuration (n,), rad.
        deflection: Δx = [Δp; Δθ] (6,) of the tip relative to q0 (m, rad; world axes).
        contact_force: normal force the surface pushes on b, n̂ᵀ f_c (N, ≥ 0 when pressing; 0 if the contact
            opened or there is none).
        converged: True when the scaled residual reached ``tol``.
        iterations: Newton iterations used (summed over the bilateral and the opened solve).
        residual: final scaled residual: max of |torque residual|/k_i (rad) and |gap| (m).
        contact_opened: True when ``bilateral=False`` and the contact would have pulled, so it opened.
        contact_wrench: f_c = X λ (6,), the wrench [f; m] the surface exerts on the robot at b (world axes;
            N, N·m); zeros when the contact opened or there is none.
    """

    q: np.ndarray
    deflection: np.ndarray
    contact_force: float
    converged: bool
    iterations: int
    residual: float
    contact_opened: bool = False
    contact_wrench: np.ndarray = field(default_factory=lambda: np.zeros(6))


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


def _gravity(model: pin.Model, data: pin.Data, q: np.ndarray) -> np.ndarray:
    """g(q) (n,), N·m: Pinocchio's generalized gravity (the joint torques that hold the chain against gravity)."""
    return np.array(pin.computeGeneralizedGravity(model, data, q), dtype=float)


def _set_points(
    model: pin.Model,
    data: pin.Data,
    q0: np.ndarray,
    K: np.ndarray,
    brace_frame_id: int,
    tip_frame_id: int,
    contact_wrench: np.ndarray,
    base_wrench: np.ndarray,
    gravity: bool,
) -> np.ndarray:
    """q_s = q0 + K⁻¹ (g(q0) − J_e(q0)ᵀ w0 − J_b(q0)ᵀ f_c0): the spring set points that make q0 an equilibrium."""
    _kinematics(model, data, q0)
    tau = -pin.getFrameJacobian(model, data, brace_frame_id, _LWA).T @ contact_wrench
    tau -= pin.getFrameJacobian(model, data, tip_frame_id, _LWA).T @ base_wrench
    if gravity:
        tau += _gravity(model, data, q0)
    return q0 + tau / K


def preload_rest_configuration(
    model: pin.Model,
    q0: np.ndarray,
    stiffness: np.ndarray,
    brace_frame_id: int,
    surface_normal: np.ndarray,
    preload: float,
    *,
    gravity: bool = False,
    tip_frame_id: int | None = None,
    base_wrench: np.ndarray | None = None,
) -> np.ndarray:
    """Spring set points that make q0 the equilibrium under a contact force ``preload`` (N) along n̂.

    rest = q0 + K⁻¹ (g(q0) − J_e(q0)ᵀ w0 − J_b,v(q0)ᵀ n̂ P) (rad, shape (n,)); without gravity and base wrench
    w0 (the defaults) this is q0 − K⁻¹ J_b,vᵀ n̂ P. ``base_wrench`` [f; m] (at the tip, world axes) needs
    ``tip_frame_id``.
    """
    q0 = np.asarray(q0, dtype=float).reshape(-1)
    K = np.asarray(stiffness, dtype=float).reshape(-1)
    nhat = np.asarray(surface_normal, dtype=float).reshape(3)
    if base_wrench is not None and tip_frame_id is None:
        raise InputError("a base_wrench needs the tip_frame_id of the frame it acts at")
    w0 = np.zeros(6) if base_wrench is None else np.asarray(base_wrench, dtype=float).reshape(6)
    tip = brace_frame_id if tip_frame_id is None else tip_frame_id
    fc0 = np.concatenate([preload * nhat, np.zeros(3)])
    return _set_points(model, model.createData(), q0, K, brace_frame_id, tip, fc0, w0, gravity)


# --------------------------------------------------------------------------------------------------
# Nonlinear static equilibrium
# --------------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class _Problem:
    """The static problem: K (q − q_s) + g(q) − J_eᵀ w − J_bᵀ X λ = 0 with the contact rows.

    Contact rows: φ(q) = 0 (rigid) or φ(q) + (λ − λ0)/k_env = 0 (penalty), with
    φ_j(q) = X_f,jᵀ (p_b(q) − p_b(q0)) + X_m,jᵀ log3(R_b(q) R_b(q0)ᵀ).
    """

    model: pin.Model
    data: pin.Data
    K: np.ndarray
    rest: np.ndarray
    brace: int
    tip: int
    X: np.ndarray
    lam0: np.ndarray
    p_b0: np.ndarray
    R_b0: np.ndarray
    w: np.ndarray
    gravity: bool
    k_env: float | None

    def residual_and_tangent(
        self, x: np.ndarray, contact: bool, need_tangent: bool
    ) -> tuple[np.ndarray, np.ndarray | None]:
        """Scaled residual (torque rows / k_i in rad, contact rows in m or rad) and its derivative."""
        model, data, K = self.model, self.data, self.K
        n = model.nv
        q = x[:n]
        _kinematics(model, data, q)
        Je = pin.getFrameJacobian(model, data, self.tip, _LWA)
        F = np.empty(x.size)
        F[:n] = K * (q - self.rest) - Je.T @ self.w
        T = None
        if need_tangent:
            T = np.zeros((x.size, x.size))
            T[:n, :n] = np.diag(K) - np.einsum("r,rik->ik", self.w, frame_jacobian_derivative(model, data, self.tip))
        if self.gravity:
            F[:n] += _gravity(model, data, q)
            if T is not None:
                T[:n, :n] += pin.computeGeneralizedGravityDerivatives(model, data, q)
        if contact:
            lam = x[n:]
            Jb = pin.getFrameJacobian(model, data, self.brace, _LWA)
            A = Jb.T @ self.X  # (n, c)
            F[:n] -= A @ lam
            M = data.oMf[self.brace].rotation @ self.R_b0.T
            phi = self.X[:3].T @ (data.oMf[self.brace].translation - self.p_b0) + self.X[3:].T @ pin.log3(M)
            F[n:] = -phi
            if self.k_env is not None:
                F[n:] -= (lam - self.lam0) / self.k_env
            if T is not None:
                dJb = frame_jacobian_derivative(model, data, self.brace)
                T[:n, :n] -= np.einsum("r,rik->ik", self.X @ lam, dJb)
                T[:n, n:] = -A
                T[n:, :n] = -(self.X[:3].T @ Jb[:3] + self.X[3:].T @ pin.Jlog3(M) @ M.T @ Jb[3:])
                if self.k_env is not None:
                    T[n:, n:] = -np.eye(lam.size) / self.k_env
        F[:n] /= K
        if T is not None:
            T[:n, :] /= K[:, None]
        return F, T


class _Residual(Protocol):
    def residual_and_tangent(
        self, x: np.ndarray, contact: bool, need_tangent: bool
    ) -> tuple[np.ndarray, np.ndarray | None]: ...


def _newton(
    problem: _Residual, x0: np.ndarray, contact: bool, tol: float, max_iter: int
) -> tuple[np.ndarray, int, float]:
    """Damped Newton on the (scaled) KKT residual. Returns (x, iterations, residual)."""
    x = x0.copy()
    F, T = problem.residual_and_tangent(x, contact, True)
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
            F_try, _ = problem.residual_and_tangent(x_try, contact, False)
            res_try = float(np.max(np.abs(F_try)))
            if res_try < res or step < 1e-4:
                break
            step *= 0.5
        x = x_try
        F, T = problem.residual_and_tangent(x, contact, True)
        res = float(np.max(np.abs(F)))
        if not np.isfinite(res):
            raise StaticSolveError(f"static equilibrium diverged (non-finite residual at iteration {it})")
    return x, it, res


def _wrench(value: np.ndarray | None, name: str) -> np.ndarray:
    if value is None:
        return np.zeros(6)
    w = np.asarray(value, dtype=float).reshape(-1)
    if w.size != 6 or not np.all(np.isfinite(w)):
        raise InputError(f"{name} must be 6 finite numbers [f; m] (N, N·m), got shape {w.shape}")
    return w


def _constraint_wrenches(value: np.ndarray | None, nhat: np.ndarray, preload: float) -> tuple[np.ndarray, np.ndarray]:
    """X (6×c) and λ0 with X λ0 = [P n̂; 0]; X defaults to the frictionless point's [n̂; 0]."""
    if value is None:
        return np.concatenate([nhat, np.zeros(3)])[:, None], np.array([preload])
    X = np.asarray(value, dtype=float)
    if X.ndim != 2 or X.shape[0] != 6 or not 1 <= X.shape[1] <= 6 or not np.all(np.isfinite(X)):
        raise InputError(f"constraint_wrenches must be a finite 6×c matrix (1 ≤ c ≤ 6), got shape {X.shape}")
    if np.linalg.matrix_rank(X) < X.shape[1]:
        raise InputError("constraint_wrenches must have independent columns")
    normal = np.concatenate([nhat, np.zeros(3)])
    coeff = np.linalg.lstsq(X, normal, rcond=None)[0]
    if np.linalg.norm(X @ coeff - normal) > 1e-9:
        raise InputError("constraint_wrenches must transmit the normal force [n̂; 0] (every contact type does)")
    return X, preload * coeff


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
    gravity: bool = False,
    base_wrench: np.ndarray | None = None,
    environment_stiffness: float | None = None,
    constraint_wrenches: np.ndarray | None = None,
    contact: bool = True,
) -> StaticResult:
    """Nonlinear static equilibrium of the spring-jointed chain, brace point b on a plane.

    Solves for (q, λ):

        K (q − q_s) + g(q) − J_e(q)ᵀ (w0 + w) − J_b(q)ᵀ X λ = 0,   φ(q) = 0 (rigid contact),

    the joint torques τ = K (q_s − q) balancing gravity g (Pinocchio's generalized gravity, with the model's
    gravity vector), the dead tip wrench and the contact wrench X λ that the surface exerts on the robot at b
    (world axes). The set points q_s = q0 + K⁻¹ (g(q0) − J_e(q0)ᵀ w0 − J_b(q0)ᵀ [P n̂; 0]) make q0 the
    equilibrium under gravity, the base wrench w0 and the preload P, so the deflection is the response to
    ``wrench`` about that loaded equilibrium. The loads are dead: constant world wrenches at the moving tip.
    The contact keeps b on the constraint manifold φ_j(q) = X_f,jᵀ (p_b(q) − p_b(q0)) + X_m,jᵀ
    log3(R_b(q) R_b(q0)ᵀ) = 0; with a finite environment stiffness it is a penalty spring instead:
    X λ with λ = λ0 − k_env φ(q), where X λ0 = [P n̂; 0].

    Args:
        model: Pinocchio model of a serial chain of 1-DoF revolute joints (nq == nv == n).
        q0: (n,) rad, preloaded equilibrium; b must lie on the plane at q0.
        stiffness: (n,) joint stiffnesses, N·m/rad, > 0.
        brace_frame_id: Pinocchio frame id of {b}.
        tip_frame_id: Pinocchio frame id of {e}.
        surface_point: (3,) m, a point of the plane (world).
        surface_normal: (3,) unit normal, pointing out of the surface toward the robot.
        wrench: (6,) [f; m] at e, world axes (N, N·m), applied on top of ``base_wrench``.
        bilateral: keep the contact even if it pulls (normal force < 0). With False, a pulling contact opens
            and the free-chain equilibrium is returned with ``contact_opened=True``.
        preload: contact force P ≥ 0 (N) along n̂ at q0 before the wrench is applied.
        tol: convergence tolerance on the scaled residual (rad for torques/k_i, m or rad for the contact).
        max_iter: Newton iteration limit (per solve).
        gravity: include gravity (the model's ``gravity`` vector, default 9.81 m/s² along −z, and its masses).
        base_wrench: (6,) [f; m] dead wrench at e (world axes) already acting at q0; default none.
        environment_stiffness: k_env > 0 (N/m along constraint forces, N·m/rad along constraint moments) for a
            penalty contact; None (default) for a rigid one.
        constraint_wrenches: X (6×c), the contact's constraint wrenches at b (world axes; e.g.
            ``Brace.X()``); it must transmit [n̂; 0]. Default [n̂; 0], the frictionless point.
        contact: False for the free chain (no contact at all; ``preload`` must then be 0).

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
    w0 = _wrench(base_wrench, "base_wrench")
    if not np.all(np.isfinite(K)) or np.any(K <= 0.0):
        raise InputError("joint stiffnesses must be finite and > 0")
    if not (np.isfinite(preload) and preload >= 0.0):
        raise InputError(f"preload must be a finite force >= 0 N, got {preload}")
    if not contact and preload != 0.0:
        raise InputError(f"the free chain (contact=False) carries no preload, got preload={preload}")
    k_env = environment_stiffness
    if k_env is not None and not (np.isfinite(k_env) and k_env > 0.0):
        raise InputError(f"environment_stiffness must be a finite stiffness > 0 (or None if rigid), got {k_env}")
    for fid in (brace_frame_id, tip_frame_id):
        if not 0 <= fid < model.nframes:
            raise InputError(f"frame id {fid} out of range (model has {model.nframes} frames)")
    X, lam0 = _constraint_wrenches(constraint_wrenches, nhat, preload)

    data = model.createData()
    _kinematics(model, data, q0)
    p_b0 = data.oMf[brace_frame_id].translation.copy()
    R_b0 = data.oMf[brace_frame_id].rotation.copy()
    if contact:
        gap0 = float(nhat @ (p_b0 - s))
        if abs(gap0) > 1e-8:
            raise InputError(f"brace point is not on the surface at q0 (gap {gap0:.3e} m)")
        A0 = pin.getFrameJacobian(model, data, brace_frame_id, _LWA).T @ X
        Je0 = pin.getFrameJacobian(model, data, tip_frame_id, _LWA)
        sv = np.linalg.svd(A0 / np.sqrt(K)[:, None], compute_uv=False)
        if sv[-1] <= 1e-12 * max(float(np.linalg.norm(Je0 / np.sqrt(K))), 1.0):
            raise StaticSolveError(
                "the joints cannot move the brace point along a constraint direction (J_bᵀ X rank deficient, e.g. "
                "J_b,vᵀ n̂ = 0): the contact carries no load and the constrained equilibrium is undefined"
            )
    rest = _set_points(model, data, q0, K, brace_frame_id, tip_frame_id, X @ lam0, w0, gravity)
    problem = _Problem(model, data, K, rest, brace_frame_id, tip_frame_id, X, lam0, p_b0, R_b0, w0 + w, gravity, k_env)

    if not contact:
        q, it, res = _newton(problem, q0.copy(), False, tol, max_iter)
        _check_converged(res, tol, max_iter, "free-chain ")
        return StaticResult(q, _tip_deflection(model, data, q, q0, tip_frame_id), 0.0, True, it, res, False)
    x, it, res = _newton(problem, np.concatenate([q0, lam0]), True, tol, max_iter)
    _check_converged(res, tol, max_iter, "")
    q, lam = x[:n], x[n:]
    fc = X @ lam
    opened = False
    if not bilateral and float(nhat @ fc[:3]) < 0.0:
        normal_force = float(nhat @ fc[:3])
        q, it2, res = _newton(problem, q.copy(), False, tol, max_iter)
        it += it2
        _check_converged(res, tol, max_iter, "free (opened-contact) ")
        _kinematics(model, data, q)
        gap = float(nhat @ (data.oMf[brace_frame_id].translation - s))
        surface = 0.0 if k_env is None else preload / k_env  # where the undeformed (penalty) surface lies
        if gap < surface - tol:
            raise StaticSolveError(
                f"unilateral contact is inconsistent: the bilateral solution pulls (normal force "
                f"{normal_force:.3e} N) but the opened solution penetrates the surface (gap {gap - surface:.3e} m)"
            )
        fc, opened = np.zeros(6), True
    return StaticResult(
        q=q,
        deflection=_tip_deflection(model, data, q, q0, tip_frame_id),
        contact_force=float(nhat @ fc[:3]),
        converged=True,
        iterations=it,
        residual=res,
        contact_opened=opened,
        contact_wrench=fc,
    )


def _check_converged(res: float, tol: float, max_iter: int, which: str) -> None:
    if res > tol:
        raise StaticSolveError(
            f"{which}static equilibrium did not converge in {max_iter} Newton iterations "
            f"(scaled residual {res:.3e} > tol {tol:.1e}); the load may be too large"
        )


# --------------------------------------------------------------------------------------------------
# Several braces
# --------------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class MultiStaticResult:
    """Result of :func:`solve_static_equilibrium_multi`.

    Attributes:
        q: equilibrium configuration (n,), rad.
        deflection: Δx = [Δp; Δθ] (6,) of the tip relative to q0 (m, rad; world axes).
        contact_forces: normal force n̂_iᵀ f_c,i each surface pushes on its b_i (N, > 0 when pressing, < 0 when
            the bilateral contact pulls), in the order of the braces.
        contact_wrenches: f_c,i = X_i λ_i (6,) per brace, [f; m] on the robot at b_i (world axes; N, N·m).
        iterations: Newton iterations used.
        residual: final scaled residual: max of |torque residual|/k_i (rad) and |φ_i| (m or rad).
    """

    q: np.ndarray
    deflection: np.ndarray
    contact_forces: np.ndarray
    contact_wrenches: tuple[np.ndarray, ...]
    iterations: int
    residual: float


def _preload_wrenches(normals: list[np.ndarray], preloads: np.ndarray) -> list[np.ndarray]:
    return [np.concatenate([P * nh, np.zeros(3)]) for nh, P in zip(normals, preloads, strict=True)]


def _per_brace(value: float | Sequence[float] | np.ndarray, count: int) -> np.ndarray:
    """One preload (N) per brace from a number or a sequence; InputError unless finite and ≥ 0."""
    p = np.asarray(value, dtype=float).reshape(-1)
    if p.size == 1:
        p = np.full(count, float(p[0]))
    if p.size != count or not np.all(np.isfinite(p)) or np.any(p < 0.0):
        raise InputError(f"preload must be one finite force >= 0 N or one per brace ({count}), got {value!r}")
    return p


def multi_preload_set_points(
    model: pin.Model,
    q0: np.ndarray,
    stiffness: np.ndarray,
    brace_frame_ids: Sequence[int],
    surface_normals: Sequence[np.ndarray],
    preloads: float | Sequence[float] | np.ndarray,
) -> np.ndarray:
    """Spring set points that make q0 the equilibrium with each contact i pushing P_i n̂_i on b_i.

    q_s = q0 + K⁻¹ (−Σ_i J_b_i(q0)ᵀ [P_i n̂_i; 0]) (rad, shape (n,)); J_b_i LOCAL_WORLD_ALIGNED. One preload
    (N) for all braces or one per brace.
    """
    q0 = np.asarray(q0, dtype=float).reshape(-1)
    K = np.asarray(stiffness, dtype=float).reshape(-1)
    normals = [_unit(nh, f"surface_normals[{i}]") for i, nh in enumerate(surface_normals)]
    if len(normals) != len(brace_frame_ids):
        raise InputError(f"give one surface normal per brace: {len(brace_frame_ids)} braces, {len(normals)} normals")
    P = _per_brace(preloads, len(normals))
    data = model.createData()
    _kinematics(model, data, q0)
    tau = np.zeros(model.nv)
    for fid, fc in zip(brace_frame_ids, _preload_wrenches(normals, P), strict=True):
        tau -= pin.getFrameJacobian(model, data, fid, _LWA).T @ fc
    return q0 + tau / K


@dataclass(frozen=True, eq=False)
class _MultiProblem:
    """K (q − q_s) − J_eᵀ w − Σ_i J_b_iᵀ X_i λ_i = 0 and φ_i(q) = 0 for every brace i (rigid, bilateral)."""

    model: pin.Model
    data: pin.Data
    K: np.ndarray
    rest: np.ndarray
    braces: tuple[int, ...]
    tip: int
    X: tuple[np.ndarray, ...]
    p_b0: tuple[np.ndarray, ...]
    R_b0: tuple[np.ndarray, ...]
    w: np.ndarray

    def residual_and_tangent(
        self, x: np.ndarray, contact: bool, need_tangent: bool
    ) -> tuple[np.ndarray, np.ndarray | None]:
        """Scaled residual (torque rows / k_i in rad, contact rows in m or rad) and its derivative.

        ``contact`` must be True (the contacts are always closed); it matches :class:`_Problem`.
        """
        model, data, K = self.model, self.data, self.K
        n = model.nv
        q = x[:n]
        _kinematics(model, data, q)
        Je = pin.getFrameJacobian(model, data, self.tip, _LWA)
        F = np.empty(x.size)
        F[:n] = K * (q - self.rest) - Je.T @ self.w
        T = None
        if need_tangent:
            T = np.zeros((x.size, x.size))
            T[:n, :n] = np.diag(K) - np.einsum("r,rik->ik", self.w, frame_jacobian_derivative(model, data, self.tip))
        row = n
        for fid, X, p0, R0 in zip(self.braces, self.X, self.p_b0, self.R_b0, strict=True):
            c = X.shape[1]
            lam = x[row : row + c]
            Jb = pin.getFrameJacobian(model, data, fid, _LWA)
            A = Jb.T @ X
            F[:n] -= A @ lam
            M = data.oMf[fid].rotation @ R0.T
            F[row : row + c] = -(X[:3].T @ (data.oMf[fid].translation - p0) + X[3:].T @ pin.log3(M))
            if T is not None:
                T[:n, :n] -= np.einsum("r,rik->ik", X @ lam, frame_jacobian_derivative(model, data, fid))
                T[:n, row : row + c] = -A
                T[row : row + c, :n] = -(X[:3].T @ Jb[:3] + X[3:].T @ pin.Jlog3(M) @ M.T @ Jb[3:])
            row += c
        F[:n] /= K
        if T is not None:
            T[:n, :] /= K[:, None]
        return F, T


def solve_static_equilibrium_multi(
    model: pin.Model,
    q0: np.ndarray,
    stiffness: np.ndarray,
    brace_frame_ids: Sequence[int],
    tip_frame_id: int,
    surfaces: Sequence[tuple[np.ndarray, np.ndarray]],
    wrench: np.ndarray,
    *,
    preload: float | Sequence[float] | np.ndarray = 0.0,
    constraint_wrenches: Sequence[np.ndarray] | None = None,
    tol: float = 1e-12,
    max_iter: int = 50,
) -> MultiStaticResult:
    """Nonlinear static equilibrium of the spring-jointed chain with several bilateral rigid contacts.

    Solves for (q, λ_1, …, λ_m), Newton on the stacked KKT system:

        K (q − q_s) − J_e(q)ᵀ w − Σ_i J_b_i(q)ᵀ X_i λ_i = 0,   φ_i(q) = 0 (i = 1..m),

    φ_i(q) = X_i,fᵀ (p_b_i(q) − p_b_i(q0)) + X_i,mᵀ log3(R_b_i(q) R_b_i(q0)ᵀ), X_i λ_i the wrench surface i
    exerts on the robot at b_i (world axes). The set points q_s = q0 − K⁻¹ Σ_i J_b_i(q0)ᵀ X_i λ_i0, with
    X_i λ_i0 = [P_i n̂_i; 0], make q0 the equilibrium under the preloads P_i
    (:func:`multi_preload_set_points` for frictionless points). The tip wrench is dead (constant world
    wrench at the moving tip). Contacts never open: check ``contact_forces`` for pulls (< 0).

    Args:
        model: Pinocchio model of a serial chain of 1-DoF revolute joints (nq == nv == n).
        q0: (n,) rad, the preloaded equilibrium; each b_i lies on its plane at q0.
        stiffness: (n,) joint stiffnesses, N·m/rad, > 0.
        brace_frame_ids: Pinocchio frame id of each {b_i}.
        tip_frame_id: Pinocchio frame id of {e}.
        surfaces: (point (3,) m, unit normal n̂_i toward the robot) of each brace's plane, world.
        wrench: (6,) [f; m] at e, world axes (N, N·m).
        preload: P_i ≥ 0 (N) along n̂_i at q0: one for all braces or one per brace.
        constraint_wrenches: X_i (6×c_i) of each brace (world axes; e.g. ``Brace.X()``), each transmitting
            [n̂_i; 0]; default [n̂_i; 0] (frictionless points).
        tol: convergence tolerance on the scaled residual (rad for torques/k_i, m or rad for the contacts).
        max_iter: Newton iteration limit.

    Returns:
        :class:`MultiStaticResult` (deflection relative to q0).

    Raises:
        InputError: bad inputs (shapes, counts, non-revolute joints, a b_i off its plane at q0).
        StaticSolveError: no convergence, or a singular stacked KKT system (dependent or unloaded contacts).
    """
    _check_model(model)
    n = model.nv
    q0 = np.asarray(q0, dtype=float).reshape(-1)
    K = np.asarray(stiffness, dtype=float).reshape(-1)
    w = _wrench(wrench, "wrench")
    if q0.size != n or K.size != n:
        raise InputError(f"q0 and stiffness must have shape ({n},), got {q0.shape} and {K.shape}")
    if not np.all(np.isfinite(K)) or np.any(K <= 0.0):
        raise InputError("joint stiffnesses must be finite and > 0")
    ids = tuple(int(f) for f in brace_frame_ids)
    if not ids:
        raise InputError("give at least one brace frame id")
    if len(surfaces) != len(ids):
        raise InputError(f"give one surface (point, normal) per brace: {len(ids)} braces, {len(surfaces)} surfaces")
    for fid in (*ids, tip_frame_id):
        if not 0 <= fid < model.nframes:
            raise InputError(f"frame id {fid} out of range (model has {model.nframes} frames)")
    P = _per_brace(preload, len(ids))
    normals = [_unit(nh, f"surfaces[{i}] normal") for i, (_, nh) in enumerate(surfaces)]
    points = [np.asarray(pt, dtype=float).reshape(3) for pt, _ in surfaces]
    if constraint_wrenches is None:
        Xs, lam0s = zip(*(_constraint_wrenches(None, nh, p) for nh, p in zip(normals, P, strict=True)), strict=True)
    else:
        if len(constraint_wrenches) != len(ids):
            raise InputError(f"give one constraint-wrench matrix X_i per brace ({len(ids)})")
        Xs, lam0s = zip(
            *(_constraint_wrenches(X, nh, p) for X, nh, p in zip(constraint_wrenches, normals, P, strict=True)),
            strict=True,
        )
    data = model.createData()
    _kinematics(model, data, q0)
    for i, (fid, pt, nh) in enumerate(zip(ids, points, normals, strict=True)):
        gap = float(nh @ (data.oMf[fid].translation - pt))
        if abs(gap) > 1e-8:
            raise InputError(f"brace {i}: b_i is not on its surface at q0 (gap {gap:.3e} m)")
    p_b0 = tuple(data.oMf[fid].translation.copy() for fid in ids)
    R_b0 = tuple(data.oMf[fid].rotation.copy() for fid in ids)
    tau = np.zeros(n)
    for fid, X, lam0 in zip(ids, Xs, lam0s, strict=True):
        tau -= pin.getFrameJacobian(model, data, fid, _LWA).T @ (X @ lam0)
    rest = q0 + tau / K
    problem = _MultiProblem(model, data, K, rest, ids, int(tip_frame_id), tuple(Xs), p_b0, R_b0, w)

    x, it, res = _newton(problem, np.concatenate([q0, *lam0s]), True, tol, max_iter)
    _check_converged(res, tol, max_iter, "several-brace ")
    q = x[:n]
    wrenches, row = [], n
    for X in Xs:
        wrenches.append(X @ x[row : row + X.shape[1]])
        row += X.shape[1]
    return MultiStaticResult(
        q=q,
        deflection=_tip_deflection(model, data, q, q0, int(tip_frame_id)),
        contact_forces=np.array([float(nh @ fc[:3]) for nh, fc in zip(normals, wrenches, strict=True)]),
        contact_wrenches=tuple(wrenches),
        iterations=it,
        residual=res,
    )
