"""σ_min/σ_max of the matrices a run watches, over many samples at once (the guard of :mod:`bracekit.simulation.loop`).

The numbers are those of :meth:`bracekit.kinematics.motions.BracedMotions.conditioning` at each sample, to the
last bit: one SVD over the stack of the matrices of each shape is one LAPACK call per matrix, and NumPy's stacked
matrix product is one BLAS call per matrix. With one brace the watched matrices J1, A (eq:braced_kin),
S A, J = J_e and J̃ (eq:J_wave) are formed as stacks, with the products and their order of
:class:`~bracekit.kinematics.split.ChainSplit` (S_t1, S_t2 and J2 of eq:twists, eq:J2); otherwise each chart
forms its own (:meth:`~bracekit.kinematics.motions.BracedMotions.watched`).

With several braces, where no state has its stacked constraint yet and every sample keeps every row of G
(:func:`~bracekit.kinematics.constraint.full_rank_constraint`: no row dropped, so no warning), G, N (the null
space of G from one stacked SVD, as ``contact_null_space`` takes it per matrix), J_e N and S J_e N are formed as
stacks too; otherwise each state's own constraint (which drops rows and warns) forms them.

:func:`stacked_conditioning` also hands on the stacks it decomposed with their singular values, one typed field per
matrix (:class:`Watched`): the run's measures take k of the braced task Jacobian and of J_e from them
(:mod:`bracekit.simulation.path_measures`) instead of forming and decomposing them again. :func:`split_parts`
gives the chain-split factors of many one-brace states as stacks (J1, J2, S_t1, S_t2), for the guard and the
measures.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Generic, NamedTuple, TypeVar, cast

import numpy as np
from numpy.typing import NDArray

from bracekit.kinematics.constraint import full_rank_constraint, stacked_null_spaces

if TYPE_CHECKING:
    from bracekit.kinematics import BracedState

Array = NDArray[np.float64]
T = TypeVar("T")

__all__ = [
    "Conditioning",
    "Decomposed",
    "SplitParts",
    "Watched",
    "chain1_maps",
    "split_parts",
    "stacked_conditioning",
    "stacked_ratios",
]


class Decomposed(NamedTuple):
    """A watched matrix of k samples as a stack (k, r, c) and its singular values (k, min(r, c)), descending."""

    stack: Array
    s: Array


@dataclass(frozen=True, slots=True)
class Watched(Generic[T]):
    """The matrices a run watches at k samples, each as one stack over the samples; None where not formed so.

    `T` is the stack (k, r, c) itself (``Watched[Array]``) or the stack with its singular values
    (``Watched[Decomposed]``). One brace fills J1, A, S A, J_e and J̃; several braces G, S J_e N, J_e and J_e N.
    S is the task-space selection (m×6) at each sample, I for the whole pose: then S A is A and S J_e N is
    J_e N, the same stack. World axes; the tip-twist rows in m/rad (linear) and dimensionless (angular). The
    keys of the measures (``sigma_ratio_<key>``) and their printed names are those of
    :data:`~bracekit.kinematics.motions.MATRIX_LABELS`, given with each field.

    Attributes:
        J1: J1 (k, 6, n1), the first n1 columns of J_b: the twist of b per chain-1 rate (eq:J1); key "J1".
        A: A = [S_t1 H, S_t2 J2] (k, 6, l′ + n2), the tip twist per braced coordinate (eq:braced_kin); key "A".
        SA: S A (k, m, l′ + n2), the task rows of A that a braced step inverts (full row rank); key "SA".
        J_e: J_e = J (k, 6, n), the whole robot's tip Jacobian (eq:J); key "J".
        J_braced: J̃ = [S_t1 (I − P) J1, S_t2 J2] (k, 6, n), the braced Jacobian of the measures (eq:J_wave);
            key "J_braced".
        G: G (k, c, n), the stacked constraint [X_1ᵀ J_b1; X_2ᵀ J_b2; …] over its c independent rows (c = Σ
            (6 − l_i) where every row is kept; docs/model.md, "Stacked constraint"; full row rank); key "G".
        SJN: S J_e N (k, m, n − c), the task rows of J_e N that a braced step inverts (full row rank); key "SJN".
        JN: J_e N (k, 6, n − c), the braced task Jacobian of several braces, N (n×(n − c)) an orthonormal basis
            of the null space of G; key "JN" (not a recorded measure: k and Πσ are taken of it).
    """

    J1: T | None = None
    A: T | None = None
    SA: T | None = None
    J_e: T | None = None
    J_braced: T | None = None
    G: T | None = None
    SJN: T | None = None
    JN: T | None = None

    @classmethod
    def of_keys(cls, found: Mapping[str, T]) -> Watched[T]:
        """The record of matrices given by their keys of MATRIX_LABELS ("JN": J_e N); the other keys are ignored."""
        return cls(
            J1=found.get("J1"),
            A=found.get("A"),
            SA=found.get("SA"),
            J_e=found.get("J"),
            J_braced=found.get("J_braced"),
            G=found.get("G"),
            SJN=found.get("SJN"),
            JN=found.get("JN"),
        )

    def get(self, key: str) -> T | None:
        """The matrix of MATRIX_LABELS key `key` ("JN": J_e N); None if it is not formed or no such key."""
        match key:
            case "J1":
                return self.J1
            case "A":
                return self.A
            case "SA":
                return self.SA
            case "J":
                return self.J_e
            case "J_braced":
                return self.J_braced
            case "G":
                return self.G
            case "SJN":
                return self.SJN
            case "JN":
                return self.JN
        return None


class Conditioning(NamedTuple):
    """σ_min/σ_max of the watched matrices at each sample, and the stacks decomposed for them.

    Attributes:
        ratios: one dict per sample, by key of MATRIX_LABELS (the user-facing names of the measures).
        decomposed: each matrix decomposed as one stack, with its singular values; also J_e N where several
            braces' stacks are formed at once (the run's measures take k of it; S J_e N's values for the pose).
    """

    ratios: list[dict[str, float]]
    decomposed: Watched[Decomposed]


class SplitParts(NamedTuple):
    """The chain-split factors of k one-brace states as stacks (:class:`~bracekit.kinematics.split.ChainSplit`).

    Attributes:
        j_e: J_e (k, 6, n). j_b: J_b (k, 6, n). j1: J1 (k, 6, n1), eq:J1. j2: J2 (k, 6, n2), eq:J2.
        s_t1: S_t1 = [[I, [b − e]×], [0, I]] (k, 6, 6); s_t2: S_t2 = diag(⁰R_b, ⁰R_b) (k, 6, 6), eq:twists.
    """

    j_e: Array
    j_b: Array
    j1: Array
    j2: Array
    s_t1: Array
    s_t2: Array


def _ratios(stack: Array, full_row_rank: bool, known: dict[int, Array] | None = None) -> list[float]:
    """σ_min/σ_max of each matrix of a (k, r, c) stack, as ``rank_ratio`` (`full_row_rank`) or ``singular_ratio``.

    `known`: the singular values of stacks already decomposed, by the stack's id (a stack watched under two keys,
    A and S A of the whole pose, is decomposed once).
    """
    k, r, c = stack.shape
    if r * c == 0 or (full_row_rank and c < r):  # no singular values, or more rows than columns
        return [1.0 if full_row_rank and r == 0 else 0.0] * k
    found = None if known is None else known.get(id(stack))
    s = cast(Array, np.linalg.svd(stack, compute_uv=False)) if found is None else found
    if known is not None:
        known[id(stack)] = s
    return [low / high if high > 0 else 0.0 for low, high in zip(s[:, -1].tolist(), s[:, 0].tolist(), strict=True)]


def stacked_ratios(ms: Sequence[Array], full_row_rank: bool) -> list[float]:
    """σ_min/σ_max of each matrix of `ms`, as ``rank_ratio`` (`full_row_rank`) or ``singular_ratio``.

    One SVD over the stack of the matrices of each shape: the ratios of the single calls, to the last bit.
    """
    out = [0.0] * len(ms)
    shapes: dict[tuple[int, ...], list[int]] = {}
    for i, m in enumerate(ms):
        shapes.setdefault(m.shape, []).append(i)
    for idx in shapes.values():
        for i, value in zip(idx, _ratios(np.array([ms[i] for i in idx], dtype=np.float64), full_row_rank), strict=True):
            out[i] = value
    return out


def split_parts(states: Sequence[BracedState]) -> SplitParts | None:
    """J_e, J_b, J1, J2, S_t1 and S_t2 of one-brace states of one model as stacks, the products of ChainSplit.

    None where b − e or ⁰R_b is not finite (``twist_shift`` and ``twist_rotate`` raise then).
    """
    n1, k = states[0].braced.split.n1, len(states)
    j_e = np.array([st.J_e for st in states])
    contacts = [st.contacts[0] for st in states]
    j_b = np.array([c.J_b for c in contacts])
    r_b = np.array([c.R_b for c in contacts])
    d = np.array([c.b for c in contacts]) - np.array([st.e for st in states])  # b − e (k, 3)
    if not (np.isfinite(d).all() and np.isfinite(r_b).all()):
        return None
    s_t1 = np.zeros((k, 6, 6))  # [[I, [b − e]×], [0, I]]
    s_t1[:, range(6), range(6)] = 1.0
    x, y, z = d[:, 0], d[:, 1], d[:, 2]
    s_t1[:, 0, 4], s_t1[:, 0, 5], s_t1[:, 1, 3] = -z, y, z
    s_t1[:, 1, 5], s_t1[:, 2, 3], s_t1[:, 2, 4] = -x, -y, x
    s_t2 = np.zeros((k, 6, 6))  # diag(⁰R_b, ⁰R_b)
    s_t2[:, :3, :3] = s_t2[:, 3:, 3:] = r_b
    back = np.zeros((k, 6, 6))  # diag(⁰R_bᵀ, ⁰R_bᵀ)
    back[:, :3, :3] = back[:, 3:, 3:] = r_b.transpose(0, 2, 1)
    j1 = np.ascontiguousarray(j_b[:, :, :n1])
    return SplitParts(j_e=j_e, j_b=j_b, j1=j1, j2=back @ j_e[:, :, n1:], s_t1=s_t1, s_t2=s_t2)


def chain1_maps(x: Array, j1: Array) -> Array | None:
    """dq1/db̃ of k one-brace states (k, n1, l') with n1 ≠ 6: the null space of Xᵀ J1 of each, from one stacked SVD.

    The numbers of each state's ``split.chain1_map`` (:func:`~bracekit.kinematics.constraint.contact_null_space`
    of Xᵀ J1, the same LAPACK call per matrix); None where the null spaces differ in width or Xᵀ J1 has no rows.
    `x`: X (6×(6−l)); `j1`: the stack of J1 (k, 6, n1), world axes.
    """
    return stacked_null_spaces(x.T @ j1)


def _split_stacks(states: Sequence[BracedState], rows: Sequence[Array | None]) -> Watched[Array] | None:
    """The watched matrices of one-brace states as (k, …) stacks; None where a chart forms its own.

    With n1 ≠ 6, A = S_t1 J1 dq1/db̃ takes each state's own dq1/db̃ (``chain1_map``). None where the states
    brace different models, a task-space selection is None at some samples only, dq1/db̃ changes shape, or
    b − e or ⁰R_b is not finite (``twist_shift`` and ``twist_rotate`` raise then).
    """
    braced = states[0].braced
    if any(st.braced is not braced for st in states):
        return None
    if any(r is None for r in rows) and not all(r is None for r in rows):
        return None
    parts = split_parts(states)
    if parts is None:
        return None
    model = braced.split
    j1, s_t1 = parts.j1, parts.s_t1
    chain2 = parts.s_t2 @ parts.j2  # S_t2 J2
    if model.n1 == 6:
        first = s_t1 @ model.H
    else:
        maps = chain1_maps(model.X, j1)
        if maps is None:
            return None
        first = s_t1 @ j1 @ maps
    a = np.concatenate([first, chain2], axis=2)
    j_braced = np.concatenate([s_t1 @ (np.eye(6) - model.P) @ j1, chain2], axis=2)
    sa = a if rows[0] is None else np.array(rows, dtype=np.float64) @ a
    return Watched(J1=j1, A=a, SA=sa, J_e=parts.j_e, J_braced=j_braced)


def _null_stacks(states: Sequence[BracedState], rows: Sequence[Array | None]) -> Watched[Array] | None:
    """The watched matrices G, S J_e N and J = J_e of several-brace states as stacks, and J_e N.

    N = ``contact_null_space(G)`` of each state from one stacked SVD (the same LAPACK call per matrix), where
    every state keeps every row of G (:func:`~bracekit.kinematics.constraint.full_rank_constraint`) and N has
    one width; None otherwise.
    """
    if any(r is None for r in rows) and not all(r is None for r in rows):
        return None
    found = full_rank_constraint(states, states[0].K)
    if found is None:
        return None
    g = found[0]
    null = stacked_null_spaces(g)  # N (k, n, n − rank G)
    if null is None:
        return None
    j_e = np.array([st.J_e for st in states], dtype=np.float64)
    a = j_e @ null  # J_e N
    sa = a if rows[0] is None else np.array(rows, dtype=np.float64) @ a
    return Watched(G=g, SJN=sa, J_e=j_e, JN=a)


#: The keys of MATRIX_LABELS whose matrix must have full row rank (``rank_ratio``): the task rows a braced step
#: inverts and the stacked constraint, as each chart's ``watched`` flags them.
FULL_ROW_RANK = frozenset({"SA", "G", "SJN"})


def stacked_conditioning(
    states: Sequence[BracedState], rows: Sequence[Array | None], keys: tuple[str, ...]
) -> Conditioning:
    """``states[i].motions.conditioning(rows[i], keys)`` of every state, each matrix kind in one stacked SVD.

    With the ratios, every matrix decomposed as one stack with its singular values (for the run's measures);
    also J_e N where several braces' stacks are formed at once (S J_e N's values for the whole pose: one stack).
    """
    if not states:
        return Conditioning([], Watched())
    formed = None
    if all(len(st.contacts) == 1 for st in states):  # the paper's chart (SplitMotions), formed as stacks
        formed = _split_stacks(states, rows)
    elif all(len(st.contacts) > 1 for st in states):  # the null space of G (NullMotions), formed as stacks
        formed = _null_stacks(states, rows)
    stacks: dict[str, tuple[Array, bool]] = {}  # by key: the stack and whether it needs full row rank
    columns: dict[str, list[float]] = {}
    if formed is not None:
        for key in keys:
            stack = formed.get(key)
            if stack is not None:
                stacks[key] = (stack, key in FULL_ROW_RANK)
    rest = [key for key in keys if key not in stacks]
    if rest:  # each chart forms its own matrices, stacked where they have one shape
        watched: list[dict[str, tuple[Callable[[], Array], bool]]] = [
            st.motions.watched(r) for st, r in zip(states, rows, strict=True)
        ]
        for key in rest:
            ms = [w[key][0]() for w in watched]
            if all(m.shape == ms[0].shape for m in ms):
                stacks[key] = (np.array(ms, dtype=np.float64), watched[0][key][1])
            else:
                columns[key] = stacked_ratios(ms, watched[0][key][1])
    known: dict[int, Array] = {}  # the stacks stay alive while `stacks` holds them
    for key in keys:
        if key not in columns:
            stack, full = stacks[key]
            columns[key] = _ratios(stack, full, known)
    decomposed = Watched.of_keys({key: Decomposed(m, known[id(m)]) for key, (m, _) in stacks.items() if id(m) in known})
    jn = None if formed is None else formed.JN
    if jn is not None and decomposed.JN is None:  # J_e N: S J_e N's singular values for the pose, else its own
        s = known.get(id(jn))
        s = np.asarray(np.linalg.svd(jn, compute_uv=False), dtype=np.float64) if s is None else s
        decomposed = replace(decomposed, JN=Decomposed(jn, s))
    return Conditioning([{key: columns[key][i] for key in keys} for i in range(len(states))], decomposed)
