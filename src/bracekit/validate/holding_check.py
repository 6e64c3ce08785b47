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

from bracekit._linalg import as_array, show
from bracekit.errors import InputError, MujocoValidationError
from bracekit.kinematics import BracedRobot
from bracekit.simulation.holding import Holding
from bracekit.statics import (
    ContactResponse,
    capacity_of,
    contact_responses,
    effort_limits,
)
from bracekit.validate.contacts import plane_contacts
from bracekit.validate.mjcf import build_mujoco_model
from bracekit.validate.session import MujocoSession, captured_warnings

__all__ = ["FAIL_ABOVE", "HOLD_BELOW", "HoldingCase", "HoldingCheck", "check_one_brace", "mujoco_holding_check"]

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


def _holding_session(
    braced: BracedRobot, q: Array, holding: Holding, q_s: Array, timestep: float, impratio: float
) -> MujocoSession:
    """The MuJoCo session of the holding checks: bracekit's set points q_s, gravity, the Coulomb cone with μ."""
    robot = braced.robot
    mu = holding.friction if holding.friction else None
    xml = build_mujoco_model(
        robot.model, q, robot.stiffness, robot.tip_id, plane_contacts(braced, environment=False),
        sphere_radius=_SPHERE_RADIUS, gravity=holding.gravity, timestep=float(timestep), friction=mu, cone="elliptic",
        impratio=float(impratio), set_points=q_s,
    )  # fmt: skip
    return MujocoSession(xml, robot.stiffness, q, list(braced.state(q).b_i))


def _settle(sim: MujocoSession, w: Array, phase: str) -> tuple[int, bool]:
    """Ramp the dead tip wrench w in over _RAMP·τ, then step until settled; (steps, settled)."""
    steps = sim.settle_ramped(w, phase, ramp=_RAMP, min_hold=_MIN_HOLD, max_hold=_MAX_HOLD, tol=_SETTLE_TOL)
    return steps, sim.motion() < _SETTLE_TOL


def holding_inputs(
    braced: BracedRobot, q: ArrayLike, holding: Holding, wrench: ArrayLike, what: str
) -> tuple[Array, Array]:
    """The checked configuration (n,) and tool wrench (6,) of a MuJoCo ``what`` on one brace (InputError)."""
    if not isinstance(braced, BracedRobot):
        raise InputError(f"expected a BracedRobot, got {type(braced).__name__}")
    if not isinstance(holding, Holding):
        raise InputError(f"holding must be a bracekit.simulation.holding.Holding, got {type(holding).__name__}")
    check_one_brace(braced, what)
    qa = braced.robot.check_q(q)
    w = as_array(wrench, "the tool wrench [f; m] (N, N·m)").reshape(-1)
    if w.size != 6:
        raise InputError(f"the tool wrench must be 6 numbers [fx, fy, fz, mx, my, mz], got {show(w)}")
    return qa, w


def check_one_brace(braced: BracedRobot, what: str) -> None:
    """InputError unless the MuJoCo ``what`` models the brace: one brace of a type MuJoCo models, rigid surface.

    The holding and capacity checks follow one brace (several-brace versions are not built: the core's
    several-brace statics, ``contact_responses`` and ``capacity_along``, are checked by the
    compliance, preloaded and tracking blocks).
    """
    if len(braced.braces) != 1:
        raise InputError(f"the MuJoCo {what} follows one brace; this robot has {len(braced.braces)}")
    plane_contacts(braced)  # a contact type MuJoCo models
    if braced.braces[0].environment_stiffness is not None:
        raise InputError(f"the MuJoCo {what} models a rigid surface; this brace has an environment stiffness")


def predicted_limits(
    braced: BracedRobot, q: Array, holding: Holding, w: Array
) -> tuple[ContactResponse, float, float | None]:
    """The first-order prediction at q for the tool wrench w (6,) on the one brace.

    Returns its contact response, the scale at which it lifts off and the scale at which it slips (None when
    frictionless).
    """
    mu = holding.friction if holding.friction else None
    resps = contact_responses(braced, q, preload=holding.preload, gravity=holding.gravity, friction=mu)
    cap = capacity_of(resps, w[None, :], effort_limits(braced.robot))
    slip = None if cap.slip is None else float(cap.slip[0, 0])
    return resps.at(0), float(cap.liftoff[0, 0]), slip


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
    qa, w = holding_inputs(braced, q, holding, wrench, "holding check")
    brace = braced.brace
    if not (isinstance(impratio, int | float) and np.isfinite(impratio) and impratio >= 1.0):
        raise InputError(f"impratio must be a finite number >= 1, got {show(impratio)}")
    for value, name in ((timestep, "timestep (s)"), (slip_tol, "slip_tol (m)")):
        if not (isinstance(value, int | float) and np.isfinite(value) and value > 0.0):
            raise InputError(f"{name} must be a finite number > 0, got {show(value)}")
    mu = holding.friction if holding.friction else None
    resp, liftoff, slip = predicted_limits(braced, qa, holding, w)
    margin = min(liftoff, np.inf if slip is None else slip)
    mode: Outcome | None = None
    if np.isfinite(margin):
        mode = "lifted_off" if liftoff <= margin else "slipped"
    s_all = _scales(scales, fractions, margin)

    nhat = brace.surface.normal
    sim = _holding_session(braced, qa, holding, resp.q_s, timestep, impratio)
    with captured_warnings(sim.messages):
        _settle(sim, np.zeros(6), "unloaded settling")
        f0, ncon = sim.contact_force()
        if ncon == 0 and holding.preload > 0.0:
            raise MujocoValidationError("no sphere–surface contact under the preload: does b lie on the surface at q?")
        b0 = sim.b_point()
        start = mujoco.MjData(sim.m)
        mujoco.mj_copyData(start, sim.m, sim.d)
        cases = []
        for s in s_all:
            mujoco.mj_copyData(sim.d, sim.m, start)
            steps, settled = _settle(sim, s * w, f"loaded settling (scale {s:.3g})")
            cases.append(_case(sim, resp, w, s, margin, mode, mu, nhat, b0, slip_tol, steps, settled))
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
    sim: MujocoSession,
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
        tau_mj = sim.m.jnt_stiffness * (sim.m.qpos_spring - sim.d.qpos)  # K (q_s − q)
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
