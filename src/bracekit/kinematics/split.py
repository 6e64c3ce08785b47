"""The paper's chain split at {b} (Section III): a view of the braced state that exists for one brace.

With one brace the chain splits at {b} into chain 1 (n1 joints, every joint that moves {b}) and chain 2
(n2 joints, from {b} to {e}); the paper's J1, J2, S_t1, S_t2, A, J̃, P and dq1/db̃ are defined on that
split. :class:`BraceSplit` holds what the split fixes in the model (n1, n2, H, X, P);
:class:`ChainSplit` what it gives at a configuration. With several braces the chain does not split at one
{b}: ``braced.split`` and ``state.split`` raise ContactError, and the general quantities of the state (the
stacked constraint G, the braced motions N, J_e N) take their place (docs/model.md, "Several braces").
Jacobians are geometric, twists [v; ω], world axes unless said.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from bracekit._forward import Forward
from bracekit.contact import Brace
from bracekit.errors import ContactError, SingularityError
from bracekit.kinematics.constraint import contact_null_space
from bracekit.spatial import twist_rotate, twist_shift
from bracekit.tolerances import J1_COND_LIMIT

if TYPE_CHECKING:
    from bracekit.kinematics.braced import BracedState, ContactState

Array = NDArray[np.float64]

#: What the chain split gives, for the error raised with several braces.
SPLIT_QUANTITIES = "the chain split at {b} (n1, n2, J1, J2, S_t1, S_t2, A, J̃, P, dq1/db̃)"
#: What takes its place with several braces.
SPLIT_INSTEAD = "the stacked constraint of the state (state.G, state.N, state.braced_jacobian = J_e N)"


def split_refused(count: int, what: str = SPLIT_QUANTITIES) -> ContactError:
    """The one error for a one-brace quantity asked of a robot with `count` braces."""
    return ContactError(
        f"{what} is defined for one brace; this robot has {count} braces and its chain does not split at one "
        f"{{b}}: use {SPLIT_INSTEAD}"
    )


@dataclass(frozen=True, eq=False)
class BraceSplit:
    """What the one-brace split fixes in the model (``braced.split``).

    Attributes:
        brace: the brace.
        brace_id: Pinocchio frame id of {b}.
        n1: joints of chain 1, base to {b} (every joint that moves {b}).
        n2: joints of chain 2, from {b} to {e}.
    """

    brace: Brace
    brace_id: int
    n1: int
    n2: int

    @cached_property
    def H(self) -> Array:
        """Allowable twists of {b} (6×l), eq:constraint."""
        return self.brace.H()

    @cached_property
    def X(self) -> Array:
        """Constraint wrench basis (6×(6−l)), Hᵀ X = 0."""
        return self.brace.X()

    @cached_property
    def P(self) -> Array:
        """The paper's projector onto the constraint directions, P = X (XᵀX)⁻¹ Xᵀ (6×6)."""
        x = self.X
        return np.asarray(x @ np.linalg.solve(x.T @ x, x.T), dtype=np.float64)


@dataclass(frozen=True, eq=False)
class ChainSplit:
    """The paper's one-brace quantities at a configuration (``state.split``). Positions in m, world frame.

    Attributes:
        state: the braced state it views.
        model: the split of the model (n1, n2, H, X, P).
    """

    state: BracedState
    model: BraceSplit

    @property
    def contact(self) -> ContactState:
        """The one contact's state (b, R_b, J_b, dJ_b)."""
        return self.state.contacts[0]

    n1 = Forward[int]("model", "Joints of chain 1.")
    n2 = Forward[int]("model", "Joints of chain 2.")
    b = Forward[Array]("contact", "Position of {b} (3,), m.")
    z_b = Forward[Array]("contact", "ẑ_b, world axes (3,).")
    R_b = Forward[Array]("contact", "Orientation ⁰R_b (3×3).")
    J_b = Forward[Array]("contact", "Geometric Jacobian at b, world axes (6×n); its chain-2 columns are zero.")
    dJ_b = Forward[Array | None]("contact", "∂J_b/∂q (6, n, n), [:, i, k] = ∂J_b[:, i]/∂q_k, if asked for.")
    H = Forward[Array]("model", "Allowable twists of {b} (6×l), eq:constraint / eq:H_point.")
    X = Forward[Array]("model", "Constraint wrenches (6×(6−l)).")
    P = Forward[Array]("model", "X (XᵀX)⁻¹ Xᵀ (6×6).")

    @cached_property
    def J1(self) -> Array:
        """Twist of b per q̇1, at b, world axes (6×n1), eq:J1."""
        return self.J_b[:, : self.n1].copy()

    @cached_property
    def J2(self) -> Array:
        """Twist of e relative to {b} per q̇2, at e, in {b}'s axes (6×n2), eq:J2."""
        return twist_rotate(self.R_b.T) @ self.state.J_e[:, self.n1 :]

    @cached_property
    def S_t1(self) -> Array:
        """[[I, [b − e]×], [0, I]] (6×6), eq:twists."""
        return twist_shift(self.b, self.state.e)

    @cached_property
    def S_t2(self) -> Array:
        """diag(⁰R_b, ⁰R_b) (6×6), eq:twists."""
        return twist_rotate(self.R_b)

    @cached_property
    def J(self) -> Array:
        """Free-space Jacobian [S_t1 J1, S_t2 J2] (6×n), eq:J; equals J_e."""
        return np.hstack([self.S_t1 @ self.J1, self.S_t2 @ self.J2])

    @cached_property
    def J_braced(self) -> Array:
        """J̃ = [S_t1 (I − P) J1, S_t2 J2] (6×n), eq:J_wave."""
        return np.hstack([self.S_t1 @ (np.eye(6) - self.P) @ self.J1, self.S_t2 @ self.J2])

    @cached_property
    def chain1_map(self) -> Array:
        """dq1/db̃ (n1×l'): joint velocities of chain 1 per coordinate of the braced motion of {b}.

        With n1 = 6 this is J1⁻¹ H (eq:q1, eq:dq_dh2). Otherwise it is an orthonormal basis of the null
        space of Xᵀ J1 (the chain-1 motions that keep the contact), so any n1 works.
        Raises SingularityError when J1 (n1 = 6) is singular.
        """
        j1 = self.J1
        if self.n1 == 6:
            s = np.linalg.svd(j1, compute_uv=False)
            if s[-1] <= s[0] / J1_COND_LIMIT:
                raise SingularityError(
                    f"J1 is singular at this configuration (cond = {s[0] / max(s[-1], 1e-300):.3g}); "
                    "chain 1 cannot realise the bracing motion"
                )
            return np.asarray(np.linalg.solve(j1, self.H), dtype=np.float64)
        return contact_null_space(self.X.T @ j1)

    @cached_property
    def A(self) -> Array:
        """Braced Jacobian [S_t1 H, S_t2 J2] (6×(l+n2)), eq:braced_kin (S_t1 J1 G with G = chain1_map)."""
        first = self.S_t1 @ self.H if self.n1 == 6 else self.S_t1 @ self.J1 @ self.chain1_map
        return np.hstack([first, self.S_t2 @ self.J2])
