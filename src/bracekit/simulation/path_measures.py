"""The measures of a whole run at once, over the stacked matrices of every sample (one brace or several).

:func:`measure_path` gives what :func:`~bracekit.simulation.samples.measure` gives each sample, one code path
for any number of braces.

The formulas are the reference's, applied to stacks (N, ·, ·) of the per-sample matrices: C_e under each model
(eq:Ce; ``constrained`` over each sample's independent rows of the stacked constraint G), C_i = ‖β_xᵀ C_e‖
(eq:compliance_index), k (eq:manip) and Πσ, σ_min of the braced task Jacobian, θ_z (eq:theta), the region
radius and surface distance of every brace, the joint-limit excursion. A stacked SVD, solve or product runs the
same LAPACK / BLAS routine per matrix as the single call, so the results equal the per-sample path to round-off
(tested to 1e-12 relative in tests/simulation/test_path_measures.py). Each stack's singular values are taken
once for the ratios and the measures that share it; the stacked constraint G is built for the whole path at
once where every sample keeps every row; the link clearance is the path's
:func:`~bracekit.kinematics.clearance.link_clearances` (compiled where numba is installed).

Whenever the batch cannot certify a sample (a singular Jacobian, a non-finite compliance, a β_x that is not a
finite non-zero twist, samples whose matrices differ in shape), it measures the samples one by one with the
reference, which raises the same typed error at the same sample as before. The warnings of a state's stacked
constraint (a redundant or unloaded contact) are given once per state, as the reference gives them.

A run hands over what its guard decomposed already (:class:`Known`: the stacks of the braced task Jacobian and
of J_e with their singular values, from the same LAPACK call per matrix): k and k_free are taken from them, and
one brace's chain-split factors come as stacks (:func:`~bracekit.simulation.stacked_ratios.split_parts`), not
from each state's ``split``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import NamedTuple, cast

import numpy as np
from numpy.typing import NDArray

from bracekit.errors import BracekitError, ContactError
from bracekit.kinematics import BracedRobot, BracedState
from bracekit.kinematics.clearance import link_clearances
from bracekit.kinematics.constraint import full_rank_constraint
from bracekit.kinematics.motions import NullMotions
from bracekit.resolution.task_space import TaskSpace
from bracekit.simulation.samples import ContactSeries, Samples, compliance_models, measure
from bracekit.simulation.stacked_ratios import FULL_ROW_RANK, Decomposed, split_parts
from bracekit.tolerances import MEASURE_SINGULAR_RATIO

Array = NDArray[np.float64]

__all__ = ["Known", "measure_path", "path_ratios"]


class _Former(NamedTuple):
    """How the path forms a recorded matrix of one state (for its σ_min/σ_max over the whole path at once).

    Attributes:
        form: the matrix of a state (the whole pose's rows for a task-row matrix).
        task_rows: whether the matrix is the task rows S(⁰R_e) of `form` (S A, S J_e N), S the space's selection.
    """

    form: Callable[[BracedState], Array]
    task_rows: bool = False


#: The recorded matrices, by key of MATRIX_LABELS: one brace's J1, A, S A and J̃, several braces' G (independent
#: rows) and S J_e N, and J = J_e with any number of braces. Those of FULL_ROW_RANK (G, S A, S J_e N) take
#: rank_ratio, the others singular_ratio.
_FORMERS: dict[str, _Former] = {
    "J": _Former(lambda st: st.J_e),
    "J1": _Former(lambda st: st.split.J1),
    "A": _Former(lambda st: st.split.A),
    "J_braced": _Former(lambda st: st.split.J_braced),
    "G": _Former(lambda st: cast(NullMotions, st.motions).G),
    "SA": _Former(lambda st: st.split.A, task_rows=True),
    "SJN": _Former(lambda st: st.motions.A, task_rows=True),
}


class Known(NamedTuple):
    """The braced task Jacobian (``motions.task_jacobian``) and J_e of every state, decomposed by the run's guard.

    None for a matrix the guard did not decompose (S J_e N of a task space other than the pose is not J_e N).
    """

    task: Decomposed | None
    tip: Decomposed | None


class _Inputs(NamedTuple):
    """What a run gives each sample besides its state, in :func:`measure`'s order."""

    beta_x: Sequence[Array]
    task_error: Sequence[float]
    sigma_ratio: Sequence[dict[str, float]]
    joint_step: Sequence[float]


class _UncertifiedError(Exception):
    """The batch cannot vouch for a sample: the reference measures them one by one."""


def measure_path(
    braced: BracedRobot,
    states: Sequence[BracedState],
    beta_x: Sequence[Array],
    task_error: Sequence[float],
    sigma_ratio: Sequence[dict[str, float]],
    joint_step: Sequence[float],
    known: Known | None = None,
) -> tuple[Samples | None, int, BracekitError | None]:
    """The measures of `states` in order: (Samples of the first `count` states or None if 0, count, error).

    `error` is the typed error of the first state that cannot be measured (None if every one is), exactly as
    :func:`~bracekit.simulation.samples.measure` raises it for that state; `count` the states measured before it.
    `known`: the stacks of every state's braced task Jacobian and J_e with their singular values, if decomposed.
    """
    if not states:
        return None, 0, None
    inputs = _Inputs(beta_x, task_error, sigma_ratio, joint_step)
    try:
        return _batch(braced, states, inputs, known), len(states), None
    except (_UncertifiedError, BracekitError, FloatingPointError, np.linalg.LinAlgError):
        return _one_by_one(braced, states, inputs)


def path_ratios(
    states: Sequence[BracedState], space: TaskSpace, keys: tuple[str, ...], known: Sequence[dict[str, float]]
) -> list[dict[str, float]]:
    """σ_min/σ_max of every matrix in `keys` at each state, in the order of `keys` (guards.sigma_ratios).

    `known`: the ratios already taken at each state (the run's guard); the others are computed here, each
    matrix as one stacked SVD over the states: σ_min/σ_max (0 for a zero matrix) as ``singular_ratio``, and for
    G, S A and S J_e N as ``rank_ratio`` (0 with more rows than columns, 1 without rows).
    """
    if not states:
        return []
    missing = [key for key in keys if key not in known[0]]
    found: dict[str, Array] = {}
    for key in missing:
        ranked = key in FULL_ROW_RANK
        try:
            stack = _matrices(states, space, key)
        except (ValueError, AttributeError, BracekitError):
            continue
        if stack is None or stack.ndim != 3:
            continue
        if ranked and (stack.shape[1] > stack.shape[2] or stack.shape[1] == 0):  # rank_ratio: 0, or 1 without rows
            found[key] = np.full(len(states), 1.0 if stack.shape[1] == 0 else 0.0)
            continue
        s = _singular_values(stack)
        with np.errstate(all="ignore"):
            found[key] = np.where(s[:, 0] > 0, s[:, -1] / s[:, 0], 0.0) if s.shape[1] else np.zeros(len(states))
    rest = tuple(key for key in missing if key not in found)
    columns = {key: values.tolist() for key, values in found.items()}
    out = []
    for i, (st, have) in enumerate(zip(states, known, strict=True)):
        more = st.motions.conditioning(None if space.is_pose else space.selection(st.R_e), rest) if rest else {}
        out.append(
            {key: have[key] if key in have else columns[key][i] if key in columns else more[key] for key in keys}
        )
    return out


def _matrices(states: Sequence[BracedState], space: TaskSpace, key: str) -> Array | None:
    """The matrix `key` of every state as one stack (N, ·, ·), its task rows S(⁰R_e) for S A and S J_e N."""
    former = _FORMERS.get(key)
    if former is None:
        return None
    found = np.array([former.form(st) for st in states], dtype=np.float64)
    if not former.task_rows or space.is_pose:
        return found
    return np.array([space.selection(st.R_e) for st in states], dtype=np.float64) @ found


#: The stacks whose singular values were taken last, with them: J_e's SVD serves both the ratio σ_min/σ_max of J
#: (path_ratios) and k of J_e (measure_path) of the same states, A's both A and S A of a pose task.
_TAKEN: list[tuple[Array, Array]] = []


def _singular_values(stack: Array) -> Array:
    """The singular values (N, min(m, n)) of a stack (N, m, n), descending: one LAPACK SVD per matrix.

    A stack equal entry by entry to one of the last few taken gets their values (the same SVD, not redone).
    """
    for held, found in _TAKEN:
        if held.shape == stack.shape and np.array_equal(held, stack):
            return found
    found = np.asarray(np.linalg.svd(stack, compute_uv=False), dtype=np.float64)
    _TAKEN.insert(0, (stack, found))
    del _TAKEN[4:]
    return found


def _one_by_one(
    braced: BracedRobot, states: Sequence[BracedState], inputs: _Inputs
) -> tuple[Samples | None, int, BracekitError | None]:
    rows = []
    error: BracekitError | None = None
    each = zip(states, inputs.beta_x, inputs.task_error, inputs.sigma_ratio, inputs.joint_step, strict=True)
    for st, beta, err, ratios, step in each:
        try:
            rows.append(measure(st, beta, err, ratios, step))
        except BracekitError as exc:
            error = exc
            break
    return (Samples.stack(braced, rows) if rows else None), len(rows), error


def _stack(arrays: Sequence[Array]) -> Array:
    """The arrays as one stack; _UncertifiedError when their shapes differ or an entry is not finite."""
    try:
        out = np.array(arrays, dtype=np.float64)
    except ValueError as exc:
        raise _UncertifiedError from exc
    if out.dtype != np.float64 or not np.isfinite(out).all():
        raise _UncertifiedError
    return out


def _finite(a: Array) -> Array:
    if not np.isfinite(a).all():
        raise _UncertifiedError
    return a


def _t(a: Array) -> Array:
    return np.swapaxes(a, -1, -2)


def _sym(out: Array) -> Array:
    return _finite(0.5 * (out + _t(out)))


def _unit(betas: Array) -> Array:
    """Each row of β_x (N, 6) over its norm (spatial.unit); _UncertifiedError where the reference would refuse it."""
    big = np.max(np.abs(betas), axis=1)
    if not ((big > 1e-150) & (big < 1e150)).all():
        raise _UncertifiedError
    return cast(Array, betas / np.sqrt(np.einsum("ij,ij->i", betas, betas))[:, None])


def _frobenius(j: Array, s: Array | None = None) -> Array:
    """K = √(tr(JJᵀ) tr((JJᵀ)⁻¹)) / 6 (eq:manip) of each 6×n J (N, 6, n), as frobenius_condition takes it.

    `s`: the singular values of the stack (N, 6), if taken.
    """
    s = _singular_values(j) if s is None else s
    if s.shape[-1] < 6 or not (s[:, -1] > MEASURE_SINGULAR_RATIO * s[:, 0]).all():
        raise _UncertifiedError
    with np.errstate(over="raise", under="ignore"):
        return np.asarray(np.sqrt(np.sum(s**2, axis=1) * np.sum(s**-2, axis=1)) / 6.0)


def _batch(braced: BracedRobot, states: Sequence[BracedState], inputs: _Inputs, known: Known | None) -> Samples:
    """The samples' measures; _UncertifiedError (or the reference's error) where the batch cannot vouch for them."""
    k = states[0].K
    q = np.array([st.q for st in states])
    task, tip = (None, None) if known is None else known
    if tip is not None and len(tip.stack) == len(states):
        j_e, s_e = _finite(tip.stack), tip.s
    else:
        j_e, s_e = _stack([st.J_e for st in states]), None
    if task is not None and len(task.stack) == len(states):
        jac, s_task = _finite(task.stack), task.s
    else:
        jac, s_task = _stack([st.motions.task_jacobian for st in states]), None
    betas = _unit(_stack([np.asarray(b, dtype=np.float64).reshape(-1) for b in inputs.beta_x]))
    if betas.shape[1] != 6:
        raise _UncertifiedError
    with np.errstate(all="ignore"):
        jk = j_e / k
        free = jk @ _t(j_e)
        models = {"free": _finite(free)}
        for model in compliance_models(braced):
            models[model] = _constrained(states, jk, free, k) if model == "constrained" else _projection(states, k)
    ci = {key: _finite(np.linalg.norm(np.einsum("ni,nij->nj", betas, c), axis=1)) for key, c in models.items()}
    st_ = np.linalg.svd(jac[:, :3], compute_uv=False)
    so_ = np.linalg.svd(jac[:, 3:], compute_uv=False)
    with np.errstate(over="raise", under="ignore"):
        prod_t, prod_o = np.prod(st_, axis=1), np.prod(so_, axis=1)
    series = {
        "prod_sigma_t": _finite(prod_t),
        "prod_sigma_o": _finite(prod_o),
        "sigma_t_min": st_.min(axis=1),
        "sigma_o_min": so_.min(axis=1),
        "k": _frobenius(jac, s_task),
        "k_free": _frobenius(j_e, s_e),
        "joint_limit_violation": np.max(
            np.maximum(0.0, np.maximum(braced.robot.lower - q, q - braced.robot.upper)), axis=1
        ),
        "task_error": np.array(inputs.task_error, dtype=np.float64),
        "joint_step": np.array(inputs.joint_step, dtype=np.float64),
        "link_clearance": _clearance(states),
    }
    contacts = []
    for i, brace in enumerate(braced.braces):
        z_b = np.array([st.contacts[i].R_b for st in states])[:, :, 2]  # ẑ_b, the third column of each ⁰R_b_i
        b = np.array([st.contacts[i].b for st in states])
        n = brace.surface.normal
        cross = np.stack(
            [
                n[1] * z_b[:, 2] - n[2] * z_b[:, 1],
                n[2] * z_b[:, 0] - n[0] * z_b[:, 2],
                n[0] * z_b[:, 1] - n[1] * z_b[:, 0],
            ],
            axis=1,
        )
        contacts.append(
            ContactSeries(
                theta_z=np.arctan2(np.linalg.norm(cross, axis=1), z_b @ n),
                region_radius=np.linalg.norm(b - brace.surface.point, axis=1),
                surface_distance=_finite((b - brace.surface.point) @ n),  # n̂ᵀ(b − c), Surface.signed_distance
            )
        )
    keys = tuple(inputs.sigma_ratio[0])
    return Samples(
        braced=braced,
        series=series,
        Ci=ci,
        sigma_ratio={key: np.array([r[key] for r in inputs.sigma_ratio], dtype=np.float64) for key in keys},
        contacts=tuple(contacts),
    )


def _constrained(states: Sequence[BracedState], jk: Array, free: Array, k: Array) -> Array:
    """C_e of every sample, constrained_compliance's formula over each sample's independent rows of G."""
    found = full_rank_constraint(states, k)
    if found is None:
        cons = [st.constraint for st in states]
        rows = cons[0].independent
        if any(c.independent != rows for c in cons):
            raise _UncertifiedError
        idx = list(rows)
        found = (_stack([c.G[idx] for c in cons]), cons[0].compliance[idx]) if rows else None
    out = free
    if found is not None:
        g, d = found
        m = _finite((g / k) @ _t(g) + np.diag(d))
        b = jk @ _t(g)
        out = out - b @ np.linalg.solve(m, _t(b))
    return _sym(out)


def _projection(states: Sequence[BracedState], k: Array) -> Array:
    """C_e = S_t1 (I − P) C1 (I − P) S_t1ᵀ + S_t2 C2 S_t2ᵀ of every sample (eq:Ce, the paper's model)."""
    parts = split_parts(states)
    if parts is None:
        raise _UncertifiedError
    n1 = parts.j1.shape[2]
    j1, j2 = _finite(parts.j1), _finite(parts.j2)
    t = np.eye(6) - states[0].braced.split.P
    s1, s2 = parts.s_t1, parts.s_t2
    c1 = (j1 / k[:n1]) @ _t(j1)
    c1t = t @ c1 @ t
    c2 = (j2 / k[n1:]) @ _t(j2)
    return _sym(s1 @ c1t @ _t(s1) + s2 @ c2 @ _t(s2))


def _clearance(states: Sequence[BracedState]) -> Array:
    """Link_clearance of each state, the path at once (inf where its model does not apply)."""
    try:
        return link_clearances(states[0].braced, [st.q for st in states])[0]
    except ContactError:
        return np.full(len(states), np.inf)
