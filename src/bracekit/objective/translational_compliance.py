"""The translational compliance c_t = βᵀ C_e,tt β along a unit translation β (m/N), docs/model.md section 11.

Beside α2's C_i (:mod:`bracekit.objective.compliance_index`, the paper's index with mixed units) this term
minimises what a probe pushing along β measures: the tip displacement along β per newton along β. With
β_x = [β; 0] it is β_xᵀ C_e β_x, a quadratic form of C_e, so its gradient is the bilinear derivative
aᵀ (∂C_e/∂q) b of :func:`~bracekit.objective.compliance_gradient.bilinear_gradient` with a = b = β_x, exact
through the kinematic Hessians.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike

from bracekit._linalg import as_array
from bracekit.compliance.directional import translational_direction
from bracekit.compliance.first_order import ComplianceModel, check_finite, check_model, end_effector_compliance
from bracekit.kinematics import BracedState
from bracekit.objective.base import Array, Term, TermContext, register_term
from bracekit.objective.compliance_gradient import bilinear_gradient


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
