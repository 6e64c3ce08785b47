"""∂(aᵀ C_e b)/∂q, the derivative of a bilinear reading of the tip compliance C_e (eq:Ce) through the Hessians.

The terms that read C_e along fixed twists use it: C_i = ‖β_xᵀC_e‖ (a = C_eβ_x, b = β_x, divided by C_i) and
c_t = β_xᵀC_eβ_x (a = b = β_x).
"""

from __future__ import annotations

import numpy as np

from bracekit._linalg import cross3
from bracekit.compliance.first_order import (
    ComplianceModel,
    braced_c1_unchecked,
    c1_unchecked,
    check_finite,
    constraint_gain,
)
from bracekit.kinematics import BracedState
from bracekit.objective.base import Array, contract, hessians


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
