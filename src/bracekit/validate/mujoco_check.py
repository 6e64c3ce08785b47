"""MuJoCo cross-check of the braced statics: the tip deflection under a dead tip wrench, settled (docs/validation.md).

:func:`mujoco_static_deflection` builds the spring-jointed chain with a sphere contact at every brace point
(:func:`~bracekit.validate.mjcf.build_mujoco_model`), preloads the contacts through the springs' set points,
settles, adds a dead tip wrench (applied at the tip point with ``mj_applyFT``), settles again and returns the
tip deflection relative to the preloaded state, in the conventions of :mod:`bracekit.validate.statics`:
Δx = [Δp; Δθ], Δθ = log3(R_e R_e,preᵀ) (world axes; m, rad), with the contact force of every brace.
Settling: max|q̇|·τ < ``tol`` on a step counter (:meth:`~bracekit.validate.session.MujocoSession.settle_until`);
a few thousand steps, 0.06–0.15 s wall time per load case on 8- and 11-joint arms.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import numpy as np
import pinocchio as pin

from bracekit.errors import InputError, MujocoValidationError
from bracekit.validate.mjcf import (
    BRACE_GEOM,
    SOFT_IMPEDANCE,
    SURFACE_GEOM,
    TIP_SITE,
    brace_geom_names,
    build_mujoco_model,
    soft_contact_solref,
)
from bracekit.validate.plane_contact import PlaneContact, contact_set_points
from bracekit.validate.session import MujocoSession, captured_warnings

__all__ = [
    "BRACE_GEOM",
    "SOFT_IMPEDANCE",
    "SURFACE_GEOM",
    "TIP_SITE",
    "MujocoResult",
    "MujocoValidationError",
    "brace_geom_names",
    "build_mujoco_model",
    "mujoco_static_deflection",
    "soft_contact_solref",
]


@dataclass(frozen=True, eq=False)
class MujocoResult:
    """Result of :func:`mujoco_static_deflection`.

    Attributes:
        q: settled joint configuration under preloads + wrench (n,), rad.
        deflection: Δx = [Δp; Δθ] (6,) of the tip site relative to the settled preloaded state (m, rad).
        contact_force: normal force the first surface pushes on its sphere at the end (N; 0 if opened).
        converged: True when both settling phases met the tolerance (otherwise an error is raised).
        steps: simulation steps used (both phases).
        contact_opened: True when a contact has no active sphere–surface contact left at the end.
        q_preloaded: settled configuration under the preloads alone (n,), rad (≈ q0).
        settle_time: the damping time constant τ used (s of simulated time).
        contact_forces: the normal force of every contact at the end (N; 0 where opened), in order.
        contacts_opened: per contact, whether it opened.
    """

    q: np.ndarray
    deflection: np.ndarray
    contact_force: float
    converged: bool
    steps: int
    contact_opened: bool
    q_preloaded: np.ndarray
    settle_time: float
    contact_forces: np.ndarray
    contacts_opened: tuple[bool, ...]


def mujoco_static_deflection(
    model: pin.Model,
    q0: np.ndarray,
    stiffness: np.ndarray,
    tip_frame_id: int,
    contacts: Sequence[PlaneContact],
    wrench: np.ndarray,
    *,
    max_steps: int = 100_000,
    tol: float = 1e-11,
    sphere_radius: float = 1e-4,
    gravity: bool = False,
    timestep: float | None = None,
) -> MujocoResult:
    """Tip deflection of the chain braced at N ≥ 1 points under a dead tip wrench, settled in MuJoCo.

    Phase 1: the springs' rest is shifted so that q0 is the equilibrium under the contacts' preloads P_i (N)
    (and gravity), as in the Pinocchio statics, and the chain settles against the planes from q0.
    Phase 2: the wrench w = [f; m] (N, N·m, world axes) is applied at the tip point with ``mj_applyFT``
    (re-applied at the moving tip: a dead load) and the chain settles again. Settling stops when the
    remaining motion max|q̇|·τ < ``tol`` (rad); the loop runs on a step counter. The contacts are unilateral:
    one that would pull more than its preload opens (``contacts_opened``).

    Args:
        model: Pinocchio model of a serial chain of 1-DoF revolute joints (nq == nv == n).
        q0: (n,) rad, the (preloaded) equilibrium; every b_i lies on its plane at q0.
        stiffness: (n,) joint stiffnesses, N·m/rad, > 0.
        tip_frame_id: Pinocchio frame id of {e}.
        contacts: the contacts (:class:`~bracekit.validate.plane_contact.PlaneContact`: frame, plane, preload
            P_i ≥ 0, k_env). A unilateral MuJoCo contact needs P_i > 0 to hold a pull.
        wrench: (6,) [f; m] at the tip, world axes (N, N·m).
        max_steps: step budget for both phases together.
        tol: settling tolerance, rad.
        sphere_radius: m; the rolling sphere differs from a point contact in proportion to it.
        gravity: gravity along −z with the URDF's masses and inertias; the set points then hold q0 under
            gravity and the preloads, q_s = q0 + K⁻¹ (g(q0) − Σ_i J_b_i,vᵀ n̂_i P_i), as in the static solve
            with ``gravity=True``.
        timestep: MuJoCo timestep (s); default min(1 ms, τ/20) (and 1/10 of a soft contact's time constant).
            Several stiff contacts may keep bouncing in a limit cycle at one timestep and settle at another
            (seen at 1 ms and at 0.5 ms, never at both): the several-brace checks retry at half the step.

    Returns:
        :class:`MujocoResult` (deflection relative to the settled preloaded state).

    Raises:
        MujocoValidationError: unstable simulation (MuJoCo warnings or non-finite state), no settling within
            ``max_steps``, a model MuJoCo rejects, or a contact without contact under a positive preload.
        InputError: bad inputs.
    """
    w = np.asarray(wrench, dtype=float).reshape(-1)
    if w.size != 6 or not np.all(np.isfinite(w)):
        raise InputError(f"wrench must be a finite (6,) vector, got shape {w.shape}")
    if max_steps < 1:
        raise InputError("max_steps must be >= 1")
    if not isinstance(gravity, bool):
        raise InputError(f"gravity must be True or False, got {gravity!r}")
    q0 = np.asarray(q0, dtype=float).reshape(-1)
    K = np.asarray(stiffness, dtype=float).reshape(-1)
    set_points = contact_set_points(model, q0, K, contacts, gravity=True) if gravity else None
    xml = build_mujoco_model(
        model, q0, K, tip_frame_id, contacts, sphere_radius=sphere_radius, gravity=gravity, set_points=set_points,
        timestep=timestep,
    )  # fmt: skip
    sim = MujocoSession(xml, K, q0)
    with captured_warnings(sim.messages):
        return _settle_phases(sim, q0, w, [float(c.preload) for c in contacts], max_steps, tol)


def _settle_phases(
    sim: MujocoSession, q0: np.ndarray, w: np.ndarray, preloads: list[float], max_steps: int, tol: float
) -> MujocoResult:
    """Settle under the preloads, then under the tip wrench (:func:`mujoco_static_deflection`)."""
    m, d = sim.m, sim.d
    zero = np.zeros(6)
    steps1, ok = sim.settle_until(zero, max_steps, tol, "preload settling")
    if not ok:
        raise MujocoValidationError(
            f"MuJoCo did not settle under the preload within {max_steps} steps (tol {tol:.1e} rad)"
        )
    mujoco.mj_forward(m, d)
    for i, preload in enumerate(preloads):
        _, ncon = sim.normal_force(i)
        if preload > 0.0 and ncon == 0:
            which = "" if len(preloads) == 1 else f" of brace {i}"
            raise MujocoValidationError(
                f"no sphere–surface contact{which} under the preload: does b lie on the plane at q0?"
            )
    q_pre = d.qpos.copy()
    p0, R0 = sim.tip()

    budget = max_steps - steps1
    steps2, ok = sim.settle_until(w, budget, tol, "loaded settling")
    if not ok:
        raise MujocoValidationError(
            f"MuJoCo did not settle under the tip wrench within {max_steps} steps in total (tol {tol:.1e} rad)"
        )
    sim.apply(w)
    mujoco.mj_forward(m, d)
    measured = [sim.normal_force(i) for i in range(len(preloads))]
    p1, R1 = sim.tip()
    opened = tuple(c == 0 or f <= 0.0 for f, c in measured)
    forces = np.array([0.0 if o else f for (f, _), o in zip(measured, opened, strict=True)])
    return MujocoResult(
        q=d.qpos.copy(),
        deflection=np.concatenate([p1 - p0, pin.log3(R1 @ R0.T)]),
        contact_force=float(forces[0]),
        converged=True,
        steps=steps1 + steps2,
        contact_opened=any(opened),
        q_preloaded=q_pre,
        settle_time=sim.tau,
        contact_forces=forces,
        contacts_opened=opened,
    )
