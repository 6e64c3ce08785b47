"""The objective g of the braced gradient projection (eq:objective) with analytic gradients.

Each term maps a :class:`BracedState` to a value and to ∂/∂q (n,), exact through Pinocchio's kinematic
Hessians (the state must be computed with ``hessians=True``). :func:`finite_difference_gradient` is the
paper's reference (central differences, δq = 1e-5 rad; :func:`central_difference`). :func:`braced_gradient`
maps ∂g/∂q to ∇g = [(∂g/∂q1) dq1/db̃, ∂g/∂q2]ᵀ (eq:grad_g).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ._linalg import cross3
from .compliance import C1 as chain1_compliance
from .compliance import (
    ComplianceModel,
    _unit6,
    braced_C1,
    check_finite,
    check_model,
    constraint_gain,
    end_effector_compliance,
)
from .errors import BarrierError, InputError
from .kinematics import BracedRobot, BracedState
from .measures import frobenius_condition, region_barrier, theta_z

Array = NDArray[np.float64]


class Term(Protocol):
    """A scalar measure of the braced robot with its exact gradient."""

    name: str

    def value(self, state: BracedState) -> float:
        """The measure at the state."""
        ...

    def gradient(self, state: BracedState) -> Array:
        """∂value/∂q (n,); needs the state's Hessians."""
        ...


def _hessians(state: BracedState) -> tuple[Array, Array]:
    if state.dJ_e is None or state.dJ_b is None:
        raise InputError("analytic gradients need the kinematic Hessians: compute the state with hessians=True")
    return state.dJ_e, state.dJ_b


def _contract(d_j: Array, u: Array) -> Array:
    """Σ_{r,i} u[r, i] ∂J[r, i]/∂q_k (n,) for a Hessian d_j (6, n, n) and coefficients u (6, n)."""
    n = d_j.shape[2]
    return u.ravel() @ d_j.reshape(-1, n)


@dataclass(frozen=True)
class ConditionNumber:
    """α1's term: Frobenius condition number k of the free-space J (eq:manip, eq:J)."""

    name: str = "k"

    def value(self, state: BracedState) -> float:
        return frobenius_condition(state.J_e)

    def gradient(self, state: BracedState) -> Array:
        d_je, _ = _hessians(state)
        j = state.J_e
        k = frobenius_condition(j)
        m_inv = np.linalg.inv(j @ j.T)
        a, b = float(np.sum(j * j)), float(np.trace(m_inv))
        # (b da + a db) / (72 k) with da = 2 Σ J ∂J, db = −2 Σ (M⁻¹M⁻¹J) ∂J, M = JJᵀ
        return _contract(d_je, (2.0 * b) * j - (2.0 * a) * (m_inv @ m_inv @ j)) / (72.0 * k)


@dataclass(frozen=True)
class ComplianceIndex:
    """α2's term: C_i = ‖β_xᵀ C_e‖ (eq:compliance_index) for a fixed unit twist β_x (6,)."""

    beta_x: Array
    model: ComplianceModel = "constrained"
    name: str = "Ci"

    def __post_init__(self) -> None:
        object.__setattr__(self, "beta_x", _unit6(self.beta_x, "beta_x"))
        check_model(self.model)

    def value(self, state: BracedState) -> float:
        return float(np.linalg.norm(self.beta_x @ end_effector_compliance(state, self.model)))

    def gradient(self, state: BracedState) -> Array:
        d_je, d_jb = _hessians(state)
        n1 = state.n1
        beta = self.beta_x
        c1 = chain1_compliance(state)
        c1t = braced_C1(state, self.model)
        s1 = state.S_t1
        # chain 2: S_t2 C2 S_t2ᵀ = J_e2 K2⁻¹ J_e2ᵀ with J_e2 = S_t2 J2 = J_e[:, n1:]
        j_e2 = state.J_e[:, n1:]
        k2 = state.K[n1:]
        v = beta @ (s1 @ c1t @ s1.T + (j_e2 / k2) @ j_e2.T)
        ci = float(check_finite(np.linalg.norm(v), "the compliance index"))
        if ci == 0.0:
            return np.zeros(state.q.size)
        # chain 2: β ⊗ (J_e2ᵀ v / k2) + v ⊗ (J_e2ᵀ β / k2) against ∂J_e, columns n1…
        u = np.zeros((6, state.q.size))
        u[:, n1:] = np.outer(beta, (j_e2.T @ v) / k2) + np.outer(v, (j_e2.T @ beta) / k2)
        grad = _contract(d_je, u)
        # S_t1 depends on b − e
        b1, v1 = s1.T @ beta, s1.T @ v
        w = cross3((c1t @ v1)[3:], beta[:3]) + cross3((c1t @ b1)[3:], v[:3])
        grad += (state.J_b[:3] - state.J_e[:3]).T @ w
        # C̃1 through C1: β̂ᵀ dC1 v̂ with the model's (constant or compliance-weighted) projector
        if self.model == "projection":
            t = np.eye(6) - state.P
            bh, vh = t @ b1, t @ v1
        else:
            x = state.X
            tt = np.eye(6) - x @ constraint_gain(state, c1) @ x.T @ c1  # (I − P_C)ᵀ
            bh, vh = tt @ b1, tt @ v1
        j1, k1 = state.J1, state.K[:n1]
        u = np.zeros((6, state.q.size))
        u[:, :n1] = np.outer(bh, (j1.T @ vh) / k1) + np.outer(vh, (j1.T @ bh) / k1)
        grad += _contract(d_jb, u)
        return grad / ci


@dataclass(frozen=True)
class BraceAngle:
    """α3's term: θ_z = acos(ẑ_tᵀ ẑ_b) (eq:theta), rad. Its gradient is 0 where θ_z = 0 (a cone point)."""

    name: str = "theta_z"

    def value(self, state: BracedState) -> float:
        return theta_z(state.braced.brace.surface.normal, state.z_b)

    def gradient(self, state: BracedState) -> Array:
        u = cross3(state.braced.brace.surface.normal, state.z_b)
        s = float(np.linalg.norm(u))
        if s < 1e-12:
            return np.zeros(state.q.size)
        return state.J_b[3:].T @ (u / s)


@dataclass(frozen=True)
class RegionBarrier:
    """α4's term: d = r_max² / (r_max² − r²), r = ‖p_b − p_t‖ (after eq:theta). Raises BarrierError at r_max."""

    r_max: float
    centre: Array
    name: str = "d"

    def __post_init__(self) -> None:
        if not (np.isfinite(self.r_max) and self.r_max > 0):
            raise InputError(f"r_max must be a positive length (m), got {self.r_max}")
        object.__setattr__(self, "centre", np.asarray(self.centre, dtype=float).reshape(3))

    def radius(self, state: BracedState) -> float:
        """r, m."""
        return float(np.linalg.norm(state.b - self.centre))

    def value(self, state: BracedState) -> float:
        return region_barrier(self.radius(state), self.r_max)

    def gradient(self, state: BracedState) -> Array:
        rel = state.b - self.centre
        r2 = float(rel @ rel)
        if r2 >= self.r_max**2:
            raise BarrierError(f"the bracing point is outside the bracing region (r = {np.sqrt(r2):.4g} m)")
        return (self.r_max**2 / (self.r_max**2 - r2) ** 2) * 2.0 * (state.J_b[:3].T @ rel)


@dataclass(frozen=True)
class Objective:
    """g = Σ α_i term_i (eq:objective): any terms, any non-negative weights."""

    terms: Sequence[Term]
    weights: Sequence[float]
    names: tuple[str, ...] = field(init=False)

    def __post_init__(self) -> None:
        if len(self.terms) != len(self.weights):
            raise InputError("an objective needs one weight per term")
        for t, w in zip(self.terms, self.weights, strict=True):
            if not np.isfinite(w) or w < 0:
                raise InputError(f"the weight of term '{t.name}' must be a non-negative number, got {w}")
        object.__setattr__(self, "names", tuple(t.name for t in self.terms))

    def value(self, state: BracedState) -> float:
        """g at the state."""
        return float(sum(w * t.value(state) for t, w in zip(self.terms, self.weights, strict=True) if w))

    def values(self, state: BracedState) -> dict[str, float]:
        """Each term's value (unweighted)."""
        return {t.name: t.value(state) for t in self.terms}

    def with_beta_x(self, beta_x: ArrayLike) -> Objective:
        """The objective with β_x of every compliance-index term replaced (itself if it has none)."""
        if not any(isinstance(t, ComplianceIndex) for t in self.terms):
            return self
        terms = [replace(t, beta_x=beta_x) if isinstance(t, ComplianceIndex) else t for t in self.terms]
        return Objective(terms, self.weights)

    def gradient(self, state: BracedState) -> Array:
        """∂g/∂q (n,), analytic."""
        out = np.zeros(state.q.size)
        for t, w in zip(self.terms, self.weights, strict=True):
            if w:
                out += w * t.gradient(state)
        return out


def central_difference(fn: Callable[[Array], float], q: Array, step: float = 1e-5) -> Array:
    """(fn(q + δ e_i) − fn(q − δ e_i)) / (2δ) for each joint i, δ = step (rad): the paper's ∂g/∂q."""
    out = np.empty(q.size)
    for i in range(q.size):
        dq = np.zeros(q.size)
        dq[i] = step
        out[i] = (fn(q + dq) - fn(q - dq)) / (2.0 * step)
    return out


def finite_difference_gradient(
    braced: BracedRobot, fn: Callable[[BracedState], float], q: ArrayLike, step: float = 1e-5
) -> Array:
    """Central differences of fn over q, δq = step (rad); the paper's ∂g/∂q."""
    return central_difference(lambda x: fn(braced.state(x)), braced.robot.check_q(q), step)


def braced_gradient(state: BracedState, dg_dq: ArrayLike) -> Array:
    """∇g over [b̃; q2] from ∂g/∂q (eq:grad_g): [(∂g/∂q1) dq1/db̃, ∂g/∂q2]ᵀ, shape (l + n2,)."""
    g = np.asarray(dg_dq, dtype=float)
    n1 = state.n1
    return np.concatenate([state.chain1_map.T @ g[:n1], g[n1:]])
