"""Quasi-static equilibrium of the braced robot at a commanded configuration q, preloaded, and its load response.

Sign conventions (SI, world axes):

* w = [f; m] is a wrench applied ON the robot's tool at the tip point e (N, N·m).
* f_c = [f; m] is the wrench applied BY the surface ON the robot, referred to the brace point b. It lies in the
  span of the load contact's constraint wrenches, f_c = X λ. Its normal force f_n = n̂ᵀ f_c[:3] is ≥ 0 when the
  surface pushes (n̂ points from the surface toward the robot); its tangential force is (I − n̂n̂ᵀ) f_c[:3].
* τ (n,) are the torques the actuators apply (N·m; N for a prismatic joint); g(q) is Pinocchio's generalised
  gravity (``computeGeneralizedGravity``, zero without gravity). Static equilibrium:
  τ = g(q) − J_eᵀ w − J_bᵀ f_c (J_e, J_b: LOCAL_WORLD_ALIGNED frame Jacobians, twists [v; ω]).

The actuators are the joint springs of the model, τ = K (q_s − q). The set points q_s are chosen so that, with
no tool load, the robot is at q and the contact carries exactly the preload f_c0 = [P n̂; 0] (no tangential force,
no moment): τ0 = g(q) − J_bᵀ f_c0 and q_s = q + K⁻¹ τ0.

Under a tool wrench w with the set points fixed, the first-order response keeps the LOAD contact closed:
K_t δq = J_eᵀ w + J_bᵀ X_L δλ and X_Lᵀ J_b δq = −δλ / k_env (0 for a rigid surface: b does not move along the
constraint directions; moving b along +n̂ relieves a compliant surface). Then δf_c = X_L δλ and δτ = −K δq.
K_t = K + ∂g/∂q − ∂(J_bᵀ f_c0)/∂q is the tangent stiffness: the joint springs plus the geometric stiffness of
gravity and of the preload (docs/model.md, Section 5); with ``geometric=False`` K_t = K, and then
δτ = −J_eᵀ w − J_bᵀ δf_c exactly. The dead load's own term ∂(J_eᵀ w)/∂q is of second order in w and dropped.

The LOAD contact is the brace's contact type, except that a ``frictionless_point`` brace given a friction
coefficient μ > 0 sticks under load and transmits a 3-D force (the ``point_with_friction`` contact's X).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike, NDArray

from bracekit._linalg import as_array, as_number, finite_math, show
from bracekit.compliance.first_order import loaded_gain, warn_unloaded
from bracekit.contact import Brace
from bracekit.errors import (
    InputError,
    ModelError,
    NumericalError,
    UnstableEquilibriumError,
)
from bracekit.kinematics import BracedRobot
from bracekit.kinematics.braced import MAX_HESSIAN_JOINTS
from bracekit.model.robot import Robot

Array = NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class ContactResponse:
    """The preloaded equilibrium at one configuration q and its first-order response to a tool wrench.

    Attributes:
        q: the commanded configuration (n,), rad.
        q_s: spring set points (n,), rad: q_s = q + K⁻¹ τ0.
        tau0: actuator torques without tool load (n,), N·m: g(q) − J_bᵀ f_c0.
        f_c0: contact wrench without tool load (6,), [P n̂; 0] at b, world axes (N, N·m).
        contact_gain: δf_c per unit tool wrench (6×6): f_c = f_c0 + contact_gain @ w (first order).
        torque_gain: δτ per unit tool wrench (n×6): τ = tau0 + torque_gain @ w (first order).
        joint_gain: δq per unit tool wrench (n×6), rad per N or N·m.
        X: constraint wrenches of the load contact (6×c), at b, world axes.
        normal: the surface normal n̂ (3,), toward the robot.
        preload: P (N).
        friction: μ, or None when no friction coefficient was given.
    """

    q: Array
    q_s: Array
    tau0: Array
    f_c0: Array
    contact_gain: Array
    torque_gain: Array
    joint_gain: Array
    X: Array
    normal: Array
    preload: float
    friction: float | None

    def contact_wrench(self, w: ArrayLike) -> Array:
        """f_c = f_c0 + contact_gain w for one wrench w (6,) or a list of them (m×6): (6,) or (m×6), N, N·m."""
        ws = _wrench_rows(w)
        out = self.f_c0 + ws @ self.contact_gain.T
        return out[0] if np.ndim(w) == 1 else out

    def torque(self, w: ArrayLike) -> Array:
        """τ = tau0 + torque_gain w for one wrench w (6,) or a list of them (m×6): (n,) or (m×n), N·m."""
        ws = _wrench_rows(w)
        out = self.tau0 + ws @ self.torque_gain.T
        return out[0] if np.ndim(w) == 1 else out


@dataclass(frozen=True, eq=False)
class ContactResponses:
    """:class:`ContactResponse` at N configurations, stacked along the first axis (same fields, shapes (N, ...)).

    ``X``, ``normal``, ``preload`` and ``friction`` are shared by every configuration.
    """

    q: Array
    q_s: Array
    tau0: Array
    f_c0: Array
    contact_gain: Array
    torque_gain: Array
    joint_gain: Array
    X: Array
    normal: Array
    preload: float
    friction: float | None

    def __len__(self) -> int:
        return int(self.q.shape[0])

    def at(self, i: int) -> ContactResponse:
        """The response at configuration i."""
        return ContactResponse(
            q=self.q[i],
            q_s=self.q_s[i],
            tau0=self.tau0[i],
            f_c0=self.f_c0[i],
            contact_gain=self.contact_gain[i],
            torque_gain=self.torque_gain[i],
            joint_gain=self.joint_gain[i],
            X=self.X,
            normal=self.normal,
            preload=self.preload,
            friction=self.friction,
        )


#: The largest tool-wrench component accepted (N, N·m): products of larger ones overflow float64.
MAX_WRENCH = 1e12
#: The largest preload accepted (N): beyond it no joint spring of a robot holds the brace.
MAX_PRELOAD = 1e6
#: The largest friction coefficient accepted: beyond it a contact simply sticks (μ² must also stay in float64).
MAX_FRICTION = 1e3


def check_preload(preload: object) -> float:
    """P as a float in [0, MAX_PRELOAD] N; InputError otherwise."""
    p = as_number(preload, "the preload P (the surface pushes on b)", nonnegative=True, unit="N")
    if p > MAX_PRELOAD:
        raise InputError(f"the preload P must be at most {MAX_PRELOAD:g} N, got {p:g}")
    return p


def check_friction(friction: object) -> float | None:
    """μ as a float ≥ 0, or None; InputError otherwise."""
    if friction is None:
        return None
    mu = as_number(friction, "the friction coefficient μ (omit it for no friction)", nonnegative=True)
    if mu > MAX_FRICTION:
        raise InputError(f"the friction coefficient μ must be at most {MAX_FRICTION:g} (it sticks), got {mu:g}")
    return mu


def load_contact_wrenches(brace: Brace, friction: float | None = None) -> Array:
    """X_L (6×c): what the brace's contact transmits under load with friction μ (``ContactType.load_wrenches``).

    A ``frictionless_point`` brace with μ > 0 transmits a 3-D force under load (it sticks); every shipped
    contact else keeps its own X.
    """
    return brace.kind.load_wrenches(brace.surface.frame, check_friction(friction))


def gravity_torque(robot: Robot, q: ArrayLike) -> Array:
    """g(q) (n,), N·m: the joint torques gravity exerts, Pinocchio's ``computeGeneralizedGravity``.

    The actuators hold the robot still by applying τ = g(q) (with no other load); ``robot.model.gravity``
    sets the field (−9.81 m/s² along world z by default).
    """
    qa = robot.check_q(q)
    _check_size(robot, "gravity torques")
    return np.asarray(pin.computeGeneralizedGravity(robot.model, robot.model.createData(), qa), dtype=float).copy()


def contact_response(
    braced: BracedRobot,
    q: ArrayLike,
    *,
    preload: float = 0.0,
    gravity: bool = False,
    friction: float | None = None,
    geometric: bool = True,
) -> ContactResponse:
    """The preloaded equilibrium at q and its first-order response to tool wrenches (module docstring).

    Args:
        braced: the braced robot.
        q: the commanded configuration (n,), rad; {b} is taken to touch the surface there.
        preload: P ≥ 0 (N), the normal force the surface exerts on b without tool load.
        gravity: include g(q) (Pinocchio's gravity field of the model).
        friction: μ ≥ 0; with μ > 0 a frictionless point brace sticks under load (3-D force). None: no friction.
        geometric: use the tangent stiffness K + ∂g/∂q − ∂(J_bᵀ f_c0)/∂q (True) or the joint stiffness K alone.

    Raises:
        InputError: a negative or non-finite preload or μ, or a configuration that is not n finite numbers.
        NumericalError: the tangent stiffness is not positive definite (gravity or the preload buckles the
            springs), or the result is not finite.
    """
    return contact_responses(braced, q, preload=preload, gravity=gravity, friction=friction, geometric=geometric).at(0)


def contact_responses(
    braced: BracedRobot,
    qs: ArrayLike,
    *,
    preload: float = 0.0,
    gravity: bool = False,
    friction: float | None = None,
    geometric: bool = True,
) -> ContactResponses:
    """:func:`contact_response` at each row of `qs` (N×n, or one configuration (n,)), with one solve per stack.

    The kinematics come from one Pinocchio pass per configuration; the linear algebra is batched.
    Directions in which chain 1 cannot push {b} carry no load (dropped, with one UnloadedContactWarning).
    """
    if not isinstance(braced, BracedRobot):
        raise InputError(f"expected a BracedRobot, got {type(braced).__name__}")
    robot = braced.robot
    p = check_preload(preload)
    mu = check_friction(friction)
    for flag, name in ((gravity, "gravity"), (geometric, "geometric")):
        if not isinstance(flag, bool):
            raise InputError(f"{name} must be True or False, got {show(flag)}")
    q_all = configurations(robot, qs)
    n, count = robot.n, q_all.shape[0]
    nhat = braced.split.brace.surface.normal
    f_c0 = np.concatenate([p * nhat, np.zeros(3)])
    x_l = load_contact_wrenches(braced.split.brace, mu)
    k = robot.stiffness
    hessians = geometric and p > 0.0
    if gravity or hessians:
        _check_size(robot, "gravity torques and geometric stiffness")
    data = robot.model.createData() if gravity else None

    j_e = np.empty((count, 6, n))
    j_b = np.empty((count, 6, n))
    g = np.zeros((count, n))
    k_t = np.zeros((count, n, n))
    k_t[:, np.arange(n), np.arange(n)] = k
    for i, q in enumerate(q_all):
        st = braced.state(q, hessians=hessians)
        j_e[i], j_b[i] = st.J_e, st.split.J_b
        if data is not None:
            if geometric:
                dg = pin.computeGeneralizedGravityDerivatives(robot.model, data, q)
                k_t[i] += np.asarray(dg, dtype=float)  # ∂g/∂q: the Hessian of the potential energy
            g[i] = pin.computeGeneralizedGravity(robot.model, data, q)
        if hessians and st.split.dJ_b is not None:
            k_t[i] -= np.einsum("r,rik->ik", f_c0, st.split.dJ_b)
    k_env = braced.split.brace.environment_stiffness
    with finite_math("the contact response"):
        k_t = 0.5 * (k_t + np.swapaxes(k_t, 1, 2))
        tau0 = g - np.einsum("nri,r->ni", j_b, f_c0)
        q_s = q_all + tau0 / k
        a = np.swapaxes(j_b, 1, 2) @ x_l  # (N, n, c): J_bᵀ X_L
        rho = _augmentation(k_t, a, k_env)
        k_aug = k_t + rho[:, None, None] * (a @ np.swapaxes(a, 1, 2))
        rhs = np.concatenate([np.swapaxes(j_e, 1, 2), a, np.swapaxes(j_b, 1, 2)], axis=2)
        sol = np.linalg.solve(k_aug, rhs)
        c = a.shape[2]
        kj_e, ka, kj_b = sol[:, :, :6], sol[:, :, 6 : 6 + c], sol[:, :, 6 + c :]
        schur = np.swapaxes(a, 1, 2) @ ka
        schur = 0.5 * (schur + np.swapaxes(schur, 1, 2))
        c1_trace = np.einsum("nri,nir->n", j_b, kj_b)  # tr(J_b K⁻¹ J_bᵀ): the scale of "unloaded"
        if k_env is None:
            gain, unloaded = loaded_gain(schur, c1_trace)
        else:  # with ρ a aᵀ in the stiffness, the surface's stiffness seen by the multiplier is k_env − ρ
            inv_k = 1.0 / (k_env - rho)
            gain = np.asarray(np.linalg.inv(schur + inv_k[:, None, None] * np.eye(c)), dtype=np.float64)
            unloaded = np.zeros(count, dtype=int)
        mult = -gain @ (np.swapaxes(a, 1, 2) @ kj_e)  # (N, c, 6): the augmented multiplier per unit w
        joint_gain = kj_e + ka @ mult
        lam = mult - rho[:, None, None] * (np.swapaxes(a, 1, 2) @ joint_gain)  # δλ = μ' − ρ aᵀ δq
        contact_gain = x_l @ lam
        torque_gain = -k[None, :, None] * joint_gain
    if np.any(unloaded):
        warn_unloaded(int(np.count_nonzero(unloaded)), None if count == 1 else count, stacklevel=3)
    out = ContactResponses(
        q=q_all,
        q_s=q_s,
        tau0=tau0,
        f_c0=np.broadcast_to(f_c0, (count, 6)).copy(),
        contact_gain=contact_gain,
        torque_gain=torque_gain,
        joint_gain=joint_gain,
        X=x_l,
        normal=nhat.copy(),
        preload=p,
        friction=mu,
    )
    for arr in (q_s, contact_gain, torque_gain, joint_gain):
        if not np.all(np.isfinite(arr)):
            raise NumericalError("the contact response is not finite; use SI units and moderate values")
    return out


def configurations(robot: Robot, qs: ArrayLike) -> Array:
    """`qs` as an N×n float array (one configuration (n,) gives N = 1); InputError if not finite numbers."""
    a = as_array(qs, "the configurations (N×n, rad)")
    if a.ndim == 1:
        a = a[None, :]
    if a.ndim != 2 or a.shape[1] != robot.n or a.shape[0] == 0:
        raise InputError(
            f"the configurations must be an N×{robot.n} array (one row of {robot.n} joint values each, N ≥ 1), "
            f"got shape {np.shape(qs)}"
        )
    return a


def wrench_list(wrenches: ArrayLike, what: str = "the tool wrenches") -> Array:
    """`wrenches` as an m×6 float array ([f; m] rows, N and N·m, at e, world axes); one (6,) gives m = 1."""
    a = as_array(wrenches, f"{what} ([f; m] rows, N and N·m)")
    if a.ndim == 1:
        a = a[None, :]
    if a.ndim != 2 or a.shape[1] != 6 or a.shape[0] == 0:
        raise InputError(f"{what} must be an m×6 array of [f; m] rows (m ≥ 1), got shape {np.shape(wrenches)}")
    if np.max(np.abs(a)) > MAX_WRENCH:
        raise InputError(f"{what} must be at most {MAX_WRENCH:g} N and N·m in every component (SI units)")
    return a


def _wrench_rows(w: ArrayLike) -> Array:
    return wrench_list(w, "the tool wrench")


def _check_size(robot: Robot, what: str) -> None:
    if robot.n > MAX_HESSIAN_JOINTS:
        raise ModelError(
            f"{what} support up to {MAX_HESSIAN_JOINTS} joints (Pinocchio's data grows as n³), the robot has "
            f"{robot.n}; use gravity=False and geometric=False or a shorter chain"
        )


def _augmentation(k_t: Array, a: Array, k_env: float | None) -> Array:
    """ρ (N,) ≥ 0 with K_t + ρ a aᵀ positive definite; NumericalError where none exists (an unstable equilibrium).

    Where K_t itself is positive definite ρ = 0. Otherwise the contact must stabilise the robot: K_t is positive
    definite on the motions it allows (rigid) or K_t + k_env a aᵀ is. Adding ρ a aᵀ changes only the
    multiplier (augmented Lagrangian), which the caller undoes: δλ = μ' − ρ aᵀ δq.
    """
    low = np.linalg.eigvalsh(k_t)[:, 0]
    rho = np.zeros(k_t.shape[0])
    for i in np.flatnonzero(~(low > 0.0)):
        scale = float(np.max(np.abs(k_t[i])))
        aa = np.linalg.eigvalsh(a[i].T @ a[i])
        trial = 1e3 * scale / max(float(aa[0]), 1e-300)
        if k_env is not None:
            trial = min(trial, 0.5 * k_env)
        low_aug = float(np.linalg.eigvalsh(k_t[i] + trial * a[i] @ a[i].T)[0])
        if not low_aug > 1e-9 * scale:
            raise UnstableEquilibriumError(
                f"the braced equilibrium is unstable at configuration {int(i)}: the tangent stiffness "
                f"K + ∂g/∂q − ∂(J_bᵀ f_c0)/∂q (smallest eigenvalue {low[i]:.3g} N·m/rad) is not positive on the "
                "motions the contact allows; use stiffer joints or a smaller preload"
            )
        rho[i] = trial
    return rho
