"""The translational compliance c_t = βᵀ C_e,tt β along a unit translation β (m/N), docs/model.md section 11.

Beside α2's C_i (:mod:`bracekit.objective.compliance_index`, the paper's index with mixed units) this term
minimises what a probe pushing along β measures: the tip displacement along β per newton along β. With
β_x = [β; 0] it is β_xᵀ C_e β_x, a quadratic form of C_e, so its gradient is the bilinear derivative
aᵀ (∂C_e/∂q) b of :func:`~bracekit.objective.compliance_gradient.bilinear_gradient` with a = b = β_x, exact
through the kinematic Hessians.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bracekit.compliance.directional import translational_direction
from bracekit.compliance.first_order import check_finite, end_effector_compliance
from bracekit.kinematics import BracedState
from bracekit.objective.base import Array, register_term
from bracekit.objective.compliance_gradient import bilinear_gradient
from bracekit.objective.compliance_index import DirectionalTerm


@register_term
@dataclass(frozen=True)
class TranslationalCompliance(DirectionalTerm):
    """c_t = βᵀ C_e,tt β (m/N) for a fixed unit translation β_x = [β; 0] and a compliance model.

    β_x must be translational (InputError otherwise); the scenario key is ``ct`` in
    ``[gradient_projection.weights]``, and the term follows the task's β_x as C_i does.
    """

    name: str = "c_t"
    key = "ct"

    def direction(self, beta_x: Array) -> Array:
        """β_x as [β; 0] with β a unit translation (3 or 6 numbers given)."""
        return np.concatenate([translational_direction(beta_x), np.zeros(3)])

    def value(self, state: BracedState) -> float:
        """c_t at the state, m/N."""
        beta = self.beta_x
        return float(check_finite(beta @ end_effector_compliance(state, self.model) @ beta, "c_t"))

    def gradient(self, state: BracedState) -> Array:
        """∂c_t/∂q (n,), exact through the state's kinematic Hessians."""
        return bilinear_gradient(state, self.model, self.beta_x, self.beta_x)
