"""Compliance of the braced robot (Section IV): C1, C2, C̃1, C_e, directional compliance, ellipsoids.

All compliances map a wrench [f; m] (N, N·m) to a small twist/deflection [Δp; Δθ] (m, rad): units
m/N, m/(N·m) = 1/N, rad/N and rad/(N·m). Two models of the bracing-consistent compliance of chain 1:

* ``"projection"``: the paper's C̃1 = (I − P) C1 (I − P) (eq:C1wave_detail).
* ``"constrained"`` (default): the exact first-order static equilibrium with the contact as a bilateral
  constraint, C̃1 = C1 − C1 X (Xᵀ C1 X)⁻¹ Xᵀ C1 (MODEL.md). With a finite environment stiffness k_env the
  inverse becomes (Xᵀ C1 X + I / k_env)⁻¹.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .errors import InputError, UnloadedContactWarning
from .kinematics import BracedState
from .spatial import unit

Array = NDArray[np.float64]
ComplianceModel = Literal["constrained", "projection"]
COMPLIANCE_MODELS: tuple[str, ...] = ("constrained", "projection")

#: Relative eigenvalue of Xᵀ C1 X below which the contact carries no load in that direction.
UNLOADED_TOL = 1e-10


def check_model(model: str) -> ComplianceModel:
    """Validate a compliance-model name."""
    if model not in COMPLIANCE_MODELS:
        raise InputError(f"unknown compliance model '{model}'; choose one of {', '.join(COMPLIANCE_MODELS)}")
    return model  # type: ignore[return-value]


def C1(state: BracedState) -> Array:
    """Free compliance of chain 1 at b, world axes: J1 K1⁻¹ J1ᵀ (6×6), eq:C1_def."""
    j1 = state.J1
    return (j1 / state.K[: state.n1]) @ j1.T


def C2(state: BracedState) -> Array:
    """Compliance of chain 2 at e, {b}'s axes: J2 K2⁻¹ J2ᵀ (6×6), eq:C2_def."""
    j2 = state.J2
    return (j2 / state.K[state.n1 :]) @ j2.T


def constraint_gain(state: BracedState, c1: Array | None = None) -> Array:
    """G = (Xᵀ C1 X + I/k_env)⁻¹ ((6−l)×(6−l)), the contact's stiffness seen through chain 1.

    Directions in which chain 1 cannot move {b} (Xᵀ C1 X singular, rigid environment) carry no load:
    they are dropped (pseudo-inverse) and an UnloadedContactWarning says so.
    """
    c1 = C1(state) if c1 is None else c1
    x = state.X
    m = x.T @ c1 @ x
    k_env = state.braced.brace.environment_stiffness
    if k_env is not None:
        return np.linalg.inv(m + np.eye(m.shape[0]) / k_env)
    # one constraint direction (a frictionless point): the eigen-decomposition of a 1×1 matrix, exactly
    w, v = (m[0], np.ones((1, 1))) if m.shape == (1, 1) else np.linalg.eigh(m)
    scale = max(float(np.trace(c1)), 1e-300)
    good = w > UNLOADED_TOL * scale
    if not np.all(good):
        warnings.warn(
            f"the contact carries no load from chain 1 along {int(np.sum(~good))} constraint direction(s) "
            "(Xᵀ C1 X is singular): chain 1 cannot push {b} there, so the brace does not stiffen it",
            UnloadedContactWarning,
            stacklevel=3,
        )
    vg = v[:, good]
    return (vg / w[good]) @ vg.T


def braced_C1(state: BracedState, model: ComplianceModel = "constrained") -> Array:
    """Bracing-consistent compliance C̃1 of chain 1 at b, world axes (6×6).

    ``projection``: (I − P) C1 (I − P), eq:C1wave_detail. ``constrained``: C1 − C1 X G Xᵀ C1 with
    G = (Xᵀ C1 X)⁻¹ (MODEL.md; the Lagrange-multiplier equilibrium).
    """
    model = check_model(model)
    c1 = C1(state)
    if model == "projection":
        t = np.eye(6) - state.P
        return t @ c1 @ t
    cx = c1 @ state.X
    out = c1 - cx @ constraint_gain(state, c1) @ cx.T
    return 0.5 * (out + out.T)


def end_effector_compliance(state: BracedState, model: ComplianceModel = "constrained") -> Array:
    """C_e = S_t1 C̃1 S_w1 + S_t2 C2 S_w2 (6×6), eq:Ce, with the dual wrench maps S_w = S_tᵀ (erratum).

    Maps a tip wrench [f; m] at e (world axes) to the tip deflection [Δp; Δθ] (world axes).
    """
    s1, s2 = state.S_t1, state.S_t2
    out = s1 @ braced_C1(state, model) @ s1.T + s2 @ C2(state) @ s2.T
    return 0.5 * (out + out.T)


def free_space_compliance(state: BracedState) -> Array:
    """Compliance of the unbraced robot at e: J K⁻¹ Jᵀ (6×6), world axes."""
    j = state.J_e
    return (j / state.K) @ j.T


def directional_compliance(c_e: Array, beta_x: ArrayLike, beta_w: ArrayLike) -> float:
    """C_βx = β_xᵀ C_e β_w (eq:directional_compliance_result); β_x a unit twist, β_w a unit wrench."""
    bx, bw = _unit6(beta_x, "beta_x"), _unit6(beta_w, "beta_w")
    return float(bx @ c_e @ bw)


def compliance_index(c_e: Array, beta_x: ArrayLike) -> float:
    """C_i = ‖β_xᵀ C_e‖₂ (eq:compliance_index): the largest deflection along β_x per unit wrench."""
    return float(np.linalg.norm(_unit6(beta_x, "beta_x") @ c_e))


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


def compliance_ellipsoids(c_e: Array) -> ComplianceEllipsoids:
    """Eigen-decomposition of the translational and rotational diagonal blocks of C_e."""
    out = []
    for block in (c_e[:3, :3], c_e[3:, 3:]):
        w, v = np.linalg.eigh(0.5 * (block + block.T))
        out.append(Ellipsoid(semi_axes=np.clip(w, 0.0, None), axes=v))
    return ComplianceEllipsoids(translational=out[0], rotational=out[1])


def _unit6(v: ArrayLike, what: str) -> Array:
    a = np.asarray(v, dtype=float).reshape(-1)
    if a.size != 6:
        raise InputError(f"{what} must have 6 components [v; ω], got {a.size}")
    try:
        return unit(a, what)
    except ValueError as exc:
        raise InputError(str(exc)) from exc
