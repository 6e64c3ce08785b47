"""Redundancy resolution (Section V): joint velocities q̇ (n,) for a desired tip twist ẋ (6,).

* :class:`FreeSpaceMinNorm`: q̇ = J⁺ ẋ, the unbraced robot.
* :class:`BracedMinNorm`: [ḃ; q̇2] = A⁺ ẋ (eq:general_inv with η = 0), q̇1 = J1⁻¹ H ḃ (eq:q1).
* :class:`BracedGradientProjection`: [ḃ; q̇2] = A⁺ ẋ + (I − A⁺A) α ∇g (eq:grad_proj), α < 0.

Each takes a :class:`~bracekit.resolution.task_space.TaskSpace` (``space``, the full pose by default) and
resolves its selected rows S(⁰R_e) only: J and A above become S J and S A, ẋ becomes S ẋ.

The braced strategies act over coordinates y of the braced motions (``state.motions``,
:mod:`bracekit.kinematics.motions`), q̇ = M y and A = J_e M: with one brace the paper's (b̃, q2) and A; with
several the null space N of the stacked constraint G, A = J_e N, and ∇g = Nᵀ ∂g/∂q. The objective's terms give
∂g/∂q for any number of braces (analytic, or central differences in the finite-difference mode).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Literal, Protocol, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from bracekit._linalg import as_array, as_number, show
from bracekit.errors import InputError, NumericalError, SingularityError
from bracekit.kinematics import BracedState
from bracekit.objective import Objective, finite_difference_gradient
from bracekit.resolution.task_space import POSE, TaskSpace, select
from bracekit.tolerances import STEP_SINGULAR_RATIO

Array = NDArray[np.float64]
GradientMode = Literal["analytic", "finite-difference"]
GRADIENT_MODES: tuple[str, ...] = ("analytic", "finite-difference")


def pinv_checked(m: Array, what: str) -> Array:
    """Moore–Penrose pseudo-inverse of a full-row-rank matrix; SingularityError near rank loss."""
    u, s, vt = np.linalg.svd(m, full_matrices=False)
    if s[-1] <= STEP_SINGULAR_RATIO * s[0]:
        raise SingularityError(f"{what} is singular (σ_min/σ_max = {s[-1] / max(s[0], 1e-300):.2e})")
    return cast(Array, (vt.T / s) @ u.T)


class Strategy(Protocol):
    """A redundancy-resolution strategy (read-only attributes: frozen dataclasses satisfy it)."""

    @property
    def name(self) -> str:
        """The strategy's name, as in scenario files."""
        ...

    @property
    def braced(self) -> bool:
        """Whether it keeps the contact (q̇ from A⁺ and eq:q1) rather than ignoring the brace."""
        ...

    @property
    def needs_hessians(self) -> bool:
        """Whether `velocity` needs the state's kinematic Hessians."""
        ...

    def velocity(self, state: BracedState, xdot: Array) -> Array:
        """Joint velocities q̇ (n,) that realise the tip twist ẋ (6,)."""
        ...


@dataclass(frozen=True)
class FreeSpaceMinNorm:
    """q̇ = J⁺ ẋ: the robot ignores the brace."""

    name: str = "free_space_min_norm"
    braced: bool = False
    needs_hessians: bool = False
    space: TaskSpace = POSE

    def velocity(self, state: BracedState, xdot: Array) -> Array:
        """Joint velocities q̇ (n,) that realise the selected rows of the tip twist ẋ (6,) at the state."""
        j, x = select(self.space, state.R_e, state.J_e, tip_twist(xdot))
        return finite_rates(pinv_checked(j, "the Jacobian J") @ x)


def with_beta_x(strategy: Strategy, beta_x: ArrayLike) -> Strategy:
    """The strategy with the β_x of its objective's compliance-index terms replaced (itself if it has none)."""
    objective = getattr(strategy, "objective", None)
    if objective is None:
        return strategy
    new = objective.with_beta_x(beta_x)
    return strategy if new is objective else replace(strategy, objective=new)  # type: ignore[type-var]


#: Largest tip twist component accepted (m/s, rad/s): far beyond any robot, small enough that J⁺ẋ cannot overflow.
MAX_TIP_TWIST = 1e12


def tip_twist(xdot: ArrayLike) -> Array:
    """ẋ as a finite (6,) float array [v; ω] (m/s, rad/s), each |component| ≤ MAX_TIP_TWIST; InputError otherwise."""
    if type(xdot) is np.ndarray and xdot.dtype == np.float64 and xdot.shape == (6,):  # the control loop's case
        values = xdot.tolist()
        if math.isfinite(sum(values)) and max(map(abs, values)) <= MAX_TIP_TWIST:  # else checked below
            return xdot
    x = as_array(xdot, "the tip twist ẋ [v; ω]", (6,))
    big = float(np.max(np.abs(x)))
    if big > MAX_TIP_TWIST:
        raise InputError(
            f"the tip twist ẋ [v; ω] has a component of magnitude {big:.3g}: give at most {MAX_TIP_TWIST:.0e} "
            "(m/s, rad/s)"
        )
    return x


def finite_rates(qdot: Array) -> Array:
    """q̇ itself if finite; NumericalError otherwise (a twist or gain so large that the rates overflow)."""
    if not np.all(np.isfinite(qdot)):
        raise NumericalError("the joint velocities are not finite: the tip twist or the gains are too large")
    return qdot


@dataclass(frozen=True)
class BracedMinNorm:
    """[ḃ; q̇2] = A⁺ ẋ, then q̇1 = J1⁻¹ H ḃ: keeps the contact, minimum norm in (b̃, q2).

    With several braces: q̇ = N (S J_e N)⁺ S ẋ, the least-norm q̇ keeping every contact.
    """

    name: str = "braced_min_norm"
    braced: bool = True
    needs_hessians: bool = False
    space: TaskSpace = POSE

    def velocity(self, state: BracedState, xdot: Array) -> Array:
        """Joint velocities q̇ (n,) that realise the selected rows of the tip twist ẋ (6,) at the state."""
        motions = state.motions
        a, x = select(self.space, state.R_e, motions.A, tip_twist(xdot))
        return finite_rates(motions.to_joint(motions.inverse(a) @ x))


@dataclass(frozen=True)
class BracedGradientProjection:
    """eq:grad_proj: A⁺ ẋ + (I − A⁺A) α ∇g, ∇g of eq:grad_g; analytic or finite-difference gradient.

    With several braces: q̇ = N [B⁺ S ẋ + α (I − B⁺B) Nᵀ ∂g/∂q], B = S J_e N, with ∂g/∂q of the same objective
    (analytic through the kinematic Hessians of J_e and every J_b_i, or central differences with `fd_step`).
    """

    objective: Objective
    alpha: float = -1.0
    gradient: GradientMode = "analytic"
    fd_step: float = 1e-5
    name: str = "braced_gradient_projection"
    braced: bool = True
    space: TaskSpace = POSE

    def __post_init__(self) -> None:
        if not isinstance(self.objective, Objective):
            raise InputError(f"the objective must be a bracekit Objective, got {type(self.objective).__name__}")
        alpha = as_number(self.alpha, "the gradient-projection gain alpha")
        as_number(self.fd_step, "the finite-difference step fd_step", positive=True, unit="rad")
        if alpha >= 0:
            raise InputError(f"the gradient-projection gain alpha must be negative (it descends g), got {alpha}")
        if not isinstance(self.gradient, str) or self.gradient not in GRADIENT_MODES:
            raise InputError(f"unknown gradient mode {show(self.gradient)}; choose one of {', '.join(GRADIENT_MODES)}")
        if not isinstance(self.space, TaskSpace):
            raise InputError(f"space must be a TaskSpace, got {show(self.space)}")

    @property
    def needs_hessians(self) -> bool:
        """Whether the analytic gradient (kinematic Hessians) is used."""
        return self.gradient == "analytic"

    def dg_dq(self, state: BracedState) -> Array:
        """∂g/∂q (n,) in the chosen gradient mode, for any number of braces."""
        if self.gradient == "analytic":
            return self.objective.gradient(state)
        return finite_difference_gradient(state.braced, self.objective.value, state.q, self.fd_step)

    def velocity(self, state: BracedState, xdot: ArrayLike) -> Array:
        """Joint velocities q̇ (n,) that realise the selected rows of the tip twist ẋ (6,) at the state."""
        motions = state.motions
        a, x = select(self.space, state.R_e, motions.A, tip_twist(xdot))
        a_pinv = motions.inverse(a)
        grad = motions.gradient(self.dg_dq(state))
        null = grad - a_pinv @ (a @ grad)
        return finite_rates(motions.to_joint(a_pinv @ x + self.alpha * null))
