"""Coordinates y of the braced motions: q̇ = M y keeps every contact, the tip twist is A y.

The braced strategies (eq:general_inv, eq:grad_proj) resolve the task over coordinates of the braced motions.
With one brace these are the paper's (b̃, q2): M = blkdiag(dq1/db̃, I_n2) (eq:q1) and A = [S_t1 H, S_t2 J2]
(eq:braced_kin), and Mᵀ ∂g/∂q is eq:grad_g. With several braces the chain does not split: M = N, an
orthonormal basis of the null space of the stacked constraint G, and A = J_e N (docs/model.md, "Several
braces"). The state chooses (``BracedState.motions``); a strategy only uses this interface.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from bracekit.errors import SingularityError
from bracekit.tolerances import STEP_SINGULAR_RATIO

if TYPE_CHECKING:
    from bracekit.kinematics.split import ChainSplit

Array = NDArray[np.float64]


class BracedMotions:
    """A chart of the braced motions at one configuration (abstract: :class:`SplitMotions`, :class:`NullMotions`).

    Attributes:
        A: tip twist per braced coordinate (6×r), world axes.
        label: the printed name of A in messages.
    """

    A: Array
    label: str

    def to_joint(self, y: Array) -> Array:
        """q̇ = M y (n,) from braced coordinates y (r,)."""
        raise NotImplementedError

    def gradient(self, dg_dq: Array) -> Array:
        """Mᵀ ∂g/∂q (r,): the gradient of g over the braced coordinates (eq:grad_g for one brace)."""
        raise NotImplementedError

    def inverse(self, a: Array) -> Array:
        """B⁺ of the task rows B = S A (m×r) of A; SingularityError when B has no full row rank."""
        m, k = a.shape
        if k < m:
            raise SingularityError(
                f"the braces leave {k} braced motion(s) for {m} task rows: {self.label} ({m}×{k}) cannot do the "
                "task; remove a brace, use a contact with more freedom or a task space with fewer rows"
            )
        u, s, vt = np.linalg.svd(a, full_matrices=False)
        if not s[-1] > STEP_SINGULAR_RATIO * s[0]:
            raise SingularityError(f"{self.label} is singular (σ_min/σ_max = {s[-1] / max(s[0], 1e-300):.2e})")
        return np.asarray((vt.T / s) @ u.T, dtype=np.float64)


@dataclass(frozen=True, eq=False)
class SplitMotions(BracedMotions):
    """The paper's coordinates (b̃, q2) of one brace: q̇ = [dq1/db̃ · b̃̇; q̇2] (eq:q1), A of eq:braced_kin."""

    split: ChainSplit
    label: str = "the braced Jacobian A"

    @property
    def A(self) -> Array:  # type: ignore[override]
        """[S_t1 H, S_t2 J2] (6×(l + n2)), eq:braced_kin."""
        return self.split.A

    def to_joint(self, y: Array) -> Array:
        """[ḃ; q̇2] → q̇ = [dq1/db̃ · ḃ; q̇2] (eq:q1)."""
        chain1 = self.split.chain1_map
        l_ = chain1.shape[1]
        return np.concatenate([chain1 @ y[:l_], y[l_:]])

    def gradient(self, dg_dq: Array) -> Array:
        """∇g over [b̃; q2]: [(∂g/∂q1) dq1/db̃, ∂g/∂q2]ᵀ (eq:grad_g)."""
        n1 = self.split.n1
        return np.concatenate([self.split.chain1_map.T @ dg_dq[:n1], dg_dq[n1:]])


@dataclass(frozen=True, eq=False)
class NullMotions(BracedMotions):
    """Coordinates y over an orthonormal basis N of the braced motions (null space of G): q̇ = N y, A = J_e N."""

    N: Array
    A: Array
    label: str = "S J_e N"

    def to_joint(self, y: Array) -> Array:
        """q̇ = N y."""
        return np.asarray(self.N @ y, dtype=np.float64)

    def gradient(self, dg_dq: Array) -> Array:
        """Nᵀ ∂g/∂q."""
        return np.asarray(self.N.T @ dg_dq, dtype=np.float64)
