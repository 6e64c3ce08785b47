"""MuJoCo check of whether the brace holds: contact forces, slip and lift-off under gravity, preload and friction.

bracekit's statics (:mod:`bracekit.statics.equilibrium`, :mod:`bracekit.statics.capacity`) set the spring set
points q_s = q + K⁻¹ τ0, τ0 = g(q) − J_bᵀ [P n̂; 0], so that the contact carries the preload P n̂ at the commanded
q, and predict to first order the contact force under a scaled tool wrench s·w,

    f_c(s) = f_c0 + s δf_c(w)    (by the surface on the robot at b, world axes, N),

and the scale at which the brace lifts off (f_n = n̂ᵀ f_c reaches 0) or slips (‖f_t‖ reaches μ f_n).

:func:`mujoco_holding_check` builds the same spring-jointed chain in MuJoCo
(:func:`~bracekit.validate.mujoco_check.build_mujoco_model`: URDF inertias and gravity along −z, springref =
q_s, a 0.1 mm sphere at b on the plane, condim 3 with sliding friction μ and MuJoCo's elliptic cone, i.e. the
Coulomb cone ‖f_t‖ ≤ μ f_n), settles it without load, then, from that state, ramps the dead tip wrench s·w
in over 2τ and settles again, for a few scales s. MuJoCo's contact force (``mj_contactForce``, rotated from the
contact frame to world axes, the force on the sphere) is compared with the first-order prediction, and MuJoCo's
outcome (held, slipped, lifted off) with the predicted margin: below ``HOLD_BELOW`` × the margin the brace must
hold, above ``FAIL_ABOVE`` × it must fail the predicted way.

Outcome in MuJoCo: ``lifted_off`` when no sphere–plane contact is active or its normal force is 0;
``slipped`` (with μ) when the material point b moved along the plane by more than ``slip_tol`` (m) between the
settled unloaded and loaded states; ``held`` otherwise (a frictionless point slides freely and is only checked
for lift-off). A soft-contact simulator lets a sticking contact creep
tangentially (MuJoCo's friction rows are regularised, with no position restoring term): with impratio 10 the
creep stays below about 1e-6 m here, against 3e-4 m and more for a real slip (docs/validation.md).
Actuator saturation is not simulated (MuJoCo's springs have no effort limit); the joint torques
τ = K (q_s − q) are compared with the prediction τ0 + s δτ(w) instead.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Literal

import mujoco
import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import brentq

from bracekit._linalg import as_array, show
from bracekit.errors import InputError, MujocoValidationError, StaticSolveError
from bracekit.kinematics import BracedRobot
from bracekit.simulation.holding import Holding
from bracekit.statics import (
    ContactResponse,
    capacity_of,
    contact_responses,
    effort_limits,
    load_contact_wrenches,
)
from bracekit.validate.mujoco_check import BRACE_GEOM, SURFACE_GEOM, TIP_SITE, _check_warnings, build_mujoco_model
from bracekit.validate.statics import solve_static_equilibrium

__all__ = [
    "FAIL_ABOVE",
    "HOLD_BELOW",
    "RAMP_SETTINGS",
    "CapacityRamp",
    "HoldingCase",
    "HoldingCheck",
    "mujoco_capacity_ramp",
    "mujoco_holding_check",
    "static_capacity_scale",
]

Array = NDArray[np.float64]
Outcome = Literal["held", "slipped", "lifted_off"]

#: Below this fraction of the predicted margin the brace must hold in MuJoCo.
HOLD_BELOW = 0.8
#: Above this fraction of the predicted margin it must slip or lift off (the predicted way) in MuJoCo.
FAIL_ABOVE = 1.2
#: Default scales, as fractions of the predicted margin (a wrench with no finite margin: absolute scales).
DEFAULT_FRACTIONS = (0.25, 0.5, 0.8, 1.2)
DEFAULT_SCALES = (0.5, 1.0)

#: MuJoCo settings of the holding check (recorded in reports).
HOLDING_SETTINGS: dict[str, Any] = {
    "contact": (
        "sphere (radius 0.1 mm) on a plane, condim 3 (sliding friction mu; condim 1 without mu), elliptic cone, "
        "solref '0.002 1', solimp '0.9999 0.9999 0.001'"
    ),
    "impratio": 10.0,
    "timestep_s": 2.5e-4,
    "gravity": "URDF masses and inertias, 9.81 m/s^2 along -z (when the holding has gravity)",
    "set_points": "q_s = q + K^-1 tau0 from bracekit.statics.contact_response",
    "load": "dead tip wrench ramped in over 2 tau, then settled until max|qdot|*tau < 1e-7 rad (at most 16 tau)",
    "slip_tol_m": 1e-4,
}

_SPHERE_RADIUS = 1e-4  # m
_RAMP = 2.0  # ramp time of the load, in units of τ
_MIN_HOLD, _MAX_HOLD = 2.0, 16.0  # settling time after the ramp, in units of τ
_SETTLE_TOL = 1e-7  # rad: remaining motion max|q̇|·τ
_CHUNK = 10  # steps between re-applications of the dead load and settling checks


@dataclass(frozen=True, eq=False)
class HoldingCase:
    """MuJoCo against the first-order prediction for one scaled wrench s·w.

    Attributes:
        scale: s (dimensionless multiplier of the wrench).
        fraction: s / predicted margin (None when the margin is infinite).
        wrench: s·w (6,), [f; m] at the tip, world axes (N, N·m).
        predicted_force: force part of f_c0 + s δf_c (3,), N, world axes, on the robot at b.
        mujoco_force: MuJoCo's contact force on the sphere (3,), N, world axes (zeros if the contact opened).
        predicted_normal, mujoco_normal: n̂ᵀ f (N, > 0 pressing).
        predicted_tangential, mujoco_tangential: ‖(I − n̂n̂ᵀ) f‖ (N).
        rel_err: ‖f_mujoco − f_pred‖ / ‖f_pred‖ where MuJoCo held and bracekit predicts holding, else None.
        rel_err_change: ‖f_mujoco − f_pred‖ / ‖s δf_c(w)‖, the error of the load's effect (same cases).
        torque_rel_err: ‖τ_mujoco − τ_pred‖ / ‖τ_pred‖, τ_mujoco = K (q_s − q), on the same cases, else None.
        cone_ratio: ‖f_t‖ / (μ f_n) in MuJoCo (None without μ or with the contact open).
        slip_displacement: tangential displacement of the material point b, settled loaded − unloaded (m).
        outcome: what MuJoCo did: ``held``, ``slipped`` or ``lifted_off``.
        expected: what the prediction requires at this fraction (``held`` below HOLD_BELOW, the predicted
            failure above FAIL_ABOVE), None in between.
        agrees: outcome == expected (None when nothing is expected).
        settled: the loaded state met the settling tolerance (a slipping contact may keep sliding).
        steps: MuJoCo steps of the loaded phase.
    """

    scale: float
    fraction: float | None
    wrench: Array
    predicted_force: Array
    mujoco_force: Array
    predicted_normal: float
    mujoco_normal: float
    predicted_tangential: float
    mujoco_tangential: float
    rel_err: float | None
    rel_err_change: float | None
    torque_rel_err: float | None
    cone_ratio: float | None
    slip_displacement: float
    outcome: Outcome
    expected: Outcome | None
    agrees: bool | None
    settled: bool
    steps: int

    def to_json(self) -> dict[str, Any]:
        """JSON-able dict (no NaN: missing numbers are None)."""
        return {
            "scale": self.scale,
            "fraction_of_margin": self.fraction,
            "wrench": self.wrench.tolist(),
            "predicted_force_N": self.predicted_force.tolist(),
            "mujoco_force_N": self.mujoco_force.tolist(),
            "predicted_normal_N": self.predicted_normal,
            "mujoco_normal_N": self.mujoco_normal,
            "predicted_tangential_N": self.predicted_tangential,
            "mujoco_tangential_N": self.mujoco_tangential,
            "rel_err": self.rel_err,
            "rel_err_change": self.rel_err_change,
            "torque_rel_err": self.torque_rel_err,
            "cone_ratio": self.cone_ratio,
            "slip_displacement_m": self.slip_displacement,
            "outcome": self.outcome,
            "expected": self.expected,
            "agrees": self.agrees,
            "settled": self.settled,
            "steps": self.steps,
        }


@dataclass(frozen=True, eq=False)
class HoldingCheck:
    """Result of :func:`mujoco_holding_check` at one configuration for one tool wrench w.

    Attributes:
        q: the commanded configuration (n,), rad.
        wrench: w (6,), N and N·m, world axes, at the tip.
        preload: P (N). friction: μ or None. gravity: whether gravity was on.
        liftoff_margin: predicted scale of w at which the brace lifts off (inf: never).
        slip_margin: predicted scale at which it slips (inf: never; None without μ).
        margin: the smaller of the two; mode: the predicted failure (``lifted_off`` / ``slipped``; None if inf).
        unloaded_force: MuJoCo's settled contact force without load (3,), N, world axes.
        unloaded_normal_rel_err: |f_n − P| / P (None for P = 0).
        unloaded_tangential: ‖f_t‖ without load in MuJoCo (N; the prediction is 0).
        cases: one :class:`HoldingCase` per scale.
        settle_time: the damping time constant τ (s of simulated time); timestep: s.
    """

    q: Array
    wrench: Array
    preload: float
    friction: float | None
    gravity: bool
    liftoff_margin: float
    slip_margin: float | None
    margin: float
    mode: Outcome | None
    unloaded_force: Array
    unloaded_normal_rel_err: float | None
    unloaded_tangential: float
    settle_time: float
    timestep: float
    cases: list[HoldingCase] = field(default_factory=list)

    @property
    def creep(self) -> float:
        """Largest tangential displacement of b over the cases MuJoCo held (m): the soft contact's creep."""
        held = [c.slip_displacement for c in self.cases if c.outcome == "held"]
        return max(held) if held else 0.0

    def to_json(self) -> dict[str, Any]:
        """JSON-able dict (infinite margins as None)."""
        return {
            "q": self.q.tolist(),
            "wrench": self.wrench.tolist(),
            "preload_N": self.preload,
            "friction": self.friction,
            "gravity": self.gravity,
            "liftoff_margin": _finite(self.liftoff_margin),
            "slip_margin": None if self.slip_margin is None else _finite(self.slip_margin),
            "margin": _finite(self.margin),
            "mode": self.mode,
            "unloaded_force_N": self.unloaded_force.tolist(),
            "unloaded_normal_rel_err": self.unloaded_normal_rel_err,
            "unloaded_tangential_N": self.unloaded_tangential,
            "creep_m": self.creep,
            "settle_time_s": self.settle_time,
            "timestep_s": self.timestep,
            "cases": [c.to_json() for c in self.cases],
        }


def _finite(x: float) -> float | None:
    return float(x) if np.isfinite(x) else None


def _expected(fraction: float | None, mode: Outcome | None) -> Outcome | None:
    if fraction is None or mode is None:
        return "held"
    if fraction <= HOLD_BELOW * (1.0 + 1e-9):
        return "held"
    if fraction >= FAIL_ABOVE * (1.0 - 1e-9):
        return mode
    return None


class _Sim:
    """The MuJoCo model, its data and the handles of the holding check."""

    def __init__(self, xml: str, q: Array, q_s: Array, k: Array, b: Array, messages: list[str]) -> None:
        try:
            self.m = mujoco.MjModel.from_xml_string(xml)
        except ValueError as exc:
            raise MujocoValidationError(f"MuJoCo rejected the generated model: {exc}") from exc
        self.d = mujoco.MjData(self.m)
        self.messages = messages
        self.q_s, self.k = q_s, k
        self.tau = float(self.m.dof_damping[0] / k[0])  # damping = τ k_i
        self.site = mujoco.mj_name2id(self.m, mujoco.mjtObj.mjOBJ_SITE, TIP_SITE)
        self.tip_body = int(self.m.site_bodyid[self.site])
        self.sphere = mujoco.mj_name2id(self.m, mujoco.mjtObj.mjOBJ_GEOM, BRACE_GEOM)
        self.plane = mujoco.mj_name2id(self.m, mujoco.mjtObj.mjOBJ_GEOM, SURFACE_GEOM)
        self.body = int(self.m.geom_bodyid[self.sphere])
        self.d.qpos[:] = q
        self.d.qvel[:] = 0.0
        mujoco.mj_forward(self.m, self.d)
        self.b_local = self.d.xmat[self.body].reshape(3, 3).T @ (b - self.d.xpos[self.body])

    def b_point(self) -> Array:
        """World position of the material point b (m)."""
        return np.asarray(self.d.xpos[self.body] + self.d.xmat[self.body].reshape(3, 3) @ self.b_local)

    def contact_force(self) -> tuple[Array, int]:
        """Force of the plane on the sphere (3,), N, world axes, and the number of active contacts."""
        total, count, f6 = np.zeros(3), 0, np.zeros(6)
        for i in range(self.d.ncon):
            c = self.d.contact[i]
            if {int(c.geom1), int(c.geom2)} != {self.sphere, self.plane} or c.exclude != 0 or c.efc_address < 0:
                continue
            mujoco.mj_contactForce(self.m, self.d, i, f6)
            f = c.frame.reshape(3, 3).T @ f6[:3]  # contact frame (rows: normal, tangents) → world; on geom2
            total += f if int(c.geom2) == self.sphere else -f
            count += 1
        return total, count

    def settle(self, w: Array, phase: str) -> tuple[int, bool]:
        """Ramp the dead tip wrench w in over _RAMP·τ, then step until settled; (steps, settled)."""
        m, d = self.m, self.d
        dt = float(m.opt.timestep)
        ramp = int(np.ceil(_RAMP * self.tau / dt)) if np.any(w != 0.0) else 0
        least = ramp + int(np.ceil(_MIN_HOLD * self.tau / dt))
        most = ramp + int(np.ceil(_MAX_HOLD * self.tau / dt))
        steps = 0
        while steps < most:
            a = 1.0 if ramp == 0 else min(1.0, steps / ramp)
            d.qfrc_applied[:] = 0.0
            if a > 0.0 and np.any(w != 0.0):
                mujoco.mj_kinematics(m, d)
                f, tq = a * w[:3], a * w[3:]
                mujoco.mj_applyFT(m, d, f, tq, d.site_xpos[self.site].copy(), self.tip_body, d.qfrc_applied)
            mujoco.mj_step(m, d, _CHUNK)
            steps += _CHUNK
            _check_warnings(d, phase, self.messages)
            if steps >= least and float(np.max(np.abs(d.qvel))) * self.tau < _SETTLE_TOL:
                break
        settled = float(np.max(np.abs(d.qvel))) * self.tau < _SETTLE_TOL
        d.qfrc_applied[:] = 0.0
        if np.any(w != 0.0):
            mujoco.mj_kinematics(m, d)
            mujoco.mj_applyFT(
                m, d, w[:3].copy(), w[3:].copy(), d.site_xpos[self.site].copy(), self.tip_body, d.qfrc_applied
            )
        mujoco.mj_forward(m, d)
        return steps, settled


def mujoco_holding_check(
    braced: BracedRobot,
    q: ArrayLike,
    holding: Holding,
    wrench: ArrayLike,
    scales: ArrayLike | None = None,
    *,
    fractions: ArrayLike = DEFAULT_FRACTIONS,
    impratio: float = HOLDING_SETTINGS["impratio"],
    timestep: float = HOLDING_SETTINGS["timestep_s"],
    slip_tol: float = HOLDING_SETTINGS["slip_tol_m"],
) -> HoldingCheck:
    """Settle the preloaded, gravity-loaded, frictional brace in MuJoCo and load it with s·w (module docstring).

    Args:
        braced: the braced robot (frictionless point brace, rigid surface; chain of revolute joints).
        q: the commanded configuration (n,), rad, with b on the surface.
        holding: gravity, preload P, friction μ (None or 0: frictionless, condim 1); its wrenches are not used.
        wrench: the tool wrench w (6,), [f; m] at the tip, world axes (N, N·m).
        scales: scales s of w to simulate; default ``fractions`` × the predicted margin, or (0.5, 1) when the
            margin is infinite.
        fractions: fractions of the predicted margin used when ``scales`` is None.
        impratio: MuJoCo's frictional-to-normal impedance ratio (≥ 1; larger: less creep).
        timestep: MuJoCo timestep (s); 1 ms lets the frictional contact on light distal links chatter.
        slip_tol: tangential displacement of b (m) above which the contact counts as slipped.

    Returns:
        :class:`HoldingCheck` with the unloaded state and one case per scale.

    Raises:
        InputError: bad inputs, or a brace MuJoCo's sphere does not model (not a frictionless point, a
            compliant surface).
        MujocoValidationError: the simulation goes unstable, or the contact is open without load.
        NumericalError: bracekit's preloaded equilibrium is unstable (from ``contact_responses``).
    """
    if not isinstance(braced, BracedRobot):
        raise InputError(f"expected a BracedRobot, got {type(braced).__name__}")
    if not isinstance(holding, Holding):
        raise InputError(f"holding must be a bracekit.simulation.holding.Holding, got {type(holding).__name__}")
    brace = braced.brace
    if brace.kind.name != "frictionless_point" or brace.environment_stiffness is not None:
        raise InputError(
            "the MuJoCo holding check models a point brace (frictionless_point, sticking with μ) on a rigid "
            f"surface; this brace is '{brace.kind.name}'"
            + (" with an environment stiffness" if brace.environment_stiffness is not None else "")
        )
    robot = braced.robot
    qa = robot.check_q(q)
    w = as_array(wrench, "the tool wrench [f; m] (N, N·m)").reshape(-1)
    if w.size != 6:
        raise InputError(f"the tool wrench must be 6 numbers [fx, fy, fz, mx, my, mz], got {show(w)}")
    if not (isinstance(impratio, int | float) and np.isfinite(impratio) and impratio >= 1.0):
        raise InputError(f"impratio must be a finite number >= 1, got {show(impratio)}")
    for value, name in ((timestep, "timestep (s)"), (slip_tol, "slip_tol (m)")):
        if not (isinstance(value, int | float) and np.isfinite(value) and value > 0.0):
            raise InputError(f"{name} must be a finite number > 0, got {show(value)}")
    mu = holding.friction if holding.friction else None

    resps = contact_responses(braced, qa, preload=holding.preload, gravity=holding.gravity, friction=mu)
    resp = resps.at(0)
    cap = capacity_of(resps, w[None, :], effort_limits(robot))
    liftoff = float(cap.liftoff[0, 0])
    slip = None if cap.slip is None else float(cap.slip[0, 0])
    margin = min(liftoff, np.inf if slip is None else slip)
    mode: Outcome | None = None
    if np.isfinite(margin):
        mode = "lifted_off" if liftoff <= margin else "slipped"
    s_all = _scales(scales, fractions, margin)

    nhat = brace.surface.normal
    k = robot.stiffness
    xml = build_mujoco_model(
        robot.model,
        qa,
        k,
        braced.brace_id,
        robot.tip_id,
        brace.surface.point,
        nhat,
        sphere_radius=_SPHERE_RADIUS,
        gravity=holding.gravity,
        timestep=float(timestep),
        friction=mu,
        cone="elliptic",
        impratio=float(impratio),
        set_points=resp.q_s,
    )
    messages: list[str] = []
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(messages.append)
    try:
        sim = _Sim(xml, qa, resp.q_s, k, braced.state(qa).b, messages)
        sim.settle(np.zeros(6), "unloaded settling")
        f0, ncon = sim.contact_force()
        if ncon == 0 and holding.preload > 0.0:
            raise MujocoValidationError("no sphere–surface contact under the preload: does b lie on the surface at q?")
        b0 = sim.b_point()
        start = mujoco.MjData(sim.m)
        mujoco.mj_copyData(start, sim.m, sim.d)
        cases = []
        for s in s_all:
            mujoco.mj_copyData(sim.d, sim.m, start)
            steps, settled = sim.settle(s * w, f"loaded settling (scale {s:.3g})")
            cases.append(_case(sim, resp, w, s, margin, mode, mu, nhat, b0, slip_tol, steps, settled))
    finally:
        mujoco.set_mju_user_warning(previous)
    fn0 = float(f0 @ nhat)
    return HoldingCheck(
        q=qa.copy(),
        wrench=w.copy(),
        preload=float(holding.preload),
        friction=mu,
        gravity=bool(holding.gravity),
        liftoff_margin=liftoff,
        slip_margin=slip,
        margin=float(margin),
        mode=mode,
        unloaded_force=f0,
        unloaded_normal_rel_err=abs(fn0 - holding.preload) / holding.preload if holding.preload > 0.0 else None,
        unloaded_tangential=float(np.linalg.norm(f0 - fn0 * nhat)),
        settle_time=sim.tau,
        timestep=float(sim.m.opt.timestep),
        cases=cases,
    )


def _scales(scales: ArrayLike | None, fractions: ArrayLike, margin: float) -> Array:
    if scales is None:
        if not np.isfinite(margin):
            return np.array(DEFAULT_SCALES)
        fr = as_array(fractions, "the fractions of the margin").reshape(-1)
        if fr.size == 0 or np.any(fr < 0.0):
            raise InputError(f"fractions must be numbers >= 0, got {show(fr)}")
        return np.asarray(fr * margin, dtype=float)
    s = as_array(scales, "the scales of the wrench").reshape(-1)  # empty: the unloaded state only
    if np.any(s < 0.0):
        raise InputError(f"scales must be numbers >= 0, got {show(s)}")
    return np.asarray(s, dtype=float)


def _case(
    sim: _Sim,
    resp: ContactResponse,
    w: Array,
    s: float,
    margin: float,
    mode: Outcome | None,
    mu: float | None,
    nhat: Array,
    b0: Array,
    slip_tol: float,
    steps: int,
    settled: bool,
) -> HoldingCase:
    f_mj, ncon = sim.contact_force()
    fn_mj = float(f_mj @ nhat)
    db = sim.b_point() - b0
    disp = float(np.linalg.norm(db - (db @ nhat) * nhat))
    outcome: Outcome
    if ncon == 0 or fn_mj <= 0.0:
        outcome, f_mj, fn_mj = "lifted_off", np.zeros(3), 0.0
    elif mu is not None and disp > slip_tol:  # a frictionless point slides freely: only lift-off counts
        outcome = "slipped"
    else:
        outcome = "held"
    f_pred = np.asarray(resp.contact_wrench(s * w)[:3], dtype=float)
    fn_pred = float(f_pred @ nhat)
    ft_mj = float(np.linalg.norm(f_mj - fn_mj * nhat))
    fraction = float(s / margin) if np.isfinite(margin) and margin > 0.0 else None
    expected = _expected(fraction, mode)
    compare = outcome == "held" and (fraction is None or fraction < 1.0)
    rel_err = change_err = torque_err = None
    if compare:
        den = float(np.linalg.norm(f_pred))
        rel_err = float(np.linalg.norm(f_mj - f_pred)) / den if den > 0.0 else None
        den_c = float(np.linalg.norm(f_pred - resp.f_c0[:3]))
        change_err = float(np.linalg.norm(f_mj - f_pred)) / den_c if den_c > 0.0 else None
        tau_mj = sim.k * (sim.q_s - sim.d.qpos)
        tau_pred = np.asarray(resp.torque(s * w), dtype=float)
        den_t = float(np.linalg.norm(tau_pred))
        torque_err = float(np.linalg.norm(tau_mj - tau_pred)) / den_t if den_t > 0.0 else None
    return HoldingCase(
        scale=float(s),
        fraction=fraction,
        wrench=s * w,
        predicted_force=f_pred,
        mujoco_force=f_mj,
        predicted_normal=fn_pred,
        mujoco_normal=fn_mj,
        predicted_tangential=float(np.linalg.norm(f_pred - fn_pred * nhat)),
        mujoco_tangential=ft_mj,
        rel_err=rel_err,
        rel_err_change=change_err,
        torque_rel_err=torque_err,
        cone_ratio=ft_mj / (mu * fn_mj) if mu is not None and fn_mj > 0.0 else None,
        slip_displacement=disp,
        outcome=outcome,
        expected=expected,
        agrees=None if expected is None else outcome == expected,
        settled=settled,
        steps=steps,
    )


# --------------------------------------------------------------------------------------------------
# Capacity under a slow load ramp
# --------------------------------------------------------------------------------------------------
#: Settings of :func:`mujoco_capacity_ramp` (recorded in reports).
RAMP_SETTINGS: dict[str, Any] = {
    "ramp": (
        "dead tip wrench s(t)*w, s(t) = rate*t from the settled unloaded state, rate = s_pred / (ramp_time*tau): "
        "s reaches the predicted scale after ramp_time damping time constants tau"
    ),
    "ramp_time_tau": 40.0,
    "stop_at": "2 x the predicted scale",
    "unbreakable_ramp_to": 10.0,
    "unbreakable": (
        "a wrench that neither lifts off nor slips at any scale (first order) is ramped to unbreakable_ramp_to x w "
        "at the rate that reaches it after ramp_time tau; it must hold"
    ),
    "liftoff_event": "no active sphere-plane contact, or normal force <= 0",
    "slip_event": "|f_t| >= (1 - cone_tol) mu f_n (the force reaches MuJoCo's elliptic Coulomb cone)",
    "cone_tol": 1e-3,
    "slide_event": "tangential displacement of b from the unloaded state > slide_tol_m",
    "slide_tol_m": 1e-5,
    "static_scale": (
        "root in s of f_n(s) (lift-off) or mu f_n(s) - |f_t(s)| (slip) of solve_static_equilibrium with the "
        "same set points, gravity, the bilateral load contact X_L (sticking point with mu), brentq"
    ),
}


@dataclass(frozen=True, eq=False)
class CapacityRamp:
    """MuJoCo's lift-off or slip scale of a tool wrench under a slow ramp, against bracekit's predicted scales.

    Scales s are dimensionless multipliers of the tool wrench w. The failure tested is the one the first-order
    statics predict first (``mode``); MuJoCo's scale is that of the first event along the ramp.

    Attributes:
        q: the commanded configuration (n,), rad.
        wrench: w (6,), [f; m] at the tip, world axes (N, N·m).
        preload: P (N). friction: μ or None (frictionless: lift-off only). gravity: whether gravity was on.
        mode: the predicted failure tested, ``lifted_off`` or ``slipped``; ``held`` for a wrench that neither
            lifts off nor slips at any scale (ramped to ``stop_scale``).
        liftoff_margin, slip_margin: first-order scales of lift-off and slip (inf: never; slip None without μ).
        predicted_scale: the first-order scale of ``mode`` (:func:`bracekit.statics.capacity_of`; inf: holds).
        static_scale: the scale of ``mode`` in the nonlinear rigid statics (None if the solve failed).
        static_message: why the static scale is missing, else None.
        mujoco_scale: s at MuJoCo's first event along the ramp (None: no event before ``stop_scale``).
        mujoco_outcome: that event: ``lifted_off`` (contact open or normal force 0) or ``slipped`` (the
            contact force reached the Coulomb cone); None without an event (``held`` for a ``held`` mode).
        slide_scale: with μ, s at which the tangential displacement of b exceeded ``slide_tol`` (None: never).
        creep: tangential displacement of b at the event, or at the end of the ramp without one (m).
        rel_err: |predicted_scale − mujoco_scale| / mujoco_scale (None without a MuJoCo scale).
        rel_err_static: |static_scale − mujoco_scale| / mujoco_scale (None when either is missing).
        rate: ramp rate ds/dt (1/s); stop_scale: the ramp's last scale; settle_time: τ (s); timestep: s.
        steps: MuJoCo steps of the ramp.
    """

    q: Array
    wrench: Array
    preload: float
    friction: float | None
    gravity: bool
    mode: Outcome
    liftoff_margin: float
    slip_margin: float | None
    predicted_scale: float
    static_scale: float | None
    static_message: str | None
    mujoco_scale: float | None
    mujoco_outcome: Outcome | None
    slide_scale: float | None
    creep: float
    rel_err: float | None
    rel_err_static: float | None
    rate: float
    stop_scale: float
    settle_time: float
    timestep: float
    steps: int

    def to_json(self) -> dict[str, Any]:
        """JSON-able dict (infinite margins as None)."""
        return {
            "q": self.q.tolist(),
            "wrench": self.wrench.tolist(),
            "preload_N": self.preload,
            "friction": self.friction,
            "gravity": self.gravity,
            "mode": self.mode,
            "liftoff_margin": _finite(self.liftoff_margin),
            "slip_margin": None if self.slip_margin is None else _finite(self.slip_margin),
            "predicted_scale": _finite(self.predicted_scale),
            "static_scale": self.static_scale,
            "static_message": self.static_message,
            "mujoco_scale": self.mujoco_scale,
            "mujoco_outcome": self.mujoco_outcome,
            "agrees": self.mujoco_outcome == self.mode,
            "slide_scale": self.slide_scale,
            "creep_m": self.creep,
            "rel_err": self.rel_err,
            "rel_err_static": self.rel_err_static,
            "rate_per_s": self.rate,
            "stop_scale": self.stop_scale,
            "settle_time_s": self.settle_time,
            "timestep_s": self.timestep,
            "steps": self.steps,
        }


def static_capacity_scale(
    braced: BracedRobot, q: ArrayLike, holding: Holding, wrench: ArrayLike, mode: Outcome, guess: float
) -> float:
    """The scale s of ``wrench`` at which the nonlinear rigid statics lift off or slip (``mode``).

    The chain has bracekit's set points (gravity and the preload P n̂ at q) and a bilateral load contact X_L
    (:func:`bracekit.statics.load_contact_wrenches`: the sticking point with μ, else [n̂; 0]);
    :func:`~bracekit.validate.statics.solve_static_equilibrium` gives its contact force f_c(s) under s·w. The
    scale is the root of f_n(s) (``lifted_off``) or μ f_n(s) − ‖f_t(s)‖ (``slipped``), bracketed from
    ``guess`` (e.g. the first-order scale) and found by Brent's method to 1e-7 relative.

    Raises:
        InputError: bad inputs, or ``slipped`` without friction.
        StaticSolveError: a static solve fails, or no sign change up to 8 × ``guess``.
    """
    robot, brace = braced.robot, braced.brace
    qa = robot.check_q(q)
    w = as_array(wrench, "the tool wrench [f; m] (N, N·m)").reshape(6)
    mu = holding.friction if holding.friction else None
    if mode == "slipped" and mu is None:
        raise InputError("a slip scale needs a friction coefficient μ > 0 in the holding")
    if not (np.isfinite(guess) and guess > 0.0):
        raise InputError(f"guess must be a finite scale > 0, got {show(guess)}")
    nhat = brace.surface.normal
    x_l = load_contact_wrenches(brace, mu)

    def margin(s: float) -> float:
        res = solve_static_equilibrium(
            robot.model, qa, robot.stiffness, braced.brace_id, robot.tip_id, brace.surface.point, nhat, s * w,
            preload=holding.preload, gravity=holding.gravity, constraint_wrenches=x_l,
        )  # fmt: skip
        f = res.contact_wrench[:3]
        fn = float(f @ nhat)
        if mode == "lifted_off":
            return fn
        assert mu is not None
        return mu * fn - float(np.linalg.norm(f - fn * nhat))

    lo, hi = 0.0, float(guess)
    g_hi = margin(hi)
    while g_hi > 0.0:
        lo, hi = hi, 1.25 * hi
        if hi > 8.0 * guess:
            raise StaticSolveError(
                f"the nonlinear statics do not {mode.replace('_', ' ')} up to 8 x the scale {guess:.4g}"
            )
        g_hi = margin(hi)
    if lo == 0.0:
        lo = hi
        while margin(lo) <= 0.0:
            lo *= 0.8
            if lo < 1e-3 * guess:
                raise StaticSolveError(
                    f"the nonlinear statics {mode.replace('_', ' ')} below 1e-3 x the scale {guess:.4g}"
                )
    return float(brentq(margin, lo, hi, xtol=1e-7 * guess, rtol=1e-10))


def mujoco_capacity_ramp(
    braced: BracedRobot,
    q: ArrayLike,
    holding: Holding,
    wrench: ArrayLike,
    *,
    ramp_time: float = RAMP_SETTINGS["ramp_time_tau"],
    impratio: float = HOLDING_SETTINGS["impratio"],
    timestep: float = HOLDING_SETTINGS["timestep_s"],
    cone_tol: float = RAMP_SETTINGS["cone_tol"],
    slide_tol: float = RAMP_SETTINGS["slide_tol_m"],
    static: bool = True,
    hold_scale: float = RAMP_SETTINGS["unbreakable_ramp_to"],
) -> CapacityRamp:
    """Ramp the tool wrench s·w slowly in MuJoCo and find the scale at which the brace lifts off or slips.

    The MuJoCo model is that of :func:`mujoco_holding_check` (bracekit's set points, gravity, elliptic Coulomb
    cone with μ). From the settled unloaded state the dead tip wrench grows as s(t) = rate·t, rate =
    s_pred / (``ramp_time``·τ), τ the damping time constant of the heaviest mode (quasi-static: the first-order
    system lags the load by about τ, and the detected scale changes by < 0.3 % between 20τ and 80τ here).
    Every 10 steps the contact is checked: it has **lifted off** when no sphere–plane contact is active or its
    normal force is 0, and **slipped** when ‖f_t‖ ≥ (1 − ``cone_tol``) μ f_n (the force is on MuJoCo's
    Coulomb cone: the sticking contact can take no more tangential force) or b has slid ``slide_tol`` first.
    The ramp goes on after a slip until b has slid ``slide_tol`` (``slide_scale``), lifts off, or s reaches
    2 s_pred.

    The failure tested is the one the first-order statics predict first. A wrench that neither lifts off nor
    slips at any scale (s_pred infinite) is a fact to show, not an error: it is ramped to ``hold_scale`` × w
    (reached after ``ramp_time`` τ) and must hold (``mode`` and, without an event, ``mujoco_outcome`` are
    ``held``); with ``static`` the nonlinear statics are solved at that scale too (``static_message``).
    Otherwise, with ``static``, the nonlinear statics' scale (:func:`static_capacity_scale`) is computed.

    Raises:
        InputError: bad inputs or a brace MuJoCo does not model.
        MujocoValidationError: the simulation goes unstable, or the contact is open without load.
        NumericalError: bracekit's preloaded equilibrium is unstable.
    """
    if not isinstance(braced, BracedRobot):
        raise InputError(f"expected a BracedRobot, got {type(braced).__name__}")
    if not isinstance(holding, Holding):
        raise InputError(f"holding must be a bracekit.simulation.holding.Holding, got {type(holding).__name__}")
    brace = braced.brace
    if brace.kind.name != "frictionless_point" or brace.environment_stiffness is not None:
        raise InputError(
            "the MuJoCo capacity ramp models a point brace (frictionless_point, sticking with μ) on a rigid surface; "
            f"this brace is '{brace.kind.name}'"
        )
    robot = braced.robot
    qa = robot.check_q(q)
    w = as_array(wrench, "the tool wrench [f; m] (N, N·m)").reshape(-1)
    if w.size != 6:
        raise InputError(f"the tool wrench must be 6 numbers [fx, fy, fz, mx, my, mz], got {show(w)}")
    for value, name, low in (
        (ramp_time, "ramp_time (in damping time constants)", 0.0),
        (impratio, "impratio", 1.0),
        (timestep, "timestep (s)", 0.0),
        (cone_tol, "cone_tol", 0.0),
        (slide_tol, "slide_tol (m)", 0.0),
        (hold_scale, "hold_scale", 0.0),
    ):
        ok = isinstance(value, int | float) and not isinstance(value, bool) and np.isfinite(value)
        if not ok or value < low or (low == 0.0 and value <= 0.0):
            raise InputError(f"{name} must be a finite number {'>= 1' if low else '> 0'}, got {show(value)}")
    mu = holding.friction if holding.friction else None

    resps = contact_responses(braced, qa, preload=holding.preload, gravity=holding.gravity, friction=mu)
    resp = resps.at(0)
    cap = capacity_of(resps, w[None, :], effort_limits(robot))
    liftoff = float(cap.liftoff[0, 0])
    slip = None if cap.slip is None else float(cap.slip[0, 0])
    predicted = min(liftoff, np.inf if slip is None else slip)
    if not predicted > 0.0:
        raise MujocoValidationError(
            f"bracekit's statics say the brace fails without load under the wrench {show(w)} (scale {predicted:g})"
        )
    unbreakable = not np.isfinite(predicted)
    mode: Outcome = "held" if unbreakable else ("lifted_off" if liftoff <= predicted else "slipped")

    static_scale: float | None = None
    static_message: str | None = None
    if static and unbreakable:
        static_message = _static_holds(braced, qa, holding, w, float(hold_scale))
    elif static:
        try:
            static_scale = static_capacity_scale(braced, qa, holding, w, mode, predicted)
        except StaticSolveError as exc:
            static_message = str(exc)

    nhat = brace.surface.normal
    xml = build_mujoco_model(
        robot.model, qa, robot.stiffness, braced.brace_id, robot.tip_id, brace.surface.point, nhat,
        sphere_radius=_SPHERE_RADIUS, gravity=holding.gravity, timestep=float(timestep), friction=mu, cone="elliptic",
        impratio=float(impratio), set_points=resp.q_s,
    )  # fmt: skip
    messages: list[str] = []
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(messages.append)
    try:
        sim = _Sim(xml, qa, resp.q_s, robot.stiffness, braced.state(qa).b, messages)
        sim.settle(np.zeros(6), "unloaded settling")
        _, ncon = sim.contact_force()
        if ncon == 0 and holding.preload > 0.0:
            raise MujocoValidationError("no sphere–surface contact under the preload: does b lie on the surface at q?")
        target, stop = (float(hold_scale),) * 2 if unbreakable else (float(predicted), 2.0 * float(predicted))
        ramp = _ramp(sim, w, target, stop, float(ramp_time), mu, nhat, float(cone_tol), float(slide_tol))
    finally:
        mujoco.set_mju_user_warning(previous)
    s_mj, outcome, slide, creep, rate, stop, steps = ramp
    if unbreakable and outcome is None:
        outcome = "held"  # ramped to hold_scale × w without an event

    def rel(x: float | None) -> float | None:
        return None if x is None or s_mj is None else abs(x - s_mj) / s_mj

    return CapacityRamp(
        q=qa.copy(),
        wrench=w.copy(),
        preload=float(holding.preload),
        friction=mu,
        gravity=bool(holding.gravity),
        mode=mode,
        liftoff_margin=liftoff,
        slip_margin=slip,
        predicted_scale=float(predicted),
        static_scale=static_scale,
        static_message=static_message,
        mujoco_scale=s_mj,
        mujoco_outcome=outcome,
        slide_scale=slide,
        creep=creep,
        rel_err=rel(float(predicted)),
        rel_err_static=rel(static_scale),
        rate=rate,
        stop_scale=stop,
        settle_time=sim.tau,
        timestep=float(sim.m.opt.timestep),
        steps=steps,
    )


#: A contact lost within this fraction of its friction cone's edge is counted as a slip, not a lift-off.
_EDGE_TOL = 0.01


def _static_holds(braced: BracedRobot, q: Array, holding: Holding, w: Array, scale: float) -> str:
    """Whether the nonlinear rigid statics (sticking load contact) still hold at ``scale`` × w, in words."""
    robot, brace = braced.robot, braced.brace
    mu = holding.friction if holding.friction else None
    nhat = brace.surface.normal
    try:
        res = solve_static_equilibrium(
            robot.model, q, robot.stiffness, braced.brace_id, robot.tip_id, brace.surface.point, nhat, scale * w,
            preload=holding.preload, gravity=holding.gravity, constraint_wrenches=load_contact_wrenches(brace, mu),
        )  # fmt: skip
    except StaticSolveError as exc:
        return f"nonlinear statics at {scale:g} x w: {exc}"
    f = res.contact_wrench[:3]
    fn = float(f @ nhat)
    ft = float(np.linalg.norm(f - fn * nhat))
    if fn <= 0.0:
        return f"nonlinear statics lift off below {scale:g} x w (normal force {fn:.3g} N there)"
    if mu is not None and ft > mu * fn:
        return f"nonlinear statics slip below {scale:g} x w (|f_t| / f_n = {ft / fn:.3g} > mu there)"
    return f"nonlinear statics hold at {scale:g} x w (f_n = {fn:.4g} N, |f_t| = {ft:.3g} N)"


def _ramp(
    sim: _Sim,
    w: Array,
    target: float,
    stop: float,
    ramp_time: float,
    mu: float | None,
    nhat: Array,
    cone_tol: float,
    slide_tol: float,
) -> tuple[float | None, Outcome | None, float | None, float, float, float, int]:
    """The load ramp of :func:`mujoco_capacity_ramp`: (scale, outcome, slide scale, creep, rate, stop, steps).

    s grows at the rate that reaches ``target`` after ``ramp_time`` τ and the ramp ends past ``stop``.
    """
    m, d = sim.m, sim.d
    dt = float(m.opt.timestep)
    rate = target / (ramp_time * sim.tau)
    b0 = sim.b_point()
    scale: float | None = None
    outcome: Outcome | None = None
    slide: float | None = None
    creep = 0.0
    steps = 0
    last_ratio = 0.0  # ‖f_t‖/f_n of the last chunk in contact
    while True:
        s = rate * steps * dt
        if s > stop:
            break
        d.qfrc_applied[:] = 0.0
        mujoco.mj_kinematics(m, d)
        mujoco.mj_applyFT(m, d, s * w[:3], s * w[3:], d.site_xpos[sim.site].copy(), sim.tip_body, d.qfrc_applied)
        mujoco.mj_step(m, d, _CHUNK)
        steps += _CHUNK
        _check_warnings(d, f"the load ramp (scale {s:.3g})", sim.messages)
        s_now = rate * steps * dt
        f, ncon = sim.contact_force()
        fn = float(f @ nhat)
        db = sim.b_point() - b0
        disp = float(np.linalg.norm(db - (db @ nhat) * nhat))
        if outcome is None:
            creep = disp
        if ncon == 0 or fn <= 0.0:
            if outcome is None:
                # a contact lost at the edge of its cone slid off within one chunk: that is a slip
                sliding = mu is not None and last_ratio >= (1.0 - _EDGE_TOL) * mu
                scale, outcome = s_now, "slipped" if sliding else "lifted_off"
            break
        if mu is None:
            continue
        ft = float(np.linalg.norm(f - fn * nhat))
        last_ratio = ft / fn
        if outcome is None and (ft >= (1.0 - cone_tol) * mu * fn or disp > slide_tol):
            scale, outcome = s_now, "slipped"
        if disp > slide_tol:
            slide = s_now
            break
    return scale, outcome, slide, creep, rate, stop, steps
