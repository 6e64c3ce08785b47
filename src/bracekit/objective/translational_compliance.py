"""The translational compliance c_t = βᵀ C_e,tt β along a unit translation β (m/N), docs/model.md section 11.

Beside α2's C_i (:mod:`bracekit.objective.compliance_index`, the paper's index with mixed units) this term
minimises what a probe pushing along β measures: the tip displacement along β per newton along β. With
β_x = [β; 0] it is β_xᵀ C_e β_x, a quadratic form of C_e, so its gradient is the bilinear derivative
aᵀ (∂C_e/∂q) b of :func:`bilinear_gradient` with a = b = β_x, exact through the kinematic Hessians.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike

from bracekit._linalg import as_array, cross3
from bracekit.compliance.directional import translational_direction
from bracekit.compliance.first_order import (
    ComplianceModel,
    braced_c1_unchecked,
    c1_unchecked,
    check_finite,
    check_model,
    constraint_gain,
    end_effector_compliance,
)
from bracekit.kinematics import BracedState
from bracekit.objective.base import Array, Term, TermContext, contract, hessians, register_term


@np.errstate(all="ignore")  # an overflow raises NumericalError (check_finite), not a RuntimeWarning
def bilinear_gradient(state: BracedState, model: ComplianceModel, a: Array, b: Array) -> Array:
    """∂(aᵀ C_e b)/∂q (n,) for constant twists a, b (6,) and C_e of eq:Ce in `model`, exact through the Hessians.

    C_e = S_t1 C̃1 S_t1ᵀ + J_e2 K2⁻¹ J_e2ᵀ (J_e2 = S_t2 J2, chain 2's columns of J_e). Three parts move with q:
    J_e2 (against ∂J_e), S_t1 through b − e, and C̃1 through C1 = J1 K1⁻¹ J1ᵀ with the model's projector held
    (d C̃1 = T dC1 Tᵀ, T = I − P for ``projection`` and I − C1 X G Xᵀ for ``constrained``, which holds with a
    finite k_env too). The state needs ``hessians=True``.
    """
    d_je, d_jb = hessians(state)
    n1, n = state.n1, state.q.size
    c1 = c1_unchecked(state)
    c1t = braced_c1_unchecked(state, model, c1)
    s1 = state.S_t1
    # chain 2: aᵀ dJ K2⁻¹ J_e2ᵀ b + bᵀ dJ K2⁻¹ J_e2ᵀ a against ∂J_e, columns n1…
    j_e2, k2 = state.J_e[:, n1:], state.K[n1:]
    u = np.zeros((6, n))
    u[:, n1:] = np.outer(a, (j_e2.T @ b) / k2) + np.outer(b, (j_e2.T @ a) / k2)
    grad = contract(d_je, u)
    # S_t1 depends on b − e
    a1, b1 = s1.T @ a, s1.T @ b
    w = cross3((c1t @ b1)[3:], a[:3]) + cross3((c1t @ a1)[3:], b[:3])
    grad += (state.J_b[:3] - state.J_e[:3]).T @ w
    # C̃1 through C1, the model's projector held
    if model == "projection":
        t = np.eye(6) - state.P
    else:
        x = state.X
        t = np.eye(6) - x @ constraint_gain(state, c1) @ x.T @ c1  # (I − P_C)ᵀ
    ah, bh = t @ a1, t @ b1
    j1, k1 = state.J1, state.K[:n1]
    u = np.zeros((6, n))
    u[:, :n1] = np.outer(ah, (j1.T @ bh) / k1) + np.outer(bh, (j1.T @ ah) / k1)
    grad += contract(d_jb, u)
    return check_finite(grad, "the gradient of a directional compliance")


@register_term
@dataclass(frozen=True)
class TranslationalCompliance(Term):
    """c_t = βᵀ C_e,tt β (m/N) for a fixed unit translation β_x = [β; 0] and a compliance model.

    β_x must be translational (InputError otherwise); the scenario key is ``ct`` in
    ``[gradient_projection.weights]``, and the term follows the task's β_x as C_i does.
    """

    beta_x: Array
    model: ComplianceModel = "constrained"
    name: str = "c_t"
    key = "ct"

    def __post_init__(self) -> None:
        super().__post_init__()
        beta = translational_direction(self.beta_x)
        object.__setattr__(self, "beta_x", np.concatenate([beta, np.zeros(3)]))
        check_model(self.model)

    def with_beta_x(self, beta_x: ArrayLike) -> TranslationalCompliance:
        """The term with β_x replaced by a new translational direction (3 or 6 numbers)."""
        return replace(self, beta_x=as_array(beta_x, "beta_x", finite=False))  # checked by __post_init__

    def value(self, state: BracedState) -> float:
        """c_t at the state, m/N."""
        beta = self.beta_x
        return float(check_finite(beta @ end_effector_compliance(state, self.model) @ beta, "c_t"))

    def gradient(self, state: BracedState) -> Array:
        """∂c_t/∂q (n,), exact through the state's kinematic Hessians."""
        return bilinear_gradient(state, self.model, self.beta_x, self.beta_x)

    @classmethod
    def from_scenario(cls, context: TermContext) -> TranslationalCompliance:
        """The term as a scenario configures it (its weight key is ``key``)."""
        return cls(context.beta_x, check_model(context.compliance_model))
