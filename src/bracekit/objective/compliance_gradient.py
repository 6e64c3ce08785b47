"""∂(aᵀ C_e b)/∂q, the derivative of a bilinear reading of the tip compliance C_e (eq:Ce) through the Hessians.

The terms that read C_e along fixed twists use it: C_i = ‖β_xᵀC_e‖ (a = C_eβ_x, b = β_x, divided by C_i) and
c_t = β_xᵀC_eβ_x (a = b = β_x).
"""

from __future__ import annotations

import numpy as np

from bracekit._linalg import cross3
from bracekit.compliance.first_order import ComplianceModel, braced_c1_unchecked, c1_unchecked, check_finite
from bracekit.kinematics import BracedState
from bracekit.objective.base import Array, contract, hessians


def bilinear_gradient(state: BracedState, model: ComplianceModel, a: Array, b: Array) -> Array:
    """∂(aᵀ C_e b)/∂q (n,) for constant twists a, b (6,) and C_e in `model`, exact through the Hessians.

    ``constrained`` (any number of braces): with C_e = J_e K⁻¹ J_eᵀ − B M⁻¹ Bᵀ, B = J_e K⁻¹ Gᵀ,
    M = G K⁻¹ Gᵀ + D over the independent rows of G = [X_iᵀ J_b_i] (constrained_compliance), p_x = M⁻¹ Bᵀ x and
    the constrained joint deflections x̃ = K⁻¹ (J_eᵀ x − Gᵀ p_x) for x = a, b:

        ∂(aᵀC_e b)/∂q_k = Σ (a b̃ᵀ + b ãᵀ) ∘ ∂J_e/∂q_k − Σ_i Σ X_i (p_b,i ãᵀ + p_a,i b̃ᵀ) ∘ ∂J_b_i/∂q_k,

    p_x,i the rows of brace i (D and the row choice are constant). ``projection``: one brace, through the chain
    split (eq:C1wave_detail): C_e = S_t1 C̃1 S_t1ᵀ + J_e2 K2⁻¹ J_e2ᵀ with C̃1 = (I − P) C1 (I − P).
    The state needs ``hessians=True``.
    """
    if model == "projection":
        return _projection_gradient(state, a, b)
    d_je, d_jb = hessians(state)
    k = state.K
    con = state.constraint
    rows = list(con.independent)
    with np.errstate(all="ignore"):  # an overflow raises NumericalError below (check_finite)
        je_t = state.J_e.T
        g = con.G[rows]
        b_mat = (state.J_e / k) @ g.T
        m = (g / k) @ g.T + np.diag(con.compliance[rows])
        if rows:
            p_b, p_a = np.linalg.solve(m, b_mat.T @ np.column_stack([b, a])).T
        else:
            p_b = p_a = np.zeros(0)
        bt = (je_t @ b - g.T @ p_b) / k
        at = (je_t @ a - g.T @ p_a) / k
        grad = contract(d_je, np.outer(a, bt) + np.outer(b, at))
        u_g = -(np.outer(p_b, at) + np.outer(p_a, bt))  # against dG, one row per independent row of G
        for i, (x, dj) in enumerate(zip(state.X_i, d_jb, strict=True)):
            mine = [j for j, row in enumerate(rows) if con.rows[row][0] == i]
            if mine:
                cols = [con.rows[rows[j]][1] for j in mine]
                grad += contract(dj, x[:, cols] @ u_g[mine])
    return check_finite(grad, "the gradient of a directional compliance")


@np.errstate(all="ignore")  # an overflow raises NumericalError (check_finite), not a RuntimeWarning
def _projection_gradient(state: BracedState, a: Array, b: Array) -> Array:
    """∂(aᵀC_e b)/∂q of the projection model (one brace: the chain split), eq:C1wave_detail."""
    d_je, (d_jb,) = hessians(state)
    split = state.split
    n1, n = split.n1, state.q.size
    c1 = c1_unchecked(state)
    c1t = braced_c1_unchecked(state, "projection", c1)
    s1 = split.S_t1
    # chain 2: aᵀ dJ K2⁻¹ J_e2ᵀ b + bᵀ dJ K2⁻¹ J_e2ᵀ a against ∂J_e, columns n1…
    j_e2, k2 = state.J_e[:, n1:], state.K[n1:]
    u = np.zeros((6, n))
    u[:, n1:] = np.outer(a, (j_e2.T @ b) / k2) + np.outer(b, (j_e2.T @ a) / k2)
    grad = contract(d_je, u)
    # S_t1 depends on b − e
    a1, b1 = s1.T @ a, s1.T @ b
    w = cross3((c1t @ b1)[3:], a[:3]) + cross3((c1t @ a1)[3:], b[:3])
    grad += (split.J_b[:3] - state.J_e[:3]).T @ w
    # C̃1 through C1 with the constant projector I − P
    t = np.eye(6) - split.P
    ah, bh = t @ a1, t @ b1
    j1, k1 = split.J1, state.K[:n1]
    u = np.zeros((6, n))
    u[:, :n1] = np.outer(ah, (j1.T @ bh) / k1) + np.outer(bh, (j1.T @ ah) / k1)
    grad += contract(d_jb, u)
    return check_finite(grad, "the gradient of a directional compliance")
