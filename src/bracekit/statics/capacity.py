"""Load capacity of the preloaded brace: how far each listed tool wrench can be scaled before the brace fails.

For a tool wrench w (6,) scaled by s ≥ 0, the first-order response of :mod:`bracekit.statics.equilibrium` gives
f_c(s) = f_c0 + s δf_c(w) and τ(s) = τ0 + s δτ(w) (conventions there: f_c by the surface on the robot at b,
f_n = n̂ᵀ f_c[:3] ≥ 0 pressing). The capacity is the largest s before:

* lift-off: f_n(s) < 0 (the surface would have to pull);
* slip (only when μ is given): ‖f_t(s)‖ > μ f_n(s), the Coulomb cone on the contact force. A ``soft_finger``
  contact's normal moment (and any contact moment) is carried without limit: only its force meets the cone;
* saturation: |τ_i(s)| > effort_i for some joint. Joints whose URDF effort is 0 or inf are unlimited.

Each limit is an exact closed form of the first-order model (linear in s, or quadratic for the cone): inf when the
load never reaches it, 0 when it is already violated at s = 0 (or is violated by any s > 0, e.g. lift-off from
P = 0 under a pulling load). Rates below RATE_RTOL of the load's response are taken as zero.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from bracekit._linalg import as_array, show
from bracekit.errors import InputError
from bracekit.kinematics import BracedRobot
from bracekit.model.robot import Robot
from bracekit.statics.equilibrium import wrench_list
from bracekit.statics.stacked import ContactResponses, brace_index, contact_responses

Array = NDArray[np.float64]

#: A rate of change (per unit scale) below this fraction of the load's response is taken as zero (round-off).
RATE_RTOL = 1e-12


def effort_limits(robot: Robot, effort: ArrayLike | None = None) -> Array:
    """Actuator limits (n,), N·m (N for a prismatic joint), in chain order; inf for an unlimited joint.

    Args:
        robot: the robot; its URDF ``<limit effort>`` values (``model.effortLimit``) are used when `effort`
            is None, with 0 (a URDF without effort, e.g. a continuous joint) read as unlimited.
        effort: limits to use instead (n,), each > 0 or inf.
    """
    if effort is None:
        e = np.asarray(robot.model.effortLimit, dtype=float).copy()
        return np.where((e > 0.0) & np.isfinite(e), e, np.inf)
    a = as_array(effort, "the effort limits (N·m)", finite=False).reshape(-1)
    if a.size != robot.n or not np.all(a > 0.0):  # also refuses NaN
        raise InputError(f"the effort limits must be {robot.n} numbers > 0 (inf: unlimited), got {show(a)}")
    return a


def peak_ratio(tau: ArrayLike, effort: Array) -> Array:
    """max_i |τ_i| / effort_i over the last axis of `tau` (…, n); 0 where no joint is limited."""
    t = np.abs(np.asarray(tau, dtype=float))
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.where(np.isfinite(effort), t / effort, 0.0)
    return np.asarray(np.max(r, axis=-1), dtype=float)


def liftoff_scale(f_n0: ArrayLike, d_n: ArrayLike, scale: ArrayLike = 1.0) -> Array:
    """Largest s with f_n0 + s d_n ≥ 0 on [0, s]: f_n0/(−d_n) if d_n < 0, else inf; 0 if f_n0 < 0.

    Rates |d_n| ≤ RATE_RTOL·`scale` (the size of the load's response, N) count as zero.
    """
    f0, d = np.broadcast_arrays(np.asarray(f_n0, dtype=float), np.asarray(d_n, dtype=float))
    falling = d < -RATE_RTOL * np.asarray(scale, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(falling, f0 / np.where(falling, -d, 1.0), np.inf)
    return np.where(f0 < 0.0, 0.0, np.maximum(s, 0.0))


def slip_scale(
    f_t0: ArrayLike, d_t: ArrayLike, f_n0: ArrayLike, d_n: ArrayLike, mu: float, scale: ArrayLike = 1.0
) -> Array:
    """Largest s with ‖f_t0 + s d_t‖ ≤ μ (f_n0 + s d_n) on [0, s]: the exit of a line from the Coulomb cone.

    f_t0, d_t (…, 3) are tangential forces and f_n0, d_n (…) normal forces. The cone is convex, so the
    admissible scales form an interval [0, s*]: s* = inf if the rate (d_t, d_n) lies in the cone, else the
    largest root of μ²f_n(s)² − ‖f_t(s)‖² = 0 with f_n ≥ 0 (the quadratic's stable roots). 0 if (f_t0, f_n0)
    is outside the cone. Rates below RATE_RTOL·`scale` count as zero.
    """
    ft0, dt = np.asarray(f_t0, dtype=float), np.asarray(d_t, dtype=float)
    fn0, dn = np.broadcast_arrays(np.asarray(f_n0, dtype=float), np.asarray(d_n, dtype=float))
    tol = RATE_RTOL * np.asarray(scale, dtype=float)
    nt0, ndt = np.linalg.norm(ft0, axis=-1), np.linalg.norm(dt, axis=-1)
    inside0 = (fn0 >= 0.0) & (nt0 <= mu * fn0 + tol)
    inside_rate = mu * dn >= ndt - tol
    a = mu * mu * dn * dn - ndt * ndt
    b = 2.0 * (mu * mu * fn0 * dn - np.sum(ft0 * dt, axis=-1))
    c = np.maximum(mu * mu * fn0 * fn0 - nt0 * nt0, 0.0)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        root = np.sqrt(np.maximum(b * b - 4.0 * a * c, 0.0))
        qq = -0.5 * (b + np.where(b >= 0.0, root, -root))
        r1 = np.where(a != 0.0, qq / a, np.where(b < 0.0, -c / b, -np.inf))
        r2 = np.where(qq != 0.0, c / qq, -np.inf)
        best = np.full(np.shape(a), 0.0)
        for r in (r1, r2):
            ok = np.isfinite(r) & (r >= 0.0) & (fn0 + r * dn >= -tol * np.maximum(r, 1.0))
            best = np.where(ok, np.maximum(best, r), best)
    return np.where(~inside0, 0.0, np.where(inside_rate, np.inf, best))


def saturation_scale(tau0: ArrayLike, d_tau: ArrayLike, effort: Array, scale: ArrayLike = 1.0) -> Array:
    """Largest s with |τ0_i + s dτ_i| ≤ effort_i for every joint (last axis n); 0 if one is already beyond.

    Unlimited joints (effort inf) never saturate; rates below RATE_RTOL·`scale` (N·m) count as zero.
    """
    t0, d = np.broadcast_arrays(np.asarray(tau0, dtype=float), np.asarray(d_tau, dtype=float))
    tol = RATE_RTOL * np.asarray(scale, dtype=float)[..., None]
    room = np.where(d > 0.0, effort - t0, effort + t0)  # distance to the limit the joint moves toward
    moving = np.isfinite(effort) & (np.abs(d) > tol)
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(moving, room / np.where(moving, np.abs(d), 1.0), np.inf)
    s = np.where(np.abs(t0) > effort, 0.0, np.maximum(s, 0.0))
    return np.asarray(np.min(s, axis=-1), dtype=float)


@dataclass(frozen=True, eq=False)
class Capacity:
    """One brace's view of the load capacity at one configuration for m tool wrenches (dimensionless scales).

    Attributes:
        liftoff: scale of each wrench at which the brace's contact would pull (m,).
        slip: scale at which its contact force leaves the Coulomb cone (m,); None without μ.
        torque: scale at which an actuator saturates (m,).
        liftoff_margin, slip_margin, torque_margin: their minima over the wrenches (slip: None without μ).
        peak_unloaded: max_i |τ0_i| / effort_i without tool load (0 if no joint is limited).
        peak_loaded: max_i |τ_i| / effort_i under each wrench at scale 1 (m,).
        normal_force: f_n under each wrench at scale 1 (m,), N.
        tangential_force: ‖f_t‖ under each wrench at scale 1 (m,), N.
        contact_wrench: f_c under each wrench at scale 1 (m×6), N and N·m.
    """

    liftoff: Array
    slip: Array | None
    torque: Array
    liftoff_margin: float
    slip_margin: float | None
    torque_margin: float
    peak_unloaded: float
    peak_loaded: Array
    normal_force: Array
    tangential_force: Array
    contact_wrench: Array


@dataclass(frozen=True, eq=False)
class CapacityAlong:
    """Load capacity with B ≥ 1 braces at N configurations for m tool wrenches (scales are dimensionless).

    Attributes:
        liftoff: scale of each wrench at which the first brace would pull (N×m): the least over the braces.
        slip: scale at which the first brace's force leaves its Coulomb cone (N×m, the least over the braces
            with μ); None when no brace has μ.
        torque: scale at which an actuator saturates (N×m).
        liftoff_margin, slip_margin, torque_margin: the least over braces and wrenches (N,) (slip: None without μ).
        peak_unloaded: max_i |τ0_i| / effort_i without tool load (N,).
        peak_loaded: max_i |τ_i| / effort_i under each wrench at scale 1 (N×m).
        brace_liftoff, brace_slip: the scales of each brace (N×B×m; slip inf for a brace without μ, None when
            no brace has μ).
        brace_liftoff_margin, brace_slip_margin: the least over the wrenches for each brace (N×B).
        normal_force, tangential_force: f_n and ‖f_t‖ of brace i under each wrench at scale 1 (N×B×m), N.
        contact_wrench: f_c,i under each wrench at scale 1 (N×B×m×6), N and N·m.
        frictions: μ_i of each brace (None: no slip limit for it).
    """

    liftoff: Array
    slip: Array | None
    torque: Array
    liftoff_margin: Array
    slip_margin: Array | None
    torque_margin: Array
    peak_unloaded: Array
    peak_loaded: Array
    brace_liftoff: Array
    brace_slip: Array | None
    brace_liftoff_margin: Array
    brace_slip_margin: Array | None
    normal_force: Array
    tangential_force: Array
    contact_wrench: Array
    frictions: tuple[float | None, ...]

    def __len__(self) -> int:
        return int(self.liftoff.shape[0])

    def at(self, i: int, brace: int | None = None) -> Capacity:
        """Brace `brace`'s view at configuration i (None: the only brace; ContactError with several)."""
        b = brace_index(brace, len(self.frictions))
        slip = None if self.brace_slip is None or self.frictions[b] is None else self.brace_slip[i, b]
        return Capacity(
            liftoff=self.brace_liftoff[i, b],
            slip=slip,
            torque=self.torque[i],
            liftoff_margin=float(self.brace_liftoff_margin[i, b]),
            slip_margin=None if slip is None else float(np.min(slip)),
            torque_margin=float(self.torque_margin[i]),
            peak_unloaded=float(self.peak_unloaded[i]),
            peak_loaded=self.peak_loaded[i],
            normal_force=self.normal_force[i, b],
            tangential_force=self.tangential_force[i, b],
            contact_wrench=self.contact_wrench[i, b],
        )


def capacity_of(responses: ContactResponses, wrenches: ArrayLike, effort: Array) -> CapacityAlong:
    """The capacity from contact responses already computed (N configurations, B braces) for wrenches (m×6).

    `effort` (n,) is :func:`effort_limits` (inf: unlimited). Each brace gets the lift-off and slip scales of
    :func:`liftoff_scale` and :func:`slip_scale` on its own contact force f_c,i(s) = f_c0,i + s δf_c,i(w) (slip
    only for a brace with μ_i); the torque scale is :func:`saturation_scale` of τ(s) = τ0 + s δτ(w).
    """
    ws = wrench_list(wrenches)
    nhat = responses.normals  # (B, 3)
    d_f = np.einsum("nbij,mj->nbmi", responses.contact_gain, ws)  # (N, B, m, 6)
    d_tau = np.einsum("nij,mj->nmi", responses.torque_gain, ws)  # (N, m, n)
    f0 = responses.f_c0[:, :, None, :]  # (N, B, 1, 6)
    fn0 = np.einsum("nbmi,bi->nbm", f0[..., :3], nhat)
    ft0 = f0[..., :3] - fn0[..., None] * nhat[None, :, None, :]
    dn = np.einsum("nbmi,bi->nbm", d_f[..., :3], nhat)
    dt = d_f[..., :3] - dn[..., None] * nhat[None, :, None, :]
    force_scale = np.linalg.norm(d_f[..., :3], axis=-1)
    liftoff = liftoff_scale(fn0, dn, force_scale)
    slip: Array | None = None
    if any(mu is not None for mu in responses.frictions):
        slip = np.full(liftoff.shape, np.inf)
        for i, mu in enumerate(responses.frictions):
            if mu is not None:
                slip[:, i] = slip_scale(ft0[:, i], dt[:, i], fn0[:, i], dn[:, i], mu, force_scale[:, i])
    tau0 = responses.tau0[:, None, :]
    torque = saturation_scale(tau0, d_tau, effort, np.max(np.abs(d_tau), axis=-1))
    wrench1 = f0 + d_f
    normal = np.einsum("nbmi,bi->nbm", wrench1[..., :3], nhat)
    least_lift = np.min(liftoff, axis=1)
    least_slip = None if slip is None else np.min(slip, axis=1)
    return CapacityAlong(
        liftoff=least_lift,
        slip=least_slip,
        torque=torque,
        liftoff_margin=np.min(least_lift, axis=1),
        slip_margin=None if least_slip is None else np.min(least_slip, axis=1),
        torque_margin=np.min(torque, axis=1),
        peak_unloaded=peak_ratio(responses.tau0, effort),
        peak_loaded=peak_ratio(tau0 + d_tau, effort),
        brace_liftoff=liftoff,
        brace_slip=slip,
        brace_liftoff_margin=np.min(liftoff, axis=2),
        brace_slip_margin=None if slip is None else np.min(slip, axis=2),
        normal_force=normal,
        tangential_force=np.linalg.norm(wrench1[..., :3] - normal[..., None] * nhat[None, :, None, :], axis=-1),
        contact_wrench=wrench1,
        frictions=responses.frictions,
    )


def capacity_along(
    braced: BracedRobot,
    qs: ArrayLike,
    wrenches: ArrayLike,
    *,
    preload: float | Sequence[float] = 0.0,
    gravity: bool = False,
    friction: float | Sequence[float | None] | None = None,
    effort: ArrayLike | None = None,
    geometric: bool = True,
) -> CapacityAlong:
    """Load capacity with every brace at each configuration of `qs` (N×n, e.g. a run's samples) for wrenches (m×6).

    Args:
        braced: the braced robot (N ≥ 1 braces).
        qs: configurations (N×n, rad), each with every {b_i} on its surface.
        wrenches: tool wrenches [f; m] at e, world axes (m×6, N and N·m).
        preload: P_i ≥ 0 (N), one for every brace or one per brace, the same at every configuration.
        gravity: include gravity torques.
        friction: μ_i ≥ 0 for the slip limit (and a sticking frictionless point), one or one per brace; None: no
            slip limit.
        effort: actuator limits (n,) instead of the URDF's (:func:`effort_limits`).
        geometric: use the tangent stiffness in the response (:func:`~bracekit.statics.contact_responses`).
    """
    if not isinstance(braced, BracedRobot):
        raise InputError(f"expected a BracedRobot, got {type(braced).__name__}")
    e = effort_limits(braced.robot, effort)
    ws = wrench_list(wrenches)
    resp = contact_responses(braced, qs, preload=preload, gravity=gravity, friction=friction, geometric=geometric)
    return capacity_of(resp, ws, e)


def load_capacity(
    braced: BracedRobot, q: ArrayLike, wrenches: ArrayLike, *, brace: int | None = None, **options: Any
) -> Capacity:
    """Brace `brace`'s view of :func:`capacity_along` at one configuration q (n,) (None: the only brace).

    `options` are those of :func:`capacity_along` (preload, gravity, friction, effort, geometric).
    """
    if not isinstance(braced, BracedRobot):
        raise InputError(f"expected a BracedRobot, got {type(braced).__name__}")
    which = brace_index(brace, len(braced.braces))
    q_row = as_array(q, "the configuration (rad)").reshape(1, -1)
    return capacity_along(braced, q_row, wrenches, **options).at(0, which)
