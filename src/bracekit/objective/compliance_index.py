"""α2's term: the compliance index C_i = ‖β_xᵀ C_e‖ (eq:compliance_index) along a unit twist β_x."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Self

import numpy as np
from numpy.typing import ArrayLike

from bracekit._linalg import as_array, cross3_list
from bracekit.compliance.first_order import (
    ComplianceModel,
    braced_c1_unchecked,
    c1_unchecked,
    check_finite,
    check_model,
    end_effector_compliance,
    unit6,
)
from bracekit.kinematics import BracedRobot, BracedState
from bracekit.objective.base import Array, Term, TermContext, hessians, register_term
from bracekit.objective.compliance_gradient import bilinear_gradient
from bracekit.objective.fused import FusedGradient, FusedKinematics


@dataclass(frozen=True)
class DirectionalTerm(Term):
    """A term of the tip compliance C_e along the task's twist β_x (6,) under a compliance model (C_i, c_t).

    Subclasses say which directions they take (:meth:`direction`: a unit twist for C_i, a translation for c_t);
    β_x follows the task's (:meth:`with_beta_x`) and a scenario makes the term from its β_x and compliance model.
    """

    beta_x: Array
    model: ComplianceModel = "constrained"

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "beta_x", self.direction(self.beta_x))
        check_model(self.model)

    def direction(self, beta_x: Array) -> Array:
        """β_x as the term takes it (6,); InputError for a direction it does not take."""
        raise NotImplementedError

    def with_beta_x(self, beta_x: ArrayLike) -> Self:
        """The term with β_x replaced (checked by :meth:`direction`)."""
        return replace(self, beta_x=as_array(beta_x, "beta_x", finite=False))

    @classmethod
    def from_scenario(cls, context: TermContext) -> Self:
        """The term as a scenario configures it (its weight key is ``key``)."""
        return cls(context.beta_x, check_model(context.compliance_model))


@register_term
@dataclass(frozen=True)
class ComplianceIndex(DirectionalTerm):
    """C_i = ‖β_xᵀ C_e‖ (eq:compliance_index) for a fixed unit twist β_x (6,) and a compliance model; m/N."""

    name: str = "Ci"
    key = "Ci"

    def direction(self, beta_x: Array) -> Array:
        """β_x scaled to a unit twist (6,)."""
        return unit6(beta_x, "beta_x")

    def value(self, state: BracedState) -> float:
        """The term's value at the state (the class docstring gives its units)."""
        return float(np.linalg.norm(self.beta_x @ end_effector_compliance(state, self.model)))

    def gradient(self, state: BracedState) -> Array:
        """∂value/∂q (n,), exact through the state's kinematic Hessians: (C_eβ)ᵀ (∂C_e/∂q) β / C_i.

        Any number of braces for ``constrained``; ``projection`` through the one brace's chain split
        (:func:`~bracekit.objective.compliance_gradient.bilinear_gradient`).
        """
        hessians(state)  # InputError before any work when the state has none
        beta = self.beta_x
        with np.errstate(all="ignore"):  # an overflow raises NumericalError below (check_finite)
            if self.model == "projection":  # eq:Ce through the split, unchecked: the index's own check below
                split = state.split
                c1t = braced_c1_unchecked(state, self.model, c1_unchecked(state))
                j_e2, k2 = state.J_e[:, split.n1 :], state.K[split.n1 :]
                v = beta @ (split.S_t1 @ c1t @ split.S_t1.T + (j_e2 / k2) @ j_e2.T)
            else:
                v = end_effector_compliance(state, self.model) @ beta
            ci = float(check_finite(np.linalg.norm(v), "the compliance index"))
        if ci == 0.0:
            return np.zeros(state.q.size)
        return check_finite(bilinear_gradient(state, self.model, v, beta) / ci, "the gradient of the compliance index")

    def fused_value(self, kin: FusedKinematics) -> float:
        """The value from the fused step's kinematics (the same as :meth:`value`)."""
        jh = kin.compliance(self.model)[2]
        v = jh.dot(jh.T.dot(self.beta_x) * kin.kinv)
        return check_finite(float(np.sqrt(v.dot(v))), "the compliance index")

    def fused_gradient(self, kin: FusedKinematics, weight: float, out: FusedGradient) -> bool:
        """Add weight · ∂value/∂q to the fused step's accumulator; True when done here."""
        beta = self.beta_x
        n1 = kin.n1
        s1t, tj1, jh = kin.compliance(self.model)
        kinv = kin.kinv
        uk = beta.dot(jh) * kinv
        v = jh.dot(uk)  # C_e β
        ci = check_finite(math.sqrt(float(v.dot(v))), "the compliance index")
        if ci == 0.0:
            return True
        wu = np.array((v.dot(jh) * kinv, uk)) * (weight / ci)
        # β ⊗ (J_e2ᵀ v / k2) + v ⊗ (J_e2ᵀ β / k2) on chain 2 (∂J_e); on chain 1 the same with
        # [b̂ v̂] = Tᵀ S_t1ᵀ [β v] against ∂J_b
        pb = np.array((beta, v)).T.dot(wu)
        out.add_ue_columns(n1, pb[:, n1:])
        out.add_ub(s1t.T.dot(pb[:, :n1]))
        # S_t1 depends on b − e: (J_b[:3] − J_e[:3])ᵀ ((C̃1 S_t1ᵀ v)_ω × β_v + (C̃1 S_t1ᵀ β)_ω × v_v)
        cv, cb = wu[:, :n1].dot(tj1[3:].T).tolist()
        w1, w2 = cross3_list(cv, beta.tolist()), cross3_list(cb, v.tolist())
        for i in range(3):
            wi = w1[i] + w2[i]
            out.y[i] += wi
            out.y[6 + i] -= wi
        return True

    def numba_params(self, braced: BracedRobot, weight: float) -> tuple[str, list[float]] | None:
        """(kind, parameters) of the numba kernel's compiled copy of this term."""
        if braced.split.brace.environment_stiffness is not None and self.model != "projection":
            return None  # the kernel's T C1 Tᵀ form needs a rigid environment
        return "Ci", [*self.beta_x.tolist(), weight, float(self.model == "projection")]
