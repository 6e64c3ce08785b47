"""The preloaded (second-order) tip compliance: the constrained model with the preload's geometric stiffness.

With the contact pressing on {b} with a force P along n̂, the equilibrium K (q − rest) = J_eᵀ w + J_b,vᵀ n̂ λ
has, about λ = P, the tangent stiffness K_t = K − P ∂(J_b,vᵀ n̂)/∂q: a geometric stiffness (Chen & Kao's
conservative congruence transformation) that the first-order models, built on K alone, neglect
(docs/model.md, "The preloaded compliance").
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from bracekit._linalg import as_number, finite_math
from bracekit.errors import InputError, SingularityError
from bracekit.kinematics import BracedRobot

Array = NDArray[np.float64]


def preloaded_compliance(braced: BracedRobot, q: ArrayLike, preload: float) -> Array:
    """Tip compliance (6×6, world axes, [Δp; Δθ] per [f; m]) with the preload's geometric stiffness.

    Linearising K (q − rest) = J_eᵀ w + J_b,vᵀ n̂ λ about the preloaded equilibrium (λ = P, N) with the
    contact kept closed gives (K − P ∂(J_b,vᵀ n̂)/∂q) δq − a δλ = J_eᵀ δw, aᵀ δq = 0 (a = J_b,vᵀ n̂): the
    constrained model with K replaced by the tangent stiffness. At P = 0 it equals the ``constrained`` C_e.
    Frictionless point contact only. Raises SingularityError when the KKT system is singular (e.g. chain 1
    cannot move {b} along n̂) and NumericalError when it overflows.
    """
    if not isinstance(braced, BracedRobot):
        raise InputError(f"expected a BracedRobot, got {type(braced).__name__}")
    if braced.brace.kind.name != "frictionless_point":
        raise InputError("the preloaded compliance is defined for the frictionless point contact")
    preload = as_number(preload, "the preload (the contact pushes)", nonnegative=True, unit="N")
    st = braced.state(q, hessians=True)
    n = braced.robot.n
    nhat = braced.brace.surface.normal
    if st.dJ_b is None:  # state(hessians=True) always gives them
        raise InputError("the preloaded compliance needs the kinematic Hessians")
    with finite_math("the preloaded compliance"):
        a = st.J_b[:3].T @ nhat
        k_t = np.diag(braced.robot.stiffness) - preload * np.einsum("r,rik->ik", nhat, st.dJ_b[:3])
        kkt = np.zeros((n + 1, n + 1))
        kkt[:n, :n] = 0.5 * (k_t + k_t.T)
        kkt[:n, n] = kkt[n, :n] = -a
        rhs = np.zeros((n + 1, 6))
        rhs[:n] = st.J_e.T
        try:
            dq = np.linalg.solve(kkt, rhs)[:n]
        except np.linalg.LinAlgError:
            raise SingularityError(
                "the preloaded equilibrium is singular here (chain 1 cannot move {b} along the normal, or the preload "
                "cancels a joint stiffness); choose another configuration or a smaller preload"
            ) from None
        c = st.J_e @ dq
        return 0.5 * (c + c.T)
