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

from bracekit._linalg import as_array, as_number
from bracekit.contact import Brace
from bracekit.errors import (
    InputError,
    ModelError,
)
from bracekit.kinematics.braced import MAX_HESSIAN_JOINTS
from bracekit.model.robot import Robot

Array = NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class LoadResponse:
    """The preloaded equilibrium and its first-order response to a tool wrench w: what every view of it holds.

    Attributes (one configuration; :class:`~bracekit.statics.stacked.ContactResponses` stacks them over N
    configurations and B braces):
        q: the commanded configuration, rad; q_s: spring set points q + K⁻¹ τ0, rad.
        tau0: actuator torques without tool load, N·m; f_c0: contact wrench without tool load, N and N·m.
        contact_gain, torque_gain, joint_gain: δf_c, δτ and δq per unit tool wrench (first order).
    """

    q: Array
    q_s: Array
    tau0: Array
    f_c0: Array
    contact_gain: Array
    torque_gain: Array
    joint_gain: Array


@dataclass(frozen=True, eq=False)
class ContactResponse(LoadResponse):
    """One brace's view of the preloaded equilibrium at one configuration q and its first-order load response.

    With several braces the record holds one brace's contact wrench; τ, q_s and δq are those of every brace
    together (:class:`~bracekit.statics.stacked.ContactResponses`).

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
