"""The contacts of the static references: a frame {b_i} on a plane, and the spring set points they preload.

A :class:`PlaneContact` is what the nonlinear static solve (:mod:`bracekit.validate.statics`) and the MuJoCo
model (:mod:`bracekit.validate.mujoco_check`) know of a brace: its frame, plane, preload P_i, constraint
wrenches X_i (default the frictionless point's [n̂_i; 0]) and environment stiffness k_env (None: rigid).
:func:`contact_set_points` gives the spring set points q_s that make a configuration the equilibrium under the
preloads (and gravity, and a base tip wrench). Units: m, N, N·m, rad; world axes; Pinocchio's
``LOCAL_WORLD_ALIGNED`` Jacobians.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import cast

import numpy as np
import pinocchio as pin

from bracekit.errors import InputError
from bracekit.validate.lagrange import _kinematics

__all__ = ["PlaneContact", "contact_set_points", "preload_rest_configuration"]

_LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED


@dataclass(frozen=True, eq=False)
class PlaneContact:
    """One contact of the static solve: the frame {b_i} on a plane, its constraint wrenches, preload and k_env.

    Attributes:
        frame_id: Pinocchio frame id of {b_i}.
        point: (3,) m, a point of the plane (world).
        normal: (3,) unit normal n̂_i, out of the surface toward the robot.
        preload: P_i ≥ 0 (N) along n̂_i at q0.
        X: the constraint wrenches (6×c_i, world axes; e.g. ``Brace.X()``), transmitting [n̂_i; 0]; None: the
            frictionless point's [n̂_i; 0].
        k_env: environment stiffness (N/m along constraint forces, N·m/rad along constraint moments) of a
            penalty contact, λ_i = λ0_i − k_env φ_i(q); None for a rigid one.
    """

    frame_id: int
    point: np.ndarray
    normal: np.ndarray
    preload: float = 0.0
    X: np.ndarray | None = None
    k_env: float | None = None


@dataclass(frozen=True, eq=False)
class _Contact:
    """A checked contact: unit n̂, X (6×c), λ0 with X λ0 = [P n̂; 0], {b}'s placement at q0."""

    frame_id: int
    point: np.ndarray
    normal: np.ndarray
    preload: float
    X: np.ndarray
    lam0: np.ndarray
    k_env: float | None
    p_b0: np.ndarray
    R_b0: np.ndarray


def _unit(v: np.ndarray, name: str) -> np.ndarray:
    v = np.asarray(v, dtype=float).reshape(3)
    nrm = np.linalg.norm(v)
    if not np.isfinite(nrm) or nrm < 1e-12:
        raise InputError(f"{name} must be a finite non-zero 3-vector")
    if abs(nrm - 1.0) > 1e-6:
        raise InputError(f"{name} must be a unit vector (norm {nrm:.6g})")
    return cast(np.ndarray, v / nrm)


def _gravity(model: pin.Model, data: pin.Data, q: np.ndarray) -> np.ndarray:
    """g(q) (n,), N·m: Pinocchio's generalized gravity (the joint torques that hold the chain against gravity)."""
    return np.array(pin.computeGeneralizedGravity(model, data, q), dtype=float)


def _constraint_wrenches(value: np.ndarray | None, nhat: np.ndarray, preload: float) -> tuple[np.ndarray, np.ndarray]:
    """X (6×c) and λ0 with X λ0 = [P n̂; 0]; X defaults to the frictionless point's [n̂; 0]."""
    if value is None:
        return np.concatenate([nhat, np.zeros(3)])[:, None], np.array([preload])
    X = np.asarray(value, dtype=float)
    if X.ndim != 2 or X.shape[0] != 6 or not 1 <= X.shape[1] <= 6 or not np.all(np.isfinite(X)):
        raise InputError(f"constraint_wrenches must be a finite 6×c matrix (1 ≤ c ≤ 6), got shape {X.shape}")
    if np.linalg.matrix_rank(X) < X.shape[1]:
        raise InputError("constraint_wrenches must have independent columns")
    normal = np.concatenate([nhat, np.zeros(3)])
    coeff = np.linalg.lstsq(X, normal, rcond=None)[0]
    if np.linalg.norm(X @ coeff - normal) > 1e-9:
        raise InputError("constraint_wrenches must transmit the normal force [n̂; 0] (every contact type does)")
    return X, preload * coeff


def _checked(model: pin.Model, data: pin.Data, contacts: Sequence[PlaneContact]) -> list[_Contact]:
    """Checked contacts with their placements at the current kinematics of ``data`` (q0)."""
    if len(contacts) == 0:
        raise InputError("give at least one contact")
    out = []
    for i, c in enumerate(contacts):
        if not isinstance(c, PlaneContact):
            raise InputError(f"contacts[{i}] must be a PlaneContact, got {type(c).__name__}")
        if not 0 <= int(c.frame_id) < model.nframes:
            raise InputError(f"frame id {c.frame_id} out of range (model has {model.nframes} frames)")
        nhat = _unit(c.normal, "surface_normal" if len(contacts) == 1 else f"surfaces[{i}] normal")
        if not (np.isfinite(c.preload) and c.preload >= 0.0):
            raise InputError(f"preload must be a finite force >= 0 N, got {c.preload}")
        k_env = c.k_env
        if k_env is not None and not (np.isfinite(k_env) and k_env > 0.0):
            raise InputError(f"environment_stiffness must be a finite stiffness > 0 (or None if rigid), got {k_env}")
        X, lam0 = _constraint_wrenches(c.X, nhat, float(c.preload))
        fid = int(c.frame_id)
        out.append(
            _Contact(
                fid,
                np.asarray(c.point, dtype=float).reshape(3),
                nhat,
                float(c.preload),
                X,
                lam0,
                k_env,
                data.oMf[fid].translation.copy(),
                data.oMf[fid].rotation.copy(),
            )
        )
    return out


def _set_points(
    model: pin.Model,
    data: pin.Data,
    q0: np.ndarray,
    K: np.ndarray,
    contacts: Sequence[_Contact],
    tip_frame_id: int,
    base_wrench: np.ndarray,
    gravity: bool,
) -> np.ndarray:
    """q_s = q0 + K⁻¹ (g(q0) − J_e(q0)ᵀ w0 − Σ_i J_b_i(q0)ᵀ X_i λ0_i): the set points that make q0 an equilibrium."""
    _kinematics(model, data, q0)
    tau = np.zeros(model.nv)
    for c in contacts:
        tau -= pin.getFrameJacobian(model, data, c.frame_id, _LWA).T @ (c.X @ c.lam0)
    tau -= pin.getFrameJacobian(model, data, tip_frame_id, _LWA).T @ base_wrench
    if gravity:
        tau += _gravity(model, data, q0)
    return cast(np.ndarray, q0 + tau / K)


def contact_set_points(
    model: pin.Model,
    q0: np.ndarray,
    stiffness: np.ndarray,
    contacts: Sequence[PlaneContact],
    *,
    gravity: bool = False,
    tip_frame_id: int | None = None,
    base_wrench: np.ndarray | None = None,
) -> np.ndarray:
    """Spring set points that make q0 the equilibrium with each contact i pushing X_i λ0_i = [P_i n̂_i; 0] on b_i.

    q_s = q0 + K⁻¹ (g(q0) − J_e(q0)ᵀ w0 − Σ_i J_b_i(q0)ᵀ [P_i n̂_i; 0]) (rad, shape (n,)); without gravity and
    base wrench w0 (the defaults) this is q0 − K⁻¹ Σ_i J_b_i,vᵀ n̂_i P_i. ``base_wrench`` [f; m] (at the tip,
    world axes) needs ``tip_frame_id``.
    """
    q0 = np.asarray(q0, dtype=float).reshape(-1)
    K = np.asarray(stiffness, dtype=float).reshape(-1)
    if base_wrench is not None and tip_frame_id is None:
        raise InputError("a base_wrench needs the tip_frame_id of the frame it acts at")
    w0 = np.zeros(6) if base_wrench is None else np.asarray(base_wrench, dtype=float).reshape(6)
    data = model.createData()
    _kinematics(model, data, q0)
    checked = _checked(model, data, contacts)
    tip = checked[0].frame_id if tip_frame_id is None else tip_frame_id
    return _set_points(model, data, q0, K, checked, tip, w0, gravity)


def preload_rest_configuration(
    model: pin.Model,
    q0: np.ndarray,
    stiffness: np.ndarray,
    brace_frame_id: int,
    surface_normal: np.ndarray,
    preload: float,
    *,
    gravity: bool = False,
    tip_frame_id: int | None = None,
    base_wrench: np.ndarray | None = None,
) -> np.ndarray:
    """:func:`contact_set_points` of one frictionless contact {b} pushed with ``preload`` (N) along n̂."""
    contact = PlaneContact(brace_frame_id, np.zeros(3), np.asarray(surface_normal, dtype=float), float(preload))
    return contact_set_points(
        model, q0, stiffness, [contact], gravity=gravity, tip_frame_id=tip_frame_id, base_wrench=base_wrench
    )


def _per_brace(value: float | Sequence[float] | np.ndarray, count: int) -> np.ndarray:
    """One preload (N) per brace from a number or a sequence; InputError unless finite and ≥ 0."""
    p = np.asarray(value, dtype=float).reshape(-1)
    if p.size == 1:
        p = np.full(count, float(p[0]))
    if p.size != count or not np.all(np.isfinite(p)) or np.any(p < 0.0):
        raise InputError(f"preload must be one finite force >= 0 N or one per brace ({count}), got {value!r}")
    return p
