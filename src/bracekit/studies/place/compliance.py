"""C_i (or c_t) of the constrained tip compliance with the placed brace, and its gradient in (q, θ).

C_e = J_e K⁻¹ J_eᵀ − B M⁻¹ Bᵀ, B = J_e K⁻¹ Gᵀ, M = G K⁻¹ Gᵀ + D with G = Xᵀ J_b (eq:Ce, the constrained model
of docs/model.md; X the contact's constraint wrenches, D = diag(1/k_env), 0 rigid). For the bilinear reading
aᵀ C_e b and any variable v with ∂J_e/∂v and ∂J_b/∂v (the derivation of
:func:`bracekit.objective.compliance_gradient.bilinear_gradient`, here for the place as well as q):

    ∂(aᵀC_e b)/∂v = Σ (a b̃ᵀ + b ãᵀ) ∘ ∂J_e/∂v − Σ X (p_b ãᵀ + p_a b̃ᵀ) ∘ ∂J_b/∂v,

p_x = M⁻¹ Bᵀ x, x̃ = K⁻¹ (J_eᵀ x − Gᵀ p_x). C_i = ‖C_e β_x‖ (eq:compliance_index): a = C_e β_x, b = β_x,
divided by C_i; c_t = β_xᵀ C_e β_x: a = b = β_x.
"""

from __future__ import annotations

from typing import Literal, NamedTuple

import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]
Measure = Literal["Ci", "ct"]


class PlacedCompliance(NamedTuple):
    """The objective's value (m/N for C_i; m/N along β_x for c_t) and its gradient over the variables (m,)."""

    value: float
    gradient: Array


def placed_compliance(
    J_e: Array,
    dJ_e: Array,
    J_b: Array,
    dJ_b: Array,
    X: Array,
    K: Array,
    D: Array,
    beta: Array,
    measure: Measure = "Ci",
) -> PlacedCompliance:
    """C_i or c_t and its gradient; dJ_e, dJ_b (6, n, m) over the m variables; X (6, r); K (n,); D (r,)."""
    g = X.T @ J_b
    m_mat = (g / K) @ g.T + np.diag(D)
    bmat = (J_e / K) @ g.T
    c_e = (J_e / K) @ J_e.T - bmat @ np.linalg.solve(m_mat, bmat.T)
    c_e = 0.5 * (c_e + c_e.T)
    if measure == "Ci":
        a = c_e @ beta
        value = float(np.linalg.norm(a))
        scale = 1.0 / value if value > 0.0 else 0.0
    else:
        a = beta
        value = float(beta @ c_e @ beta)
        scale = 1.0
    b = beta
    p_b, p_a = np.linalg.solve(m_mat, bmat.T @ np.column_stack([b, a])).T
    bt = (J_e.T @ b - g.T @ p_b) / K
    at = (J_e.T @ a - g.T @ p_a) / K
    u_e = np.outer(a, bt) + np.outer(b, at)
    u_b = -X @ (np.outer(p_b, at) + np.outer(p_a, bt))
    rows, mvars = u_e.size, dJ_e.shape[2]
    grad = u_e.ravel() @ dJ_e.reshape(rows, mvars) + u_b.ravel() @ dJ_b.reshape(rows, mvars)
    return PlacedCompliance(value, scale * grad)
