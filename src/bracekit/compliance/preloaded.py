"""The preloaded (second-order) tip compliance: the constrained model on the loaded equilibrium's tangent stiffness.

The joints are springs τ = K (q_s − q) that hold the robot at q under gravity, a dead tip wrench w0 and the
contact's preload f_c0 = P [n̂; 0]: τ = g(q) − J_eᵀ w0 − J_bᵀ f_c0. At fixed set points q_s a small tip wrench
δw then meets the tangent stiffness K_t = K + ∂g/∂q − ∂(J_eᵀ w0)/∂q − ∂(J_bᵀ f_c0)/∂q (S.-F. Chen and
I. Kao, "Conservative congruence transformation for joint and Cartesian stiffness matrices of robotic hands
and fingers", The International Journal of Robotics Research, 2000), not K alone as in the first-order
models. docs/model.md, "The preloaded compliance", derives the signs and the treatment of dead moments.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike, NDArray

from bracekit._linalg import as_array, as_number, finite_math, show
from bracekit.compliance.first_order import (
    COMPLIANCE_MODELS,
    ComplianceModel,
    c1_unchecked,
    check_finite,
    check_model,
    end_effector_compliance,
    free_space_compliance,
    warn_unloaded,
)
from bracekit.errors import InputError, SingularityError, UnstableEquilibriumError
from bracekit.kinematics import BracedRobot, BracedState
from bracekit.tolerances import UNLOADED_TOL

Array = NDArray[np.float64]

__all__ = ["loaded_free_space_compliance", "preloaded_compliance", "run_compliance", "tangent_stiffness"]


def _check(braced: object, gravity: object, wrench: ArrayLike | None) -> tuple[BracedRobot, Array]:
    if not isinstance(braced, BracedRobot):
        raise InputError(f"expected a BracedRobot, got {type(braced).__name__}")
    if not isinstance(gravity, bool):
        raise InputError(f"gravity must be True or False, got {show(gravity)}")
    w0 = np.zeros(6) if wrench is None else as_array(wrench, "the tool wrench [f; m] (N, N·m)", (6,))
    return braced, w0


def tangent_stiffness(
    state: BracedState, preload: float, *, gravity: bool = False, wrench: ArrayLike | None = None
) -> Array:
    """K_t = K + ∂g/∂q − ∂(J_eᵀ w0)/∂q − P ∂(J_b,vᵀ n̂)/∂q (n×n, N·m/rad) at the state's loaded equilibrium.

    Args:
        state: ``braced.state(q, hessians=True)``.
        preload: P ≥ 0 (N), the contact force [P n̂; 0] of the surface on the robot at b.
        gravity: include ∂g/∂q of Pinocchio's generalized gravity (the model's gravity vector and masses).
        wrench: w0 = [f; m] (6,), the dead tool wrench on the robot at e (world axes; N, N·m); default none.

    Returns:
        K_t. The terms of K, gravity, the tool force and the preload are Hessians of potentials and are
        symmetrised (round-off only); the tool moment's term −∂(J_e,ωᵀ m)/∂q is not symmetric (a dead moment
        is not conservative) and is kept as it is.
    """
    if not isinstance(state, BracedState) or state.dJ_e is None or state.split.dJ_b is None:
        raise InputError("tangent_stiffness needs a BracedState with Hessians: braced.state(q, hessians=True)")
    p = as_number(preload, "the preload (the contact pushes)", nonnegative=True, unit="N")
    braced, w0 = _check(state.braced, gravity, wrench)
    nhat = braced.split.brace.surface.normal
    with finite_math("the tangent stiffness"):
        k_sym = np.diag(state.K) - np.einsum("r,rik->ik", w0[:3], state.dJ_e[:3])
        k_sym -= p * np.einsum("r,rik->ik", nhat, state.split.dJ_b[:3])
        if gravity:
            model = braced.robot.model
            k_sym += pin.computeGeneralizedGravityDerivatives(model, model.createData(), state.q)
        k_t: Array = 0.5 * (k_sym + k_sym.T) - np.einsum("r,rik->ik", w0[3:], state.dJ_e[3:])
    return k_t


def _loaded_directions(state: BracedState, k_env: float | None) -> Array:
    """X, with the unloaded directions dropped (rigid environment) as the ``constrained`` model drops them."""
    x = state.split.X
    if k_env is not None:
        return x
    c1 = c1_unchecked(state)
    with np.errstate(all="ignore"):
        m = check_finite(x.T @ c1 @ x, "Xᵀ C1 X")
    w, v = np.linalg.eigh(m)
    good = w > UNLOADED_TOL * max(float(check_finite(np.trace(c1), "tr(C1)")), 1e-300)
    if not good.all():
        warn_unloaded(int(np.sum(~good)), stacklevel=3)
    return x @ v[:, good]


def _kkt_compliance(state: BracedState, k_t: Array, x: Array, k_env: float | None, symmetric: bool) -> Array:
    """C = J_e δq/δw from [K_t, −J_bᵀX; −XᵀJ_b, −I/k_env] [δq; δλ] = [J_eᵀ δw; 0] (−I/k_env → 0 when rigid)."""
    n, c = state.q.size, x.shape[1]
    with finite_math("the preloaded compliance"):
        a = state.split.J_b.T @ x
        kkt = np.zeros((n + c, n + c))
        kkt[:n, :n] = k_t
        kkt[:n, n:] = -a
        kkt[n:, :n] = -a.T
        if k_env is not None:
            kkt[n:, n:] = -np.eye(c) / k_env
        rhs = np.zeros((n + c, 6))
        rhs[:n] = state.J_e.T
        try:
            dq = np.linalg.solve(kkt, rhs)[:n]
        except np.linalg.LinAlgError:
            raise SingularityError(
                "the loaded equilibrium is singular here (chain 1 cannot move {b} along a constraint direction, or "
                "the loads cancel a joint stiffness); choose another configuration or smaller loads"
            ) from None
        # static stability: the stiffness on the motions the contact allows has eigenvalues of positive real part
        if k_env is not None:
            reduced = k_t + k_env * (a @ a.T)
        elif c:
            _, s, vt = np.linalg.svd(a.T)
            z = vt[int(np.sum(s > 1e-12 * max(float(s[0]), 1e-300))) :].T
            reduced = z.T @ k_t @ z
        else:
            reduced = k_t
        if reduced.size and not float(np.min(np.linalg.eigvals(reduced).real)) > 0.0:
            raise UnstableEquilibriumError(
                "the loaded equilibrium is unstable here: the tangent stiffness is not positive on the motions the "
                "contact allows (gravity, the tool wrench or the preload overcome the joint springs); reduce them"
            )
        out: Array = state.J_e @ dq
        return 0.5 * (out + out.T) if symmetric else out


def preloaded_compliance(
    braced: BracedRobot,
    q: ArrayLike,
    preload: float = 0.0,
    *,
    gravity: bool = False,
    wrench: ArrayLike | None = None,
) -> Array:
    """Tip compliance C (6×6, world axes, [δp; δθ] per [δf; δm]) about the loaded, preloaded equilibrium at q.

    The springs' set points hold q under gravity g(q) (Pinocchio's generalized gravity), the dead tool wrench
    w0 = ``wrench`` on the robot at e and the contact wrench f_c0 = P [n̂; 0] of the surface on the robot at b.
    A small tool wrench δw then deflects the robot by δq, δλ (contact wrench X δλ) with

        [K_t, −J_bᵀX; −XᵀJ_b, −I/k_env] [δq; δλ] = [J_eᵀ δw; 0],   C = J_e δq/δw,

    K_t from :func:`tangent_stiffness`, X the brace's constraint wrenches (any contact type), k_env the brace's
    environment stiffness (−I/k_env → 0 for a rigid surface, and unloaded directions are dropped as in the
    ``constrained`` model, with an UnloadedContactWarning). With P = 0, no gravity and no wrench this is the
    ``constrained`` C_e.

    Args:
        braced: the braced robot (its brace gives X and k_env).
        q: (n,) rad, the loaded equilibrium configuration.
        preload: P ≥ 0 (N), the normal force with which the surface pushes on b at q.
        gravity: include gravity (the model's gravity vector and link masses).
        wrench: w0 = [f; m] (6,), the dead tool wrench on the robot at e (world axes; N, N·m); default none.

    Returns:
        C (6×6): m/N, m/(N·m), rad/N, rad/(N·m) blocks. Symmetric unless w0 has a moment: a dead moment makes
        K_t, and so C, non-symmetric; C is then the true tangent compliance (δx = C δw), and measures built for a
        symmetric C (ellipsoids) use its symmetric part ½(C + Cᵀ).

    Raises:
        SingularityError: the KKT system is singular (chain 1 cannot move {b} along a constraint direction).
        NumericalError: the loaded equilibrium is unstable (K_t not positive on the allowed motions) or the
            computation overflows.
    """
    braced, w0 = _check(braced, gravity, wrench)
    p = as_number(preload, "the preload (the contact pushes)", nonnegative=True, unit="N")
    st = braced.state(q, hessians=True)
    k_t = tangent_stiffness(st, p, gravity=gravity, wrench=w0)
    k_env = braced.split.brace.environment_stiffness
    return _kkt_compliance(st, k_t, _loaded_directions(st, k_env), k_env, not w0[3:].any())


def loaded_free_space_compliance(
    braced: BracedRobot, q: ArrayLike, *, gravity: bool = False, wrench: ArrayLike | None = None
) -> Array:
    """Tip compliance of the unbraced robot about its loaded equilibrium at q: J_e K_t⁻¹ J_eᵀ (6×6, world axes).

    K_t = K + ∂g/∂q − ∂(J_eᵀ w0)/∂q (:func:`tangent_stiffness` with P = 0); the brace is ignored. Equals
    ``free_space_compliance`` without gravity and wrench. Non-symmetric when w0 has a moment (see
    :func:`preloaded_compliance`). Raises SingularityError or NumericalError as :func:`preloaded_compliance`.
    """
    braced, w0 = _check(braced, gravity, wrench)
    st = braced.state(q, hessians=True)
    k_t = tangent_stiffness(st, 0.0, gravity=gravity, wrench=w0)
    return _kkt_compliance(st, k_t, np.zeros((6, 0)), None, not w0[3:].any())


#: Compliance models of a run: the first-order ones, and ``preloaded`` (reported along the constrained runs).
RUN_MODELS: tuple[str, ...] = (*COMPLIANCE_MODELS, "preloaded")


def check_run_model(model: object) -> str:
    """A run's compliance model: one of RUN_MODELS; InputError naming them otherwise."""
    if not isinstance(model, str) or model not in RUN_MODELS:
        raise InputError(f"unknown compliance model {show(model)}; choose one of {', '.join(RUN_MODELS)}")
    return model


def simulated_model(model: str) -> ComplianceModel:
    """The first-order model the runs of `model` simulate with (``preloaded`` runs are the constrained ones)."""
    return check_model("constrained" if model == "preloaded" else model)


def run_compliance(state: Any, model: str, braced: bool, *, preload: float = 0.0, gravity: bool = False) -> Array:
    """The 6×6 tip compliance C_e that a run under `model` reports at `state` (what its figures and views draw).

    Args:
        state: the run's state at q: a ``BracedState``, or a ``BracedState`` with several braces.
        model: the run's compliance model ("constrained", "projection" or "preloaded").
        braced: False for the free-space run.
        preload: P, N (only with "preloaded").
        gravity: statics with gravity (only with "preloaded").

    Returns:
        With "preloaded" and one brace: :func:`preloaded_compliance` (braced) or :func:`loaded_free_space_compliance`;
        otherwise C_e of :func:`simulated_model` (eq:Ce; stacked with several braces) or J K⁻¹ Jᵀ unbraced.
    """
    if model == "preloaded" and isinstance(state, BracedState):
        if braced:
            return preloaded_compliance(state.braced, state.q, preload, gravity=gravity)
        return loaded_free_space_compliance(state.braced, state.q, gravity=gravity)
    if not braced:
        return free_space_compliance(state)
    return end_effector_compliance(state, simulated_model(model))
