"""The preloaded (second-order) tip compliance: the constrained model on the loaded equilibrium's tangent stiffness.

The joints are springs τ = K (q_s − q) that hold the robot at q under gravity, a dead tip wrench w0 and the
contact's preload f_c0 = P [n̂; 0]: τ = g(q) − J_eᵀ w0 − J_bᵀ f_c0. At fixed set points q_s a small tip wrench
δw then meets the tangent stiffness K_t = K + ∂g/∂q − ∂(J_eᵀ w0)/∂q − ∂(J_bᵀ f_c0)/∂q (S.-F. Chen and
I. Kao, "Conservative congruence transformation for joint and Cartesian stiffness matrices of robotic hands
and fingers", The International Journal of Robotics Research, 2000), not K alone as in the first-order
models. docs/model.md, "The preloaded compliance", derives the signs and the treatment of dead moments.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike, NDArray

from bracekit._linalg import as_array, as_number, finite_math, show
from bracekit.compliance.first_order import (
    COMPLIANCE_MODELS,
    ComplianceModel,
    check_model,
    end_effector_compliance,
    free_space_compliance,
)
from bracekit.errors import InputError, SingularityError, UnstableEquilibriumError
from bracekit.kinematics import BracedRobot, BracedState

Array = NDArray[np.float64]

__all__ = ["loaded_free_space_compliance", "preloaded_compliance", "run_compliance", "tangent_stiffness"]


def _check(braced: object, gravity: object, wrench: ArrayLike | None) -> tuple[BracedRobot, Array]:
    if not isinstance(braced, BracedRobot):
        raise InputError(f"expected a BracedRobot, got {type(braced).__name__}")
    if not isinstance(gravity, bool):
        raise InputError(f"gravity must be True or False, got {show(gravity)}")
    w0 = np.zeros(6) if wrench is None else as_array(wrench, "the tool wrench [f; m] (N, N·m)", (6,))
    return braced, w0


def _preloads(braced: BracedRobot, preload: float | ArrayLike) -> Array:
    """P_i ≥ 0 (N) of each brace from one P (every brace) or one per brace."""
    many = isinstance(preload, list | tuple | np.ndarray)
    values = as_array(preload, "the preloads P_i of the braces (N)").reshape(-1) if many else None
    if values is None:
        p = as_number(preload, "the preload (the contact pushes)", nonnegative=True, unit="N")
        return np.full(len(braced.braces), p)
    if values.shape != (len(braced.braces),):
        raise InputError(f"give one preload or one per brace ({len(braced.braces)}), got {values.size}")
    what = "the preload (the contact pushes)"
    return np.array([as_number(float(v), what, nonnegative=True, unit="N") for v in values])


def tangent_stiffness(
    state: BracedState, preload: float | ArrayLike, *, gravity: bool = False, wrench: ArrayLike | None = None
) -> Array:
    """K_t = K + ∂g/∂q − ∂(J_eᵀ w0)/∂q − Σ_i P_i ∂(J_b_i,vᵀ n̂_i)/∂q (n×n, N·m/rad) at the loaded equilibrium.

    Args:
        state: ``braced.state(q, hessians=True)``.
        preload: P_i ≥ 0 (N), the contact force [P_i n̂_i; 0] of each surface on the robot at b_i: one number for
            every brace, or one per brace.
        gravity: include ∂g/∂q of Pinocchio's generalized gravity (the model's gravity vector and masses).
        wrench: w0 = [f; m] (6,), the dead tool wrench on the robot at e (world axes; N, N·m); default none.

    Returns:
        K_t. The terms of K, gravity, the tool force and the preloads are Hessians of potentials and are
        symmetrised (round-off only); the tool moment's term −∂(J_e,ωᵀ m)/∂q is not symmetric (a dead moment
        is not conservative) and is kept as it is.
    """
    if not isinstance(state, BracedState) or not state.has_hessians:
        raise InputError("tangent_stiffness needs a BracedState with Hessians: braced.state(q, hessians=True)")
    braced, w0 = _check(state.braced, gravity, wrench)
    p = _preloads(braced, preload)
    with finite_math("the tangent stiffness"):
        k_sym = np.diag(state.K) - np.einsum("r,rik->ik", w0[:3], state.dJ_e[:3])  # type: ignore[index]
        for p_i, brace, c in zip(p, braced.braces, state.contacts, strict=True):
            k_sym -= p_i * np.einsum("r,rik->ik", brace.surface.normal, c.dJ_b[:3])  # type: ignore[index]
        if gravity:
            model = braced.robot.model
            k_sym += pin.computeGeneralizedGravityDerivatives(model, model.createData(), state.q)
        k_t: Array = 0.5 * (k_sym + k_sym.T) - np.einsum("r,rik->ik", w0[3:], state.dJ_e[3:])  # type: ignore[index]
    return k_t


def _kkt_compliance(state: BracedState, k_t: Array, braced: bool, symmetric: bool) -> Array:
    """C = J_e δq/δw from [K_t, −Gᵀ; −G, −D] [δq; δλ] = [J_eᵀ δw; 0] over the independent rows of G.

    G = [X_iᵀ J_b_i] stacked (``state.constraint``: unloaded and dependent rigid rows dropped, with their
    warnings), D = diag(1/k_env) of each row's brace (0 for a rigid surface); no rows for the free robot.
    """
    n = state.q.size
    if braced:
        con = state.constraint
        rows = list(con.independent)
        g, d = con.G[rows], con.compliance[rows]
    else:
        g, d = np.zeros((0, n)), np.zeros(0)
    c = g.shape[0]
    with finite_math("the preloaded compliance"):
        a = g.T
        kkt = np.zeros((n + c, n + c))
        kkt[:n, :n] = k_t
        kkt[:n, n:] = -a
        kkt[n:, :n] = -a.T
        kkt[n:, n:] = -np.diag(d)
        rhs = np.zeros((n + c, 6))
        rhs[:n] = state.J_e.T
        try:
            dq = np.linalg.solve(kkt, rhs)[:n]
        except np.linalg.LinAlgError:
            raise SingularityError(
                "the loaded equilibrium is singular here (no joint can move a {b_i} along a constraint direction, "
                "or the loads cancel a joint stiffness); choose another configuration or smaller loads"
            ) from None
        # static stability: the stiffness on the motions the contacts allow has eigenvalues of positive real part
        rigid = d == 0.0
        soft = ~rigid
        reduced = k_t + (a[:, soft] / d[soft]) @ a[:, soft].T if soft.any() else k_t
        if rigid.any():
            _, s, vt = np.linalg.svd(a[:, rigid].T)
            z = vt[int(np.sum(s > 1e-12 * max(float(s[0]), 1e-300))) :].T
            reduced = z.T @ reduced @ z
        if reduced.size and not float(np.min(np.linalg.eigvals(reduced).real)) > 0.0:
            raise UnstableEquilibriumError(
                "the loaded equilibrium is unstable here: the tangent stiffness is not positive on the motions the "
                "contacts allow (gravity, the tool wrench or the preload overcome the joint springs); reduce them"
            )
        out: Array = state.J_e @ dq
        return 0.5 * (out + out.T) if symmetric else out


def preloaded_compliance(
    braced: BracedRobot,
    q: ArrayLike,
    preload: float | ArrayLike = 0.0,
    *,
    gravity: bool = False,
    wrench: ArrayLike | None = None,
) -> Array:
    """Tip compliance C (6×6, world axes, [δp; δθ] per [δf; δm]) about the loaded, preloaded equilibrium at q.

    The springs' set points hold q under gravity g(q) (Pinocchio's generalized gravity), the dead tool wrench
    w0 = ``wrench`` on the robot at e and the contact wrenches f_c0,i = P_i [n̂_i; 0] of each surface on the robot
    at b_i. A small tool wrench δw then deflects the robot by δq, δλ (contact wrenches X_i δλ_i) with

        [K_t, −Gᵀ; −G, −D] [δq; δλ] = [J_eᵀ δw; 0],   C = J_e δq/δw,

    K_t from :func:`tangent_stiffness`, G = [X_iᵀ J_b_i] the stacked constraint over its independent rows (any
    contact types; unloaded and dependent rows dropped as in the ``constrained`` model, with their warnings),
    D = diag(1/k_env) of each row's brace (0 for a rigid surface). With every P_i = 0, no gravity and no wrench
    this is the ``constrained`` C_e, for any number of braces.

    Args:
        braced: the braced robot (its braces give X_i and k_env).
        q: (n,) rad, the loaded equilibrium configuration.
        preload: P_i ≥ 0 (N), the normal force with which each surface pushes on b_i at q: one for every brace,
            or one per brace.
        gravity: include gravity (the model's gravity vector and link masses).
        wrench: w0 = [f; m] (6,), the dead tool wrench on the robot at e (world axes; N, N·m); default none.

    Returns:
        C (6×6): m/N, m/(N·m), rad/N, rad/(N·m) blocks. Symmetric unless w0 has a moment: a dead moment makes
        K_t, and so C, non-symmetric; C is then the true tangent compliance (δx = C δw), and measures built for a
        symmetric C (ellipsoids) use its symmetric part ½(C + Cᵀ).

    Raises:
        SingularityError: the KKT system is singular.
        NumericalError: the loaded equilibrium is unstable (K_t not positive on the allowed motions) or the
            computation overflows.
    """
    braced, w0 = _check(braced, gravity, wrench)
    st = braced.state(q, hessians=True)
    k_t = tangent_stiffness(st, preload, gravity=gravity, wrench=w0)
    return _kkt_compliance(st, k_t, True, not w0[3:].any())


def loaded_free_space_compliance(
    braced: BracedRobot, q: ArrayLike, *, gravity: bool = False, wrench: ArrayLike | None = None
) -> Array:
    """Tip compliance of the unbraced robot about its loaded equilibrium at q: J_e K_t⁻¹ J_eᵀ (6×6, world axes).

    K_t = K + ∂g/∂q − ∂(J_eᵀ w0)/∂q (:func:`tangent_stiffness` with P = 0); the braces are ignored. Equals
    ``free_space_compliance`` without gravity and wrench. Non-symmetric when w0 has a moment (see
    :func:`preloaded_compliance`). Raises SingularityError or NumericalError as :func:`preloaded_compliance`.
    """
    braced, w0 = _check(braced, gravity, wrench)
    st = braced.state(q, hessians=True)
    k_t = tangent_stiffness(st, 0.0, gravity=gravity, wrench=w0)
    return _kkt_compliance(st, k_t, False, not w0[3:].any())


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


def run_compliance(
    state: BracedState, model: str, braced: bool, *, preload: float | ArrayLike = 0.0, gravity: bool = False
) -> Array:
    """The 6×6 tip compliance C_e that a run under `model` reports at `state` (what its figures and views draw).

    Args:
        state: the run's state at q (any number of braces).
        model: the run's compliance model ("constrained", "projection" or "preloaded").
        braced: False for the free-space run.
        preload: P, or P_i of each brace, N (only with "preloaded").
        gravity: statics with gravity (only with "preloaded").

    Returns:
        With "preloaded": :func:`preloaded_compliance` (braced) or :func:`loaded_free_space_compliance`; otherwise
        C_e of :func:`simulated_model` (eq:Ce; stacked with several braces) or J K⁻¹ Jᵀ unbraced.
    """
    if model == "preloaded":
        if braced:
            return preloaded_compliance(state.braced, state.q, preload, gravity=gravity)
        return loaded_free_space_compliance(state.braced, state.q, gravity=gravity)
    if not braced:
        return free_space_compliance(state)
    return end_effector_compliance(state, simulated_model(model))
