"""σ_min/σ_max of the matrices a run watches, over many samples at once (the guard of :mod:`bracekit.simulation.loop`).

The numbers are those of :meth:`bracekit.kinematics.motions.BracedMotions.conditioning` at each sample, to the
last bit: one SVD over the stack of the matrices of each shape is one LAPACK call per matrix, and NumPy's stacked
matrix product is one BLAS call per matrix. With one brace the watched matrices J1, A (eq:braced_kin),
S A, J = J_e and J̃ (eq:J_wave) are formed as stacks, with the products and their order of
:class:`~bracekit.kinematics.split.ChainSplit` (S_t1, S_t2 and J2 of eq:twists, eq:J2); otherwise each chart
forms its own (:meth:`~bracekit.kinematics.motions.BracedMotions.watched`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import cast

import numpy as np
from numpy.typing import NDArray

from bracekit.kinematics.motions import BracedMotions, SplitMotions

Array = NDArray[np.float64]

__all__ = ["stacked_conditioning", "stacked_ratios"]


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


def _split_stacks(charts: Sequence[SplitMotions], rows: Sequence[Array | None]) -> dict[str, tuple[Array, bool]] | None:
    """The watched matrices of one-brace charts as (k, …) stacks; None where a chart forms its own.

    With n1 ≠ 6, A = S_t1 J1 dq1/db̃ takes each chart's own dq1/db̃ (``chain1_map``). None where the charts
    split different models, a task-space selection is None at some samples only, dq1/db̃ changes shape, or
    b − e or ⁰R_b is not finite (``twist_shift`` and ``twist_rotate`` raise then).
    """
    model = charts[0].split.model
    if any(c.split.model is not model for c in charts):
        return None
    if any(r is None for r in rows) and not all(r is None for r in rows):
        return None
    states = [c.split.state for c in charts]
    n1, k = model.n1, len(states)
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
    chain2 = s_t2 @ (back @ j_e[:, :, n1:])  # S_t2 J2
    if n1 == 6:
        first = s_t1 @ model.H
    else:
        maps = [c.split.chain1_map for c in charts]
        if any(m.shape != maps[0].shape for m in maps):
            return None
        first = s_t1 @ j1 @ np.array(maps)
    a = np.concatenate([first, chain2], axis=2)
    j_braced = np.concatenate([s_t1 @ (np.eye(6) - model.P) @ j1, chain2], axis=2)
    sa = a if rows[0] is None else np.array(rows, dtype=np.float64) @ a
    return {"J1": (j1, False), "A": (a, False), "SA": (sa, True), "J": (j_e, False), "J_braced": (j_braced, False)}


def stacked_conditioning(
    motions: Sequence[BracedMotions], rows: Sequence[Array | None], keys: tuple[str, ...]
) -> list[dict[str, float]]:
    """``motions[i].conditioning(rows[i], keys)`` of every chart, each matrix kind in one stacked SVD."""
    if not motions:
        return []
    stacks = None
    if all(type(m) is SplitMotions for m in motions):
        stacks = _split_stacks(motions, rows)  # type: ignore[arg-type]
    if stacks is not None:  # the stacks stay alive while `known` holds their ids
        known: dict[int, Array] = {}
        columns = {key: _ratios(*stacks[key], known) for key in keys}
    else:
        watched: list[dict[str, tuple[Callable[[], Array], bool]]] = [
            m.watched(r) for m, r in zip(motions, rows, strict=True)
        ]
        columns = {key: stacked_ratios([w[key][0]() for w in watched], watched[0][key][1]) for key in keys}
    return [{key: columns[key][i] for key in keys} for i in range(len(motions))]
