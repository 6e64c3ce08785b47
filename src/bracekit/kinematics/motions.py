"""Coordinates y of the braced motions: q̇ = M y keeps every contact, the tip twist is A y.

The braced strategies (eq:general_inv, eq:grad_proj) resolve the task over coordinates of the braced motions.
With one brace these are the paper's (b̃, q2): M = blkdiag(dq1/db̃, I_n2) (eq:q1) and A = [S_t1 H, S_t2 J2]
(eq:braced_kin), and Mᵀ ∂g/∂q is eq:grad_g. With several braces the chain does not split: M = N, an
orthonormal basis of the null space of the stacked constraint G, and A = J_e N (docs/model.md, "Several
braces"). The state chooses (``BracedState.motions``); a strategy only uses this interface.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from bracekit.errors import SingularityError
from bracekit.tolerances import STEP_SINGULAR_RATIO

if TYPE_CHECKING:
    from bracekit.kinematics.split import ChainSplit

Array = NDArray[np.float64]

#: Printed names of the matrices whose conditioning a run records (measure ``sigma_ratio_<key>``): the
#: paper's (one brace) and the stacked constraint's (several braces); J = J_e in both.
MATRIX_LABELS = {
    "J1": "J1",
    "A": "A",
    "SA": "S A (the task rows of A)",
    "J": "J",
    "J_braced": "J̃",
    "G": "G (independent rows)",
    "SJN": "S J_e N",
}


def singular_ratio(m: Array) -> float:
    """σ_min / σ_max of a matrix (over its min(rows, columns) singular values); 0 for a zero matrix."""
    s = np.linalg.svd(np.asarray(m, dtype=float), compute_uv=False)
    return float(s[-1] / s[0]) if s.size and s[0] > 0 else 0.0


def rank_ratio(m: Array) -> float:
    """σ_min / σ_max of a matrix that must have full row rank: 0 with more rows than columns; 1 with no rows."""
    if m.size == 0:
        return 1.0 if m.shape[0] == 0 else 0.0
    s = np.linalg.svd(m, compute_uv=False)
    return float(s[-1] / s[0]) if m.shape[1] >= m.shape[0] and s[0] > 0 else 0.0


def _ratio_of(form: Callable[[], Array], full_row_rank: bool) -> Callable[[], float]:
    """The ratio of the matrix `form` gives, computed when called: :func:`rank_ratio` or :func:`singular_ratio`."""
    return (lambda: rank_ratio(form())) if full_row_rank else (lambda: singular_ratio(form()))


class BracedMotions:
    """A chart of the braced motions at one configuration (abstract: :class:`SplitMotions`, :class:`NullMotions`).

    Attributes:
        A: tip twist per braced coordinate (6×r), world axes.
        label: the printed name of A in messages.
    """

    A: Array
    label: str

    @property
    def task_jacobian(self) -> Array:
        """The braced task Jacobian the measures k and Πσ take (eq:manip): J̃ for one brace, J_e N for several."""
        raise NotImplementedError

    def task_key(self, whole_pose: bool) -> str | None:
        """The key of :meth:`watched` whose matrix is ``task_jacobian`` (`whole_pose`: S = I), None if none is."""
        raise NotImplementedError

    def to_joint(self, y: Array) -> Array:
        """q̇ = M y (n,) from braced coordinates y (r,)."""
        raise NotImplementedError

    def inverted(self, braced: bool) -> tuple[str, ...]:
        """Keys of the matrices a braced (or free-space) strategy inverts, which a run keeps from singularity."""
        raise NotImplementedError

    def watched(self, rows: Array | None) -> dict[str, tuple[Callable[[], Array], bool]]:
        """Each matrix a run records (keys of MATRIX_LABELS), formed when called, and whether it needs full row rank.

        A matrix that needs full row rank has :func:`rank_ratio` as its ratio, the others :func:`singular_ratio`.
        `rows`: the task-space selection S (m×6) at the state, None for the whole pose.
        """
        raise NotImplementedError

    def matrices(self, rows: Array | None) -> dict[str, Callable[[], float]]:
        """σ_min/σ_max of each matrix a run records (keys of MATRIX_LABELS), computed when called.

        `rows`: the task-space selection S (m×6) at the state, None for the whole pose.
        """
        return {key: _ratio_of(form, full) for key, (form, full) in self.watched(rows).items()}

    def conditioning(self, rows: Array | None, keys: tuple[str, ...] | None = None) -> dict[str, float]:
        """σ_min/σ_max of the matrices named in `keys` (every recorded matrix if None)."""
        found = self.matrices(rows)
        return {key: found[key]() for key in (tuple(found) if keys is None else keys)}

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

    @property
    def task_jacobian(self) -> Array:
        """J̃ = [S_t1 (I − P) J1, S_t2 J2] (eq:J_wave): the paper's measures' Jacobian."""
        return self.split.J_braced

    def task_key(self, whole_pose: bool) -> str | None:
        """J̃, watched whole."""
        return "J_braced"

    def to_joint(self, y: Array) -> Array:
        """[ḃ; q̇2] → q̇ = [dq1/db̃ · ḃ; q̇2] (eq:q1)."""
        chain1 = self.split.chain1_map
        l_ = chain1.shape[1]
        return np.concatenate([chain1 @ y[:l_], y[l_:]])

    def gradient(self, dg_dq: Array) -> Array:
        """∇g over [b̃; q2]: [(∂g/∂q1) dq1/db̃, ∂g/∂q2]ᵀ (eq:grad_g)."""
        n1 = self.split.n1
        return np.concatenate([self.split.chain1_map.T @ dg_dq[:n1], dg_dq[n1:]])

    def watched(self, rows: Array | None) -> dict[str, tuple[Callable[[], Array], bool]]:
        """J1, A (eq:braced_kin), J = J_e and J̃ (eq:J_wave), whole; S A, the task rows of A that a step inverts."""
        sp = self.split
        return {
            "J1": (lambda: sp.J1, False),
            "A": (lambda: sp.A, False),
            "SA": ((lambda: sp.A) if rows is None else (lambda: rows @ sp.A), True),
            "J": (lambda: sp.state.J_e, False),
            "J_braced": (lambda: sp.J_braced, False),
        }

    def inverted(self, braced: bool) -> tuple[str, ...]:
        """Free space: J (J⁺ ẋ), then J̃. Braced: S A (eq:general_inv in the task rows), J1 when n1 = 6 (eq:q1), J̃."""
        if not braced:
            return ("J", "J_braced")
        return ("SA", "J1", "J_braced") if self.split.n1 == 6 else ("SA", "J_braced")


@dataclass(frozen=True, eq=False)
class NullMotions(BracedMotions):
    """Coordinates y over an orthonormal basis N of the braced motions (null space of G): q̇ = N y, A = J_e N.

    G: the stacked constraint over its independent rows; J_e: the tip Jacobian (6×n).
    """

    N: Array
    A: Array
    G: Array
    J_e: Array
    label: str = "S J_e N"

    @property
    def task_jacobian(self) -> Array:
        """J_e N (6×(n − rank G))."""
        return self.A

    def task_key(self, whole_pose: bool) -> str | None:
        """S J_e N, which is J_e N for the whole pose; else J_e N itself ("JN"), which stacks give beside it."""
        return "SJN" if whole_pose else "JN"

    def to_joint(self, y: Array) -> Array:
        """q̇ = N y."""
        return np.asarray(self.N @ y, dtype=np.float64)

    def gradient(self, dg_dq: Array) -> Array:
        """Nᵀ ∂g/∂q."""
        return np.asarray(self.N.T @ dg_dq, dtype=np.float64)

    def watched(self, rows: Array | None) -> dict[str, tuple[Callable[[], Array], bool]]:
        """G over its independent rows, the task rows S J_e N of A and J = J_e."""
        return {
            "G": (lambda: self.G, True),
            "SJN": ((lambda: self.A) if rows is None else (lambda: rows @ self.A), True),
            "J": (lambda: self.J_e, False),
        }

    def inverted(self, braced: bool) -> tuple[str, ...]:
        """Free space: J. Braced: G and S J_e N."""
        return ("G", "SJN") if braced else ("J",)
