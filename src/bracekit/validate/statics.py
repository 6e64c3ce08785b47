"""The nonlinear static reference of the braced compliance models (docs/model.md, "The exact constrained compliance").

:func:`solve_statics` solves the static equilibrium of a spring-jointed chain under a dead tip wrench with any
number N ≥ 1 of contacts, each a frame {b_i} on a plane (:class:`PlaneContact`: frictionless point by default,
any constraint wrenches X_i; rigid or a penalty spring k_env; unilateral or bilateral), optionally with
gravity and a base tip wrench: Newton on the KKT system with the analytic derivatives of the Jacobians
(:func:`~bracekit.validate.lagrange.frame_jacobian_derivative`) and of the gravity torque.
:func:`solve_static_equilibrium` is its one-contact form (one brace given by frame, plane and preload).
The first-order bordered-KKT reference is :func:`~bracekit.validate.lagrange.lagrange_compliance`.

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
from bracekit.validate.lagrange import _check_model, _kinematics, frame_jacobian_derivative, lagrange_compliance
from bracekit.validate.plane_contact import (
    PlaneContact,
    _checked,
    _Contact,
    _gravity,
    _set_points,
    contact_set_points,
    preload_rest_configuration,
)

__all__ = [
    "PlaneContact",
    "StaticResult",
    "StaticSolveError",
    "contact_set_points",
    "frame_jacobian_derivative",
    "lagrange_compliance",
    "preload_rest_configuration",
    "solve_static_equilibrium",
    "solve_statics",
]

_LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED


@dataclass(frozen=True, eq=False)
class StaticResult:
    """Result of :func:`solve_statics` (and :func:`solve_static_equilibrium`).

    Attributes:
        q: equilibrium configuration (n,), rad.
        deflection: Δx = [Δp; Δθ] (6,) of the tip relative to q0 (m, rad; world axes).
        contact_force: normal force the surface pushes on b, n̂ᵀ f_c (N, ≥ 0 when pressing; 0 if the contact
            opened or there is none); with several contacts, that of the first.
        converged: True when the scaled residual reached ``tol``.
        iterations: Newton iterations used (summed over the bilateral and the opened solves).
        residual: final scaled residual: max of |torque residual|/k_i (rad) and |gap| (m).
        contact_opened: True when ``bilateral=False`` and a contact would have pulled, so it opened.
        contact_wrench: f_c = X λ (6,) of the first contact, [f; m] the surface exerts on the robot at b (world
            axes; N, N·m); zeros when it opened or there is none.
        contact_forces: n̂_iᵀ f_c,i of every contact (N,), N (< 0: a bilateral contact pulls; 0 when opened).
        contact_wrenches: f_c,i of every contact, (6,) each.
        contacts_opened: per contact, whether it opened.
    """

    q: np.ndarray
    deflection: np.ndarray
    contact_force: float
    converged: bool
    iterations: int
    residual: float
    contact_opened: bool = False
    contact_wrench: np.ndarray = field(default_factory=lambda: np.zeros(6))
    contact_forces: np.ndarray = field(default_factory=lambda: np.zeros(0))
    contact_wrenches: tuple[np.ndarray, ...] = ()
    contacts_opened: tuple[bool, ...] = ()


#: The several-brace result is the same record (``contact_forces``, ``contact_wrenches`` per brace).
MultiStaticResult = StaticResult


# --------------------------------------------------------------------------------------------------
# Helpers
# --------------------------------------------------------------------------------------------------
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


def _wrench(value: np.ndarray | None, name: str) -> np.ndarray:
    if value is None:
        return np.zeros(6)
    w = np.asarray(value, dtype=float).reshape(-1)
    if w.size != 6 or not np.all(np.isfinite(w)):
        raise InputError(f"{name} must be 6 finite numbers [f; m] (N, N·m), got shape {w.shape}")
    return w


# --------------------------------------------------------------------------------------------------
# Nonlinear static equilibrium
# --------------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class _Problem:
    """The static problem: K (q − q_s) + g(q) − J_eᵀ w − Σ_i J_b_iᵀ X_i λ_i = 0 with the active contacts' rows.

    Contact rows: φ_i(q) = 0 (rigid) or φ_i(q) + (λ_i − λ0_i)/k_env = 0 (penalty), with
    φ_ij(q) = X_f,ijᵀ (p_b_i(q) − p_b_i(q0)) + X_m,ijᵀ log3(R_b_i(q) R_b_i(q0)ᵀ).
    """

    model: pin.Model
    data: pin.Data
    K: np.ndarray
    rest: np.ndarray
    tip: int
    contacts: tuple[_Contact, ...]
    w: np.ndarray
    gravity: bool

    def residual_and_tangent(
        self, x: np.ndarray, active: tuple[bool, ...], need_tangent: bool
    ) -> tuple[np.ndarray, np.ndarray | None]:
        """Scaled residual (torque rows / k_i in rad, contact rows in m or rad) and its derivative.

        x = [q; λ_i of the active contacts in order].
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
        if self.gravity:
            F[:n] += _gravity(model, data, q)
            if T is not None:
                T[:n, :n] += pin.computeGeneralizedGravityDerivatives(model, data, q)
        row = n
        for c, on in zip(self.contacts, active, strict=True):
            if not on:
                continue
            X, m = c.X, c.X.shape[1]
            lam = x[row : row + m]
            Jb = pin.getFrameJacobian(model, data, c.frame_id, _LWA)
            A = Jb.T @ X  # (n, c)
            F[:n] -= A @ lam
            M = data.oMf[c.frame_id].rotation @ c.R_b0.T
            phi = X[:3].T @ (data.oMf[c.frame_id].translation - c.p_b0) + X[3:].T @ pin.log3(M)
            F[row : row + m] = -phi
            if c.k_env is not None:
                F[row : row + m] -= (lam - c.lam0) / c.k_env
            if T is not None:
                dJb = frame_jacobian_derivative(model, data, c.frame_id)
                T[:n, :n] -= np.einsum("r,rik->ik", X @ lam, dJb)
                T[:n, row : row + m] = -A
                T[row : row + m, :n] = -(X[:3].T @ Jb[:3] + X[3:].T @ pin.Jlog3(M) @ M.T @ Jb[3:])
                if c.k_env is not None:
                    T[row : row + m, row : row + m] = -np.eye(m) / c.k_env
            row += m
        F[:n] /= K
        if T is not None:
            T[:n, :] /= K[:, None]
        return F, T


class _Residual(Protocol):
    def residual_and_tangent(
        self, x: np.ndarray, active: tuple[bool, ...], need_tangent: bool
    ) -> tuple[np.ndarray, np.ndarray | None]: ...


def _newton(
    problem: _Residual, x0: np.ndarray, active: tuple[bool, ...], tol: float, max_iter: int
) -> tuple[np.ndarray, int, float]:
    """Damped Newton on the (scaled) KKT residual. Returns (x, iterations, residual)."""
    x = x0.copy()
    F, T = problem.residual_and_tangent(x, active, True)
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
            F_try, _ = problem.residual_and_tangent(x_try, active, False)
            res_try = float(np.max(np.abs(F_try)))
            if res_try < res or step < 1e-4:
                break
            step *= 0.5
        x = x_try
        F, T = problem.residual_and_tangent(x, active, True)
        res = float(np.max(np.abs(F)))
        if not np.isfinite(res):
            raise StaticSolveError(f"static equilibrium diverged (non-finite residual at iteration {it})")
    return x, it, res


def _check_converged(res: float, tol: float, max_iter: int, which: str) -> None:
    if res > tol:
        raise StaticSolveError(
            f"{which}static equilibrium did not converge in {max_iter} Newton iterations "
            f"(scaled residual {res:.3e} > tol {tol:.1e}); the load may be too large"
        )


def _stack(x: np.ndarray, contacts: Sequence[_Contact], active: tuple[bool, ...], n: int) -> list[np.ndarray]:
    """λ_i of every contact from x = [q; λ of the active ones] (zeros for the inactive)."""
    out, row = [], n
    for c, on in zip(contacts, active, strict=True):
        m = c.X.shape[1]
        out.append(x[row : row + m].copy() if on else np.zeros(m))
        row += m if on else 0
    return out


def solve_statics(
    model: pin.Model,
    q0: np.ndarray,
    stiffness: np.ndarray,
    tip_frame_id: int,
    contacts: Sequence[PlaneContact],
    wrench: np.ndarray,
    *,
    bilateral: bool = True,
    tol: float = 1e-12,
    max_iter: int = 50,
    gravity: bool = False,
    base_wrench: np.ndarray | None = None,
    contact: bool = True,
) -> StaticResult:
    """Nonlinear static equilibrium of the spring-jointed chain with N ≥ 1 contacts of frames {b_i} on planes.

    Solves for (q, λ_1, …, λ_N):

        K (q − q_s) + g(q) − J_e(q)ᵀ (w0 + w) − Σ_i J_b_i(q)ᵀ X_i λ_i = 0,   φ_i(q) = 0 (rigid contact i),

    the joint torques τ = K (q_s − q) balancing gravity g (Pinocchio's generalized gravity, with the model's
    gravity vector), the dead tip wrench and the contact wrenches X_i λ_i that the surfaces exert on the robot
    at b_i (world axes). The set points q_s (:func:`contact_set_points`) make q0 the equilibrium under gravity,
    the base wrench w0 and the preloads X_i λ0_i = [P_i n̂_i; 0], so the deflection is the response to
    ``wrench`` about that loaded equilibrium. The loads are dead: constant world wrenches at the moving tip.
    Contact i keeps b_i on its constraint manifold φ_ij(q) = X_f,ijᵀ (p_b_i(q) − p_b_i(q0)) + X_m,ijᵀ
    log3(R_b_i(q) R_b_i(q0)ᵀ) = 0; with a finite k_env it is a penalty spring instead: λ_i = λ0_i − k_env φ_i(q).

    Unilateral contacts (``bilateral=False``): after the bilateral solve, every contact whose normal force
    n̂_iᵀ f_c,i pulls opens and the equilibrium is solved again without it (repeated while another pulls);
    an opened contact whose point then lies inside its (undeformed) surface is an inconsistent contact set.

    Args:
        model: Pinocchio model of a serial chain of 1-DoF revolute joints (nq == nv == n).
        q0: (n,) rad, the preloaded equilibrium; every b_i must lie on its plane at q0.
        stiffness: (n,) joint stiffnesses, N·m/rad, > 0.
        tip_frame_id: Pinocchio frame id of {e}.
        contacts: the contacts (:class:`PlaneContact`), at least one.
        wrench: (6,) [f; m] at e, world axes (N, N·m), applied on top of ``base_wrench``.
        bilateral: keep the contacts even if they pull; False: a pulling contact opens (``contact_opened``).
        tol: convergence tolerance on the scaled residual (rad for torques/k_i, m or rad for the contacts).
        max_iter: Newton iteration limit (per solve).
        gravity: include gravity (the model's ``gravity`` vector, default 9.81 m/s² along −z, and its masses).
        base_wrench: (6,) [f; m] dead wrench at e (world axes) already acting at q0; default none.
        contact: False for the free chain (no contact acts; every preload must then be 0).

    Returns:
        :class:`StaticResult` (deflection relative to q0).

    Raises:
        InputError: bad inputs (shapes, non-revolute joints, a b_i off its plane at q0, negative preloads).
        StaticSolveError: no convergence within ``max_iter``, a singular KKT system (a contact carries no load
            from the chain, or the contacts are dependent), or an opened contact that would penetrate its plane.
    """
    _check_model(model)
    n = model.nv
    q0 = np.asarray(q0, dtype=float).reshape(-1)
    K = np.asarray(stiffness, dtype=float).reshape(-1)
    w = np.asarray(wrench, dtype=float).reshape(-1)
    if q0.size != n or K.size != n:
        raise InputError(f"q0 and stiffness must have shape ({n},), got {q0.shape} and {K.shape}")
    if w.size != 6:
        raise InputError(f"wrench must have shape (6,), got {w.shape}")
    w0 = _wrench(base_wrench, "base_wrench")
    if not np.all(np.isfinite(K)) or np.any(K <= 0.0):
        raise InputError("joint stiffnesses must be finite and > 0")
    if not 0 <= int(tip_frame_id) < model.nframes:
        raise InputError(f"frame id {tip_frame_id} out of range (model has {model.nframes} frames)")
    tip = int(tip_frame_id)
    data = model.createData()
    _kinematics(model, data, q0)
    cs = _checked(model, data, contacts)
    if not contact and any(c.preload != 0.0 for c in cs):
        raise InputError(f"the free chain (contact=False) carries no preload, got preload={cs[0].preload}")
    if contact:
        for i, c in enumerate(cs):
            gap0 = float(c.normal @ (c.p_b0 - c.point))
            if abs(gap0) > 1e-8:
                which = "" if len(cs) == 1 else f" {i}"
                raise InputError(f"brace point{which} is not on the surface at q0 (gap {gap0:.3e} m)")
        A0 = np.hstack([pin.getFrameJacobian(model, data, c.frame_id, _LWA).T @ c.X for c in cs])
        Je0 = pin.getFrameJacobian(model, data, tip, _LWA)
        sv = np.linalg.svd(A0 / np.sqrt(K)[:, None], compute_uv=False)
        if sv[-1] <= 1e-12 * max(float(np.linalg.norm(Je0 / np.sqrt(K))), 1.0):
            raise StaticSolveError(
                "the joints cannot move the brace point along a constraint direction (J_bᵀ X rank deficient, e.g. "
                "J_b,vᵀ n̂ = 0, or dependent contacts): the contact carries no load and the constrained equilibrium "
                "is undefined"
            )
    rest = _set_points(model, data, q0, K, cs, tip, w0, gravity)
    problem = _Problem(model, data, K, rest, tip, tuple(cs), w0 + w, gravity)
    off = (False,) * len(cs)

    if not contact:
        q, it, res = _newton(problem, q0.copy(), off, tol, max_iter)
        _check_converged(res, tol, max_iter, "free-chain ")
        empty = tuple(np.zeros(6) for _ in cs)
        return StaticResult(
            q, _tip_deflection(model, data, q, q0, tip), 0.0, True, it, res, False,
            contact_forces=np.zeros(len(cs)), contact_wrenches=empty, contacts_opened=off,
        )  # fmt: skip
    active = (True,) * len(cs)
    x, it, res = _newton(problem, np.concatenate([q0, *(c.lam0 for c in cs)]), active, tol, max_iter)
    _check_converged(res, tol, max_iter, "" if len(cs) == 1 else "several-brace ")
    while not bilateral:
        lams = _stack(x, cs, active, n)
        normal = [float(c.normal @ (c.X @ lam)[:3]) for c, lam in zip(cs, lams, strict=True)]
        pulling = [i for i, on in enumerate(active) if on and normal[i] < 0.0]
        if not pulling:
            break
        active = tuple(on and i not in pulling for i, on in enumerate(active))
        x0 = np.concatenate([x[:n], *(lam for lam, on in zip(lams, active, strict=True) if on)])
        x, it2, res = _newton(problem, x0, active, tol, max_iter)
        it += it2
        _check_converged(res, tol, max_iter, "free (opened-contact) ")
        _kinematics(model, data, x[:n])
        for i, c in enumerate(cs):
            if active[i]:
                continue
            gap = float(c.normal @ (data.oMf[c.frame_id].translation - c.point))
            surface = 0.0 if c.k_env is None else c.preload / c.k_env  # where the undeformed (penalty) surface lies
            if gap < surface - tol:
                pull = f" (normal force {normal[i]:.3e} N)" if i in pulling else ""
                raise StaticSolveError(
                    f"unilateral contact is inconsistent: the bilateral solution pulls{pull} but the opened solution "
                    f"penetrates the surface (gap {gap - surface:.3e} m)"
                )
    q = x[:n]
    wrenches = tuple(c.X @ lam for c, lam in zip(cs, _stack(x, cs, active, n), strict=True))
    forces = np.array([float(c.normal @ fc[:3]) for c, fc in zip(cs, wrenches, strict=True)])
    opened = tuple(not on for on in active)
    return StaticResult(
        q=q,
        deflection=_tip_deflection(model, data, q, q0, tip),
        contact_force=float(forces[0]),
        converged=True,
        iterations=it,
        residual=res,
        contact_opened=any(opened),
        contact_wrench=wrenches[0],
        contact_forces=forces,
        contact_wrenches=wrenches,
        contacts_opened=opened,
    )


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
    """:func:`solve_statics` with one contact: brace {b} on the plane (``surface_point``, ``surface_normal``).

    Args:
        model: Pinocchio model of a serial chain of 1-DoF revolute joints (nq == nv == n).
        q0: (n,) rad, preloaded equilibrium; b must lie on the plane at q0.
        stiffness: (n,) joint stiffnesses, N·m/rad, > 0.
        brace_frame_id: Pinocchio frame id of {b}.
        tip_frame_id: Pinocchio frame id of {e}.
        surface_point: (3,) m, a point of the plane (world).
        surface_normal: (3,) unit normal, pointing out of the surface toward the robot.
        wrench: (6,) [f; m] at e, world axes (N, N·m), applied on top of ``base_wrench``.
        bilateral: keep the contact even if it pulls; False: a pulling contact opens (``contact_opened``).
        preload: contact force P ≥ 0 (N) along n̂ at q0 before the wrench is applied.
        tol: convergence tolerance on the scaled residual.
        max_iter: Newton iteration limit (per solve).
        gravity: include gravity.
        base_wrench: (6,) [f; m] dead wrench at e (world axes) already acting at q0; default none.
        environment_stiffness: k_env > 0 of a penalty contact; None (default) for a rigid one.
        constraint_wrenches: X (6×c), the contact's constraint wrenches at b (world axes); default [n̂; 0].
        contact: False for the free chain (``preload`` must then be 0).
    """
    c = PlaneContact(
        brace_frame_id, np.asarray(surface_point, dtype=float), np.asarray(surface_normal, dtype=float),
        float(preload), constraint_wrenches, environment_stiffness,
    )  # fmt: skip
    return solve_statics(
        model, q0, stiffness, tip_frame_id, [c], wrench, bilateral=bilateral, tol=tol, max_iter=max_iter,
        gravity=gravity, base_wrench=base_wrench, contact=contact,
    )  # fmt: skip
