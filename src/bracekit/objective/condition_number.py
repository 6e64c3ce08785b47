"""α1's term: the Frobenius condition number k of the free-space Jacobian J (eq:manip, eq:J)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from bracekit.compliance.measures import frobenius_condition
from bracekit.kinematics import BracedRobot, BracedState
from bracekit.objective.base import Array, Term, TermContext, contract, hessians, register_term
from bracekit.objective.fused import FusedGradient, FusedKinematics


@register_term
@dataclass(frozen=True)
class ConditionNumber(Term):
    """k = √(tr(JJᵀ) tr((JJᵀ)⁻¹)) / 6 of the free-space J = J_e (eq:manip); 1 when isotropic.

    The same for any number of braces (J_e does not depend on them); the measure k of a run is that of the braced
    task Jacobian instead (docs/model.md).
    """

    name: str = "k"
    key = "k"

    def value(self, state: BracedState) -> float:
        """The term's value at the state (the class docstring gives its units)."""
        return frobenius_condition(state.J_e)

    def gradient(self, state: BracedState) -> Array:
        """∂value/∂q (n,), exact through the state's kinematic Hessians."""
        d_je, _ = hessians(state)
        j = state.J_e
        k = frobenius_condition(j)
        m_inv = np.linalg.inv(j @ j.T)
        a, b = float(np.sum(j * j)), float(np.trace(m_inv))
        # (b da + a db) / (72 k) with da = 2 Σ J ∂J, db = −2 Σ (M⁻¹M⁻¹J) ∂J, M = JJᵀ
        return contract(d_je, (2.0 * b) * j - (2.0 * a) * (m_inv @ m_inv @ j)) / (72.0 * k)

    def fused_value(self, kin: FusedKinematics) -> float:
        """The value from the fused step's kinematics (the same as :meth:`value`)."""
        a, bb, _ = kin.frobenius()
        return float(np.sqrt(a * bb) / 6.0)

    def fused_gradient(self, kin: FusedKinematics, weight: float, out: FusedGradient) -> bool:
        """Add weight · ∂value/∂q to the fused step's accumulator; True when done here."""
        a, bb, m2j = kin.frobenius()  # (b da + a db) / (72 k), as gradient()
        c = weight / (6.0 * math.sqrt(a * bb))
        out.add_ue(kin.je * (c * bb) - m2j * (c * a))
        return True

    def numba_params(self, braced: BracedRobot, weight: float) -> tuple[str, list[float]]:
        """(kind, parameters) of the numba kernel's compiled copy of this term."""
        return "k", [weight]

    @classmethod
    def from_scenario(cls, context: TermContext) -> ConditionNumber:
        """The term as a scenario configures it (its weight key is ``key``)."""
        return cls()
