"""The stacked contact constraint G of N ≥ 1 braces, its independent rows and the braced motions N.

Brace i touches its surface at {b_i} through a contact with constraint wrenches X_i (6×(6−l_i), world axes).
A joint motion Δq keeps that contact when X_iᵀ J_b_i Δq = 0, with J_b_i the LOCAL_WORLD_ALIGNED Jacobian of
{b_i} (6×n). Stacked over the braces, in their order,

    G = [X_1ᵀ J_b1; X_2ᵀ J_b2; …]   (c×n, c = Σ (6 − l_i)),

and the braced motions are the null space of G (orthonormal basis N, n×(n − rank G)). Two contacts may
constrain the same motion (the same frame twice, or two links that only move together): their rows of G are
then dependent. :func:`stacked_constraint` keeps a maximal independent set of the rigid rows, in the order of
the braces, and warns which rows it dropped and on which kept rows they depend (docs/model.md, "Several
braces"). The compliance with these constraints is :func:`bracekit.compliance.first_order.constrained_compliance`.
:func:`full_rank_constraint` gives G of many states at once where each keeps every row (no warning).
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from bracekit.errors import NumericalError, RedundantContactWarning, UnloadedContactWarning
from bracekit.tolerances import NULL_SPACE_RTOL, UNLOADED_TOL

if TYPE_CHECKING:
    from bracekit.kinematics.braced import BracedRobot, BracedState

Array = NDArray[np.float64]
#: The name of G K⁻¹ Gᵀ in messages (Xᵀ C1 X of the paper's chain 1 for one brace).
GKG = "G K⁻¹ Gᵀ (Xᵀ C1 X for one brace)"


def contact_null_space(g: Array) -> Array:
    """Orthonormal basis (n×(n − rank g)) of the null space of a constraint g (rows × n), e.g. Xᵀ J1 or G."""
    _, s, vt = np.linalg.svd(g)
    rank = int(np.sum(s > NULL_SPACE_RTOL * max(1.0, s[0] if s.size else 1.0)))
    return np.ascontiguousarray(vt[rank:].T, dtype=np.float64)


def stacked_null_spaces(g: Array) -> Array | None:
    """:func:`contact_null_space` of each matrix of a stack g (k, rows, n) from one stacked SVD: (k, n, n − rank).

    The same LAPACK call and rank rule per matrix; None where the ranks differ (the bases would differ in width)
    or the matrices have no rows or columns.
    """
    if min(g.shape[1], g.shape[2]) == 0:
        return None
    _, s, vt = np.linalg.svd(g)
    big = np.maximum(1.0, s[:, 0])
    ranks = np.sum(s > NULL_SPACE_RTOL * big[:, None], axis=1)
    rank = int(ranks[0])
    if not (ranks == rank).all():
        return None
    return np.ascontiguousarray(vt[:, rank:].transpose(0, 2, 1), dtype=np.float64)


@dataclass(frozen=True, eq=False)
class StackedConstraint:
    """The stacked contact constraint of the braces at one configuration (one brace: G = Xᵀ J_b).

    Attributes:
        G: [X_1ᵀ J_b1; X_2ᵀ J_b2; …] (c×n): row r is constraint wrench ``rows[r]`` applied to the twist of its
            {b_i}; force rows in m/rad of joint motion (m for a prismatic joint), moment rows in rad/rad.
        rows: (brace index i in ``braced.braces``, column of X_i) of each row of G.
        compliance: 1/k_env of each row's brace (c,), m/N or rad/(N·m); 0 for a rigid contact.
        independent: rows of G the compliance uses: every compliant row and a maximal independent set of
            the rigid rows, chosen in order (earlier braces first).
        dependent: rigid rows of G left out: dependent on earlier rows, or carrying no load.
        N: orthonormal basis of the braced motions, the null space of G (n×(n − rank G)).
    """

    G: Array
    rows: tuple[tuple[int, int], ...]
    compliance: Array
    independent: tuple[int, ...]
    dependent: tuple[int, ...]

    @cached_property
    def N(self) -> Array:
        """Orthonormal basis of the braced motions, the null space of G (n×(n − rank G)); computed when asked."""
        return contact_null_space(self.G)

    @property
    def rank(self) -> int:
        """Rank of G as used for the braced motions: n − (columns of N)."""
        return int(self.G.shape[1] - self.N.shape[1])


def stacked_constraint(state: BracedState) -> StackedConstraint:
    """Build G from a stacked state, pick its independent rows and the braced motions N.

    Rows are compared in the compliance metric, w_r = G_r K^(−1/2) (so w_r w_sᵀ is an entry of G K⁻¹ Gᵀ, the
    matrix the compliance inverts). A rigid row r is dropped when adding it would leave the kept rows with
    σ_min² ≤ UNLOADED_TOL · max(σ_max², max_i tr(J_b_i K⁻¹ J_b_iᵀ)), σ over the singular values of the
    weighted rigid rows: the same threshold as the one-brace ``constrained`` model, whose unloaded directions
    have eigenvalues of Xᵀ C1 X at or below UNLOADED_TOL · tr(C1). A dropped row that is negligible by itself
    carries no load (UnloadedContactWarning); one that is a combination of kept rows is redundant
    (RedundantContactWarning, naming the rows it depends on). Compliant rows (finite k_env) are always kept:
    G K⁻¹ Gᵀ + diag(1/k_env) is singular only through dependent rigid rows.

    Raises NumericalError when G or the compliance metric is not finite.
    """
    braced = state.braced
    k = state.K
    blocks: list[Array] = []
    rows: list[tuple[int, int]] = []
    comp: list[float] = []
    for i, (brace, x, j_b) in enumerate(zip(braced.braces, braced.X_i, state.J_b_i, strict=True)):  # X_i cached
        blocks.append(x.T @ j_b)
        rows.extend((i, col) for col in range(x.shape[1]))
        k_env = brace.environment_stiffness
        comp.extend([0.0 if k_env is None else 1.0 / float(k_env)] * x.shape[1])
    with np.errstate(all="ignore"):
        g = np.ascontiguousarray(np.vstack(blocks), dtype=np.float64)
        w = g / np.sqrt(k)
        traces = [float((j_b * j_b / k).sum()) for j_b in state.J_b_i]  # np.sum's reduction, without its wrapper
    if not (np.isfinite(g).all() and np.isfinite(w).all() and np.isfinite(traces).all()):
        raise NumericalError(
            f"{GKG} is not finite: the compliance overflows (joint stiffnesses too small for 1/K or lengths too large)"
        )
    compliance = np.array(comp, dtype=np.float64)
    rigid = [r for r in range(len(rows)) if compliance[r] == 0.0]
    _, unloaded, dependent = _independent_rows(w, rigid, max((traces[rows[r][0]] for r in rigid), default=0.0))
    # a row that depends on rows of its own brace only is a direction no joint can load: the contact is unloaded
    # there (chain 1 moves {b} in fewer directions than it constrains); across braces it is redundant
    unloaded += [r for r, deps in dependent if all(rows[s][0] == rows[r][0] for s in deps)]
    redundant = [(r, deps) for r, deps in dependent if r not in unloaded]
    if unloaded:
        warnings.warn(
            "the contact carries no load along "
            + ", ".join(_label(braced, rows[r]) for r in unloaded)
            + ": no joint can push {b} there, so those rows of the stacked constraint G are dropped",
            UnloadedContactWarning,
            stacklevel=4,
        )
    if redundant:
        text = "; ".join(
            f"{_label(braced, rows[r])} depends on {', '.join(_label(braced, rows[s]) for s in deps)}"
            for r, deps in redundant
        )
        warnings.warn(
            f"dependent contact constraints (two contacts constrain the same motion): {text}; "
            "each dependent row is dropped, the contact forces are shared but the compliance is unchanged",
            RedundantContactWarning,
            stacklevel=4,
        )
    dropped = set(unloaded) | {r for r, _ in redundant}
    independent = tuple(r for r in range(len(rows)) if r not in dropped)
    return StackedConstraint(
        G=g,
        rows=tuple(rows),
        compliance=compliance,
        independent=independent,
        dependent=tuple(sorted(dropped)),
    )


def full_rank_constraint(states: Sequence[BracedState], k: Array) -> tuple[Array, Array] | None:
    """(G (N, c, n), 1/k_env of its rows (c,)) of the states when every one keeps every row, else None.

    The stacked constraint of each state at once (stacked_constraint's G, weights and threshold): every row is
    independent when the weighted rigid rows w = G_rigid K^(−1/2) have σ_min² > UNLOADED_TOL · max(σ_max²,
    max_i tr(J_b_i K⁻¹ J_b_iᵀ)) at every state (no row dropped, no warning). None hands the states to their own
    stacked constraint (which drops rows and warns, or raises on a non-finite G): also where a state has its
    constraint already (its own counts) or the states brace different models. `k`: the joint stiffnesses (n,).
    """
    braced = states[0].braced
    if any("constraint" in st.__dict__ or st.braced is not braced for st in states):
        return None
    blocks, comp = [], []
    traces: list[Array] = []
    rigid_of: list[bool] = []
    with np.errstate(all="ignore"):
        for i, (brace, x) in enumerate(zip(braced.braces, braced.X_i, strict=True)):
            j_b = np.array([st.contacts[i].J_b for st in states], dtype=np.float64)
            blocks.append(x.T @ j_b)
            k_env = brace.environment_stiffness
            comp.extend([0.0 if k_env is None else 1.0 / float(k_env)] * x.shape[1])
            rigid_of.extend([k_env is None] * x.shape[1])
            traces.append(np.sum(j_b * j_b / k, axis=(1, 2)) if k_env is None else np.zeros(len(states)))
        g = np.concatenate(blocks, axis=1)
        if not np.isfinite(g).all():
            return None
        rigid = [r for r, yes in enumerate(rigid_of) if yes]
        if not rigid:
            return g, np.array(comp, dtype=np.float64)
        w = g[:, rigid] / np.sqrt(k)
        if len(rigid) > g.shape[2] or not (np.isfinite(w).all() and np.isfinite(traces).all()):
            return None
        s = np.sqrt(np.einsum("nij,nij->ni", w, w))[:, 0:1] if len(rigid) == 1 else np.linalg.svd(w, compute_uv=False)
        limit = UNLOADED_TOL * np.maximum(s[:, 0] ** 2, np.max(traces, axis=0))
        if not (s[:, -1] ** 2 > limit).all():
            return None
    return g, np.array(comp, dtype=np.float64)


def _independent_rows(
    w: Array, rigid: list[int], trace: float
) -> tuple[list[int], list[int], list[tuple[int, tuple[int, ...]]]]:
    """Kept rigid rows, unloaded rows and (redundant row, rows it depends on) of the weighted constraint w.

    See :func:`stacked_constraint` for the threshold. With full rank every rigid row is kept (one SVD).
    """
    if not rigid:
        return [], [], []
    wr = w[rigid]
    if len(rigid) == 1:  # one row (a frictionless point): its σ² is its squared norm
        s = np.sqrt(np.array([float(wr[0] @ wr[0])]))
    else:
        s = np.linalg.svd(wr, compute_uv=False)
    limit = UNLOADED_TOL * max(float(s[0]) ** 2, trace)
    if s.size == len(rigid) and s[-1] ** 2 > limit:
        return list(rigid), [], []
    kept: list[int] = []
    unloaded: list[int] = []
    redundant: list[tuple[int, tuple[int, ...]]] = []
    for r in rigid:
        row = w[r]
        if float(row @ row) <= limit:
            unloaded.append(r)
            continue
        trial = w[[*kept, r]]
        if np.linalg.svd(trial, compute_uv=False)[-1] ** 2 > limit:
            kept.append(r)
            continue
        base = w[kept]  # row ≈ coefᵀ base: name the kept rows with a share of it
        coef = np.linalg.lstsq(base.T, row, rcond=None)[0]
        share = np.abs(coef) * np.linalg.norm(base, axis=1)
        deps = tuple(kept[m] for m in np.flatnonzero(share > 1e-6 * np.linalg.norm(row)))
        redundant.append((r, deps or tuple(kept)))
    return kept, unloaded, redundant


def _label(braced: BracedRobot, row: tuple[int, int]) -> str:
    """'braces[i] (frame 'name', contact) row j' for an error or warning message."""
    i, col = row
    brace = braced.braces[i]
    return f"braces[{i}] (frame '{brace.frame}', {brace.kind.name}) row {col}"
