"""Compliance of the braced robot (Section IV): C1, C2, C̃1, C_e, directional compliance, ellipsoids.

All compliances map a wrench [f; m] (N, N·m) to a small twist/deflection [Δp; Δθ] (m, rad): units
m/N, m/(N·m) = 1/N, rad/N and rad/(N·m). Two models of the bracing-consistent compliance of chain 1:

* ``"projection"``: the paper's C̃1 = (I − P) C1 (I − P) (eq:C1wave_detail).
* ``"constrained"`` (default): the exact first-order static equilibrium with the contact as a bilateral
  constraint, C̃1 = C1 − C1 X (Xᵀ C1 X)⁻¹ Xᵀ C1 (docs/model.md). With a finite environment stiffness k_env the
  inverse becomes (Xᵀ C1 X + I / k_env)⁻¹.

The ``constrained`` C_e of any number of braces is :func:`constrained_compliance`, over the stacked constraint
G of the state; with several braces the chain does not split at one {b}, so C1, C2, C̃1 and the
``projection`` model (the state's ``split``) are defined for one brace and raise ContactError otherwise.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from typing import Literal, TypeVar, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from bracekit._linalg import as_array, finite_math, show
from bracekit.errors import ContactError, InputError, NumericalError, UnloadedContactWarning
from bracekit.kinematics import BracedState, ChainSplit
from bracekit.kinematics.constraint import GKG
from bracekit.spatial import unit
from bracekit.tolerances import UNLOADED_TOL

Array = NDArray[np.float64]
ComplianceModel = Literal["constrained", "projection"]
COMPLIANCE_MODELS: tuple[str, ...] = ("constrained", "projection")
_T = TypeVar("_T")


def check_model(model: str) -> ComplianceModel:
    """Validate a compliance-model name."""
    if not isinstance(model, str) or model not in COMPLIANCE_MODELS:
        raise InputError(f"unknown compliance model {show(model)}; choose one of {', '.join(COMPLIANCE_MODELS)}")
    return cast(ComplianceModel, model)


def check_state(state: object) -> BracedState:
    """`state` if it is a BracedState (from ``BracedRobot.state(q)``); InputError otherwise."""
    if not isinstance(state, BracedState):
        raise InputError(f"expected a BracedState (from BracedRobot.state(q)), got {type(state).__name__}")
    return state


def check_split(state: object, what: str = "C1, C2 and C̃1 are") -> ChainSplit:
    """The chain split of a one-brace state; ContactError naming `what` (with its verb) with several braces."""
    st = check_state(state)
    if len(st.contacts) != 1:
        raise ContactError(
            f"{what} defined for one brace (the chain splits at {{b}}); this state has {len(st.contacts)} "
            "braces: use end_effector_compliance(state, 'constrained')"
        )
    return st.split


def compliance_matrix(c_e: ArrayLike, what: str = "the compliance C_e") -> Array:
    """`c_e` as a finite 6×6 float array; InputError naming `what` otherwise."""
    return as_array(c_e, what, (6, 6))


def c1_unchecked(state: BracedState) -> Array:
    """J1 K1⁻¹ J1ᵀ without the finiteness check: inf or NaN where it overflows, and no warning.

    For callers that check what they build from it, with their own message.
    """
    j1 = check_split(state).J1
    with np.errstate(all="ignore"):
        return (j1 / state.K[: state.split.n1]) @ j1.T


def C1(state: BracedState) -> Array:
    """Free compliance of chain 1 at b, world axes: J1 K1⁻¹ J1ᵀ (6×6), eq:C1_def. NumericalError on overflow."""
    return check_finite(c1_unchecked(state), "C1")


def C2(state: BracedState) -> Array:
    """Compliance of chain 2 at e, {b}'s axes: J2 K2⁻¹ J2ᵀ (6×6), eq:C2_def. NumericalError on overflow."""
    return check_finite(_c2(check_state(state)), "C2")


def _c2(state: BracedState) -> Array:
    j2 = check_split(state).J2
    with np.errstate(all="ignore"):
        return (j2 / state.K[state.split.n1 :]) @ j2.T


def check_finite(a: _T, what: str) -> _T:
    """`a` itself if every entry is finite; NumericalError naming `what` otherwise (no silent NaN or inf)."""
    if not (math.isfinite(a) if isinstance(a, float) else np.isfinite(np.asarray(a)).all()):
        raise NumericalError(
            f"{what} is not finite: the compliance overflows (joint stiffnesses too small for 1/K or lengths too large)"
        )
    return a


def warn_unloaded(count: int, configurations: int | None = None, stacklevel: int = 2) -> None:
    """The UnloadedContactWarning: `count` constraint directions, or `count` of `configurations`, carry no load."""
    where = (
        f"along {count} constraint direction(s)"
        if configurations is None
        else f"at {count} of {configurations} configurations"
    )
    warnings.warn(
        f"the contact carries no load from chain 1 {where} (Xᵀ C1 X is singular): "
        "chain 1 cannot push {b} there, so the brace does not stiffen it",
        UnloadedContactWarning,
        stacklevel=stacklevel + 1,
    )


def loaded_gain(m: Array, trace_c1: ArrayLike, k_env: float | None = None) -> tuple[Array, NDArray[np.int_]]:
    """G = (Xᵀ C1 X + I/k_env)⁻¹ and the number of unloaded directions, for one m = Xᵀ C1 X or a stack (N, c, c).

    With a rigid environment (k_env None) G is the inverse over the loaded directions only: eigenvalues of m
    at or below UNLOADED_TOL · tr(C1) (`trace_c1`: a number, or one per matrix) are dropped and counted.
    The count has m's stack shape (an integer for one m). Raises NumericalError if m or tr(C1) is not finite.
    """
    check_finite(m, GKG)
    check_finite(trace_c1, "tr(C1)")
    if k_env is not None:
        inv = np.asarray(np.linalg.inv(m + np.eye(m.shape[-1]) / k_env), dtype=np.float64)
        return inv, np.zeros(m.shape[:-2], dtype=np.int_)
    # one constraint direction (a frictionless point): m is its own eigenvalue, exactly
    w, v = (m[..., 0], np.ones(m.shape)) if m.shape[-1] == 1 else np.linalg.eigh(m)
    good = w > UNLOADED_TOL * np.maximum(trace_c1, 1e-300)[..., None]
    gain: Array = (v / np.where(good, w, np.inf)[..., None, :]) @ np.swapaxes(v, -1, -2)
    return gain, np.asarray(np.sum(~good, axis=-1), dtype=np.int_)


def constraint_gain(state: BracedState, c1: Array | None = None) -> Array:
    """G = (Xᵀ C1 X + I/k_env)⁻¹ ((6−l)×(6−l)), the contact's stiffness seen through chain 1.

    Directions in which chain 1 cannot move {b} (Xᵀ C1 X singular, rigid environment) carry no load:
    they are dropped (pseudo-inverse) and an UnloadedContactWarning says so. NumericalError if C1 is not finite.
    """
    c1 = c1_unchecked(state) if c1 is None else c1
    x = state.split.X
    with np.errstate(all="ignore"):  # a non-finite Xᵀ C1 X raises NumericalError in loaded_gain
        g, unloaded = loaded_gain(x.T @ c1 @ x, np.trace(c1), state.braced.split.brace.environment_stiffness)
    if unloaded:
        warn_unloaded(int(unloaded), stacklevel=3)
    return g


def braced_c1_unchecked(state: BracedState, model: ComplianceModel, c1: Array) -> Array:
    """C̃1 of :func:`braced_C1` from C1, without the final finiteness check (the callers check)."""
    with np.errstate(all="ignore"):
        if model == "projection":
            t = np.eye(6) - state.split.P
            return t @ c1 @ t
        cx = c1 @ state.split.X
        out = c1 - cx @ constraint_gain(state, c1) @ cx.T
        return 0.5 * (out + out.T)


def braced_C1(state: BracedState, model: ComplianceModel = "constrained") -> Array:
    """Bracing-consistent compliance C̃1 of chain 1 at b, world axes (6×6).

    ``projection``: (I − P) C1 (I − P), eq:C1wave_detail. ``constrained``: C1 − C1 X G Xᵀ C1 with
    G = (Xᵀ C1 X)⁻¹ (docs/model.md; the Lagrange-multiplier equilibrium). NumericalError on overflow.
    """
    model = check_model(model)
    return check_finite(braced_c1_unchecked(state, model, c1_unchecked(state)), "C̃1")


def end_effector_compliance(state: BracedState, model: ComplianceModel = "constrained") -> Array:
    """C_e (6×6) of the state: tip wrench [f; m] at e (world axes) → tip deflection [Δp; Δθ] (world axes).

    ``constrained`` (any number of braces): :func:`constrained_compliance`. ``projection`` (one brace, the
    paper's model): C_e = S_t1 C̃1 S_w1 + S_t2 C2 S_w2, eq:Ce, with the dual wrench maps S_w = S_tᵀ (erratum)
    and C̃1 = (I − P) C1 (I − P); ContactError with several braces (it needs the chain split).
    Raises NumericalError if it overflows float64.
    """
    model = check_model(model)
    if model == "constrained":
        return constrained_compliance(state)
    split = check_split(state, "the projection model (the paper's C̃1) is")
    c1t = braced_c1_unchecked(state, model, c1_unchecked(state))
    with np.errstate(all="ignore"):  # an overflow gives inf or NaN, which check_finite refuses
        s1, s2 = split.S_t1, split.S_t2
        out = s1 @ c1t @ s1.T + s2 @ _c2(state) @ s2.T
        return check_finite(0.5 * (out + out.T), "C_e")


def constrained_compliance(state: BracedState) -> Array:
    """C_e of N ≥ 1 braces: the exact first-order equilibrium with every contact as a constraint (6×6), eq:Ce.

    C_e = J_e K⁻¹ J_eᵀ − J_e K⁻¹ Gᵀ (G K⁻¹ Gᵀ + D)⁻¹ G K⁻¹ J_eᵀ, over the independent rows of the stacked
    constraint G = [X_1ᵀ J_b1; X_2ᵀ J_b2; …] (``state.constraint``: dependent rigid rows are dropped with a
    RedundantContactWarning, rows carrying no load with an UnloadedContactWarning); D = diag(1/k_env) of each
    row's brace, 0 for a rigid contact. Maps a tip wrench [f; m] at e (world axes) to the tip deflection
    [Δp; Δθ] (world axes); with one brace it is the paper's C_e with the ``constrained`` C̃1 (docs/model.md).
    NumericalError on overflow.
    """
    con = check_state(state).constraint
    rows = list(con.independent)
    k, j_e = state.K, state.J_e
    with np.errstate(all="ignore"):  # an overflow gives inf or NaN, which check_finite refuses
        jk = j_e / k
        out = jk @ j_e.T
        if rows:
            g = con.G[rows]
            m = (g / k) @ g.T + np.diag(con.compliance[rows])
            b = jk @ g.T
            out = out - b @ np.linalg.solve(check_finite(m, "G K⁻¹ Gᵀ"), b.T)
        return check_finite(0.5 * (out + out.T), "C_e")


def free_space_compliance(state: BracedState) -> Array:
    """Compliance of the unbraced robot at e: J K⁻¹ Jᵀ (6×6), world axes."""
    j = check_state(state).J_e
    with np.errstate(all="ignore"):
        return check_finite((j / state.K) @ j.T, "the free-space compliance J K⁻¹ Jᵀ")


def directional_compliance(c_e: ArrayLike, beta_x: ArrayLike, beta_w: ArrayLike) -> float:
    """C_βx = β_xᵀ C_e β_w (eq:directional_compliance_result); β_x a unit twist, β_w a unit wrench.

    `c_e` is a 6×6 compliance (e.g. :func:`end_effector_compliance`); β_x and β_w are scaled to unit length.
    """
    c = compliance_matrix(c_e)
    bx, bw = unit6(beta_x, "beta_x"), unit6(beta_w, "beta_w")
    with np.errstate(all="ignore"):
        return float(check_finite(bx @ c @ bw, "the directional compliance"))


def compliance_index(c_e: ArrayLike, beta_x: ArrayLike) -> float:
    """C_i = ‖β_xᵀ C_e‖₂ (eq:compliance_index): the largest deflection along β_x per unit wrench.

    `c_e` is a 6×6 compliance; β_x (6,) is scaled to unit length.
    """
    c = compliance_matrix(c_e)
    beta = unit6(beta_x, "beta_x")
    with np.errstate(all="ignore"):
        return float(check_finite(np.linalg.norm(beta @ c), "the compliance index"))


@dataclass(frozen=True)
class Ellipsoid:
    """Principal axes of a 3×3 compliance block: ``axes[:, i]`` (unit, world) has ``semi_axes[i]``.

    semi_axes are the block's eigenvalues, ascending: deflection per unit load along each axis.
    """

    semi_axes: Array
    axes: Array


@dataclass(frozen=True)
class ComplianceEllipsoids:
    """Translational (m/N) and rotational (rad/(N·m)) compliance ellipsoids of C_e."""

    translational: Ellipsoid
    rotational: Ellipsoid


def compliance_ellipsoids(c_e: ArrayLike) -> ComplianceEllipsoids:
    """Eigen-decomposition of the translational and rotational diagonal blocks of a 6×6 compliance C_e."""
    c = compliance_matrix(c_e)
    out = []
    with finite_math("the compliance ellipsoids"):
        for block in (c[:3, :3], c[3:, 3:]):
            w, v = np.linalg.eigh(0.5 * (block + block.T))
            out.append(Ellipsoid(semi_axes=np.clip(w, 0.0, None), axes=v))
    return ComplianceEllipsoids(translational=out[0], rotational=out[1])


def unit6(v: ArrayLike, what: str) -> Array:
    """`v` (6 numbers [v; ω], not all zero) scaled to unit length; InputError naming `what` otherwise."""
    if type(v) is np.ndarray and v.dtype == np.float64 and v.shape == (6,):  # a run's β_x(t), once a step
        values = v.tolist()
        big = max(map(abs, values))
        if 1e-150 < big < 1e150 and math.isfinite(sum(values)):  # ‖v‖ neither overflows nor underflows: unit's
            return np.asarray(v / math.sqrt(float(v.dot(v))), dtype=np.float64)
    a = as_array(v, what, finite=False).reshape(-1)
    if a.size != 6:
        raise InputError(f"{what} must have 6 components [v; ω], got {a.size}")
    return unit(a, what)
