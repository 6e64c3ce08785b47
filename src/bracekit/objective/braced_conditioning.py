"""The braced-conditioning barrier: it keeps the braced task Jacobian away from rank loss (eq:cond_barrier).

With M = S C_e Sᵀ, C_e the constrained first-order compliance of every brace (eq:Ce) and S = S(⁰R_e) the task
space's selected rows (``pose``, ``position``, ``position+axis``), λ_min and λ_max the extreme eigenvalues of M
and r = √(λ_min / λ_max):

    φ(r) = (r₀ − r)² / (r₀ r)   for 0 < r < r₀,   0 for r ≥ r₀.

For rigid braces C_e = J_e K^(−1/2) Π K^(−1/2) J_eᵀ, Π the projector onto the null space of G K^(−1/2), so the
eigenvalues of M are the squared singular values of the braced task Jacobian S J_e N in the joint-stiffness
metric and r is its σ_min/σ_max (that of S J_e N itself when the joints are equally stiff). r → 0 exactly where
the braced motions cannot realise some task direction: a braced singularity. φ and φ' vanish at r₀, φ grows
without bound as r → 0; a gradient-projection run that weights it uses the redundancy to steer away.

∂λ/∂q for an eigenpair (λ, v), a = Sᵀ v: aᵀ (∂C_e/∂q) a through the kinematic Hessians
(:func:`~bracekit.objective.compliance_gradient.bilinear_gradient`), plus, for ``position+axis``, the turn of
the selected plane with the tool axis u = ⁰R_e a_tip: −2 (uᵀ (C_e a)_ω) J_ωᵀ (u × a_ω). Then
∂r/∂q = (r/2)(∂λ_min/λ_min − ∂λ_max/λ_max) and ∂φ/∂q = φ'(r) ∂r/∂q, φ'(r) = (r² − r₀²) / (r₀ r²).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from bracekit._linalg import as_number, inverse
from bracekit.compliance.first_order import constrained_compliance
from bracekit.errors import BarrierError, InputError
from bracekit.kinematics import BracedState
from bracekit.objective.base import Array, Term, TermContext, register_term
from bracekit.objective.compliance_gradient import bilinear_gradient
from bracekit.objective.fused import FusedGradient, FusedKinematics

#: r₀: the barrier is zero while σ_min/σ_max of the braced task Jacobian is at or above this.
DEFAULT_THRESHOLD = 0.01


def conditioning_ratio(c_e: Array, rows: Array) -> float:
    """R = √(λ_min/λ_max) of S C_e Sᵀ for the selected rows S (m×6) and a compliance C_e (6×6)."""
    lam = np.linalg.eigvalsh(rows @ c_e @ rows.T)
    return float(np.sqrt(max(lam[0], 0.0) / lam[-1])) if lam[-1] > 0.0 else 0.0


@register_term
@dataclass(frozen=True, eq=False)
class BracedConditioning(Term):
    """φ(r) = (r₀ − r)²/(r₀ r) below r₀, 0 above, r the σ_min/σ_max of the braced task Jacobian (eq:cond_barrier).

    Dimensionless, ≥ 0; one term for any number of braces (every brace is in C_e). BarrierError where r = 0.

    Attributes:
        threshold: r₀ in (0, 1).
        space: the task space (a :class:`~bracekit.resolution.task_space.TaskSpace`) whose rows S(⁰R_e) are
            conditioned; None for the full pose.
    """

    threshold: float = DEFAULT_THRESHOLD
    space: Any = None
    name: str = "conditioning"
    key = "conditioning"

    def __post_init__(self) -> None:
        super().__post_init__()
        r0 = as_number(self.threshold, "the conditioning threshold r0", positive=True)
        if not r0 < 1.0:
            raise InputError(f"the conditioning threshold r0 is a ratio σ_min/σ_max below 1, got {r0:g}")
        if self.space is not None and not callable(getattr(self.space, "selection", None)):
            raise InputError(f"space must be a TaskSpace or None, got {type(self.space).__name__}")
        object.__setattr__(self, "threshold", r0)

    def _rows(self, rotation: Array) -> Array:
        """S(⁰R_e) (m×6); the identity for the full pose."""
        return np.eye(6) if self.space is None else np.asarray(self.space.selection(rotation), dtype=float)

    def _barrier(self, r: float) -> float:
        r0 = self.threshold
        if r >= r0:
            return 0.0
        if not r > 0.0:
            raise BarrierError(
                "the braced task Jacobian is singular (σ_min/σ_max = 0): the conditioning barrier is infinite"
            )
        return (r0 - r) ** 2 / (r0 * r)

    def value(self, state: BracedState) -> float:
        """The term's value at the state (the class docstring gives it)."""
        return self._barrier(conditioning_ratio(constrained_compliance(state), self._rows(state.R_e)))

    def gradient(self, state: BracedState) -> Array:
        """∂value/∂q (n,), exact through the state's kinematic Hessians (module docstring)."""
        c_e = constrained_compliance(state)
        rows = self._rows(state.R_e)
        lam, vec = np.linalg.eigh(rows @ c_e @ rows.T)
        r = float(np.sqrt(max(lam[0], 0.0) / lam[-1])) if lam[-1] > 0.0 else 0.0
        r0 = self.threshold
        if r >= r0:
            return np.zeros(state.q.size)
        self._barrier(r)  # BarrierError at r = 0
        d_min, d_max = (self._eigen_gradient(state, c_e, rows.T @ vec[:, i]) for i in (0, -1))
        dr: Array = 0.5 * r * (d_min / float(lam[0]) - d_max / float(lam[-1]))
        return (r * r - r0 * r0) / (r0 * r * r) * dr

    def _eigen_gradient(self, state: BracedState, c_e: Array, a: Array) -> Array:
        """∂λ/∂q of the eigenvalue λ = aᵀ C_e a of S C_e Sᵀ with a = Sᵀ v (module docstring)."""
        grad = bilinear_gradient(state, "constrained", a, a)
        if self.space is not None and self.space.kind == "position+axis":
            u = self.space.world_axis(state.R_e)
            grad -= 2.0 * float(u @ (c_e @ a)[3:]) * (state.J_e[3:].T @ np.cross(u, a[3:]))
        return grad

    def fused_value(self, kin: FusedKinematics) -> float | None:
        """0 where the fused step's kinematics show r clearly above r₀; None (the reference) otherwise."""
        return 0.0 if self._clearly_inactive(kin) else None

    def fused_gradient(self, kin: FusedKinematics, weight: float, out: FusedGradient) -> bool:
        """Nothing to add where r is clearly above r₀ (True); False (the reference gradient) otherwise."""
        return self._clearly_inactive(kin)

    def _clearly_inactive(self, kin: FusedKinematics) -> bool:
        """Whether r of one rigid brace, from the fused step's J_e and J_b, exceeds r₀ by 10 %.

        S C_e Sᵀ = S J_e K⁻¹ J_eᵀ Sᵀ − B M⁻¹ Bᵀ with M = G K⁻¹ Gᵀ, B = S J_e K⁻¹ Gᵀ, G = Xᵀ J_b; M⁻¹ by LU,
        certified by ‖M‖_F ‖M⁻¹‖_F < 1e8 (else the reference decides).
        """
        if kin.k_env is not None:
            return False
        with np.errstate(all="ignore"):  # an overflow fails the certificate: the reference then decides
            return self._inactive_rigid(kin)

    def _inactive_rigid(self, kin: FusedKinematics) -> bool:
        g = kin.X.T.dot(kin.jb)
        gk = g * kin.kinv
        m = gk.dot(g.T)
        m_inv = inverse(m)
        if m_inv is None or not float(np.vdot(m_inv, m_inv)) * float(np.vdot(m, m)) < 1e16:
            return False
        kind = "pose" if self.space is None else self.space.kind
        sj = kin.je[:3] if kind == "position" else kin.je if kind == "pose" else self._rows(kin.me[:3, :3]).dot(kin.je)
        sk = sj * kin.kinv
        bk = sk.dot(g.T)
        mat = sk.dot(sj.T) - bk.dot(m_inv).dot(bk.T)
        lam = np.linalg.eigvalsh(0.5 * (mat + mat.T))
        return bool(lam[-1] > 0.0 and lam[0] > (1.1 * self.threshold) ** 2 * lam[-1])

    @classmethod
    def from_scenario(cls, context: TermContext) -> BracedConditioning:
        """The term on the scenario's task space, default r₀ (its weight key is ``key``)."""
        return cls(space=context.space)
