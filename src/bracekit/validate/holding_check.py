"""MuJoCo check of whether the braces hold: contact forces, slip and lift-off under gravity, preload and friction.

bracekit's statics (:mod:`bracekit.statics.stacked`, :mod:`bracekit.statics.capacity`) set the spring set points
q_s = q + K⁻¹ τ0, τ0 = g(q) − Σ_i J_b_iᵀ [P_i n̂_i; 0], so that brace i carries its preload P_i n̂_i at the
commanded q (one brace or several, one path), and predict to first order each brace's contact force under a
scaled tool wrench s·w,

    f_c,i(s) = f_c0,i + s δf_c,i(w)    (by surface i on the robot at b_i, world axes, N),

and the scale at which brace i lifts off (f_n,i = n̂_iᵀ f_c,i reaches 0) or slips (‖f_t,i‖ reaches μ f_n,i):
each brace has its own friction cone and normal-force limit. The margin is that of the first brace to fail
(:class:`Prediction`).

:func:`mujoco_holding_check` builds the same spring-jointed chain in MuJoCo
(:func:`~bracekit.validate.mjcf.build_mujoco_model`: URDF inertias and gravity along −z, springref =
q_s, a 0.1 mm sphere at each b_i on its plane, condim 3 with sliding friction μ and MuJoCo's elliptic cone, i.e.
the Coulomb cone ‖f_t‖ ≤ μ f_n), settles it without load, then, from that state, ramps the dead tip wrench s·w
in over 2τ and settles again, for a few scales s. MuJoCo's contact force of each brace (``mj_contactForce``,
rotated from the contact frame to world axes, the force on the sphere) is compared with the first-order
prediction, and MuJoCo's outcome (held, slipped, lifted off) with the predicted margin: below ``HOLD_BELOW`` ×
the margin every brace must hold, above ``FAIL_ABOVE`` × it the braces must fail the predicted way.

Outcome in MuJoCo, per brace: ``lifted_off`` when no sphere–plane contact is active or its normal force is 0;
``slipped`` (with μ) when the material point b_i moved along the plane by more than ``slip_tol`` (m) between the
settled unloaded and loaded states; ``held`` otherwise (a frictionless point slides freely and is only checked
for lift-off). The case's outcome is ``lifted_off`` if a brace lifted off, else ``slipped`` if one slipped.
A case below HOLD_BELOW × the margin whose loaded state did not settle within the budget (its braces still
creeping below the slip threshold) has not been shown to hold: it disagrees (``settled`` False, beside its
outcome), and its forces, not an equilibrium, are not compared with the first order.
A soft-contact simulator lets a sticking contact creep
tangentially (MuJoCo's friction rows are regularised, with no position restoring term): with impratio 10 the
creep stays below about 1e-6 m here, against 3e-4 m and more for a real slip (docs/validation.md).
Actuator saturation is not simulated (MuJoCo's springs have no effort limit); the joint torques
τ = K (q_s − q) are compared with the prediction τ0 + s δτ(w) instead.
"""

from __future__ import annotations

import warnings
from typing import Any

import mujoco
import numpy as np
from numpy.typing import ArrayLike

from bracekit._linalg import as_array, show
from bracekit.errors import InputError, MujocoValidationError, RedundantContactWarning, UnloadedContactWarning
from bracekit.kinematics import BracedRobot
from bracekit.simulation.holding import Holding
from bracekit.statics import ContactResponse, capacity_of, contact_responses, effort_limits
from bracekit.validate.contacts import plane_contacts
from bracekit.validate.holding_records import BraceForce, HoldingCase, HoldingCheck, Outcome, Prediction
from bracekit.validate.inputs import Array
from bracekit.validate.mjcf import build_mujoco_model
from bracekit.validate.session import MujocoSession, captured_warnings

__all__ = [
    "FAIL_ABOVE",
    "HOLD_BELOW",
    "BraceForce",
    "HoldingCase",
    "HoldingCheck",
    "Outcome",
    "Prediction",
    "check_determinate",
    "check_mujoco_contacts",
    "mujoco_holding_check",
]

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


def _expected(fraction: float | None, pred: Prediction, s: float) -> tuple[Outcome | None, tuple[Outcome, ...]]:
    """(The outcome the first-order limits predict at scale s, the outcomes that agree with it) off the bands.

    Below HOLD_BELOW × the margin: every brace held. Above FAIL_ABOVE × the margin the brace predicted to fail
    first (i*) has failed; past its slip scale it may be near its own lift-off scale too, so the way follows that
    scale's band: lifted off past FAIL_ABOVE × s_lift,i*, slipped below HOLD_BELOW × it, either in between. (What
    the other braces do after i* fails is outside the first-order prediction.)
    """
    if fraction is None or pred.mode is None or fraction <= HOLD_BELOW * (1.0 + 1e-9):
        return "held", ("held",)
    if fraction < FAIL_ABOVE * (1.0 - 1e-9):
        return None, ()
    lift = float(pred.liftoff[pred.brace])
    if s >= FAIL_ABOVE * lift:
        return "lifted_off", ("lifted_off",)
    if s <= HOLD_BELOW * lift:
        return "slipped", ("slipped",)
    return ("lifted_off" if s >= lift else "slipped"), ("slipped", "lifted_off")


def _holding_session(
    braced: BracedRobot, q: Array, holding: Holding, q_s: Array, timestep: float, impratio: float
) -> MujocoSession:
    """The MuJoCo session of the holding checks: bracekit's set points q_s, gravity, the Coulomb cone with μ."""
    robot = braced.robot
    xml = build_mujoco_model(
        robot.model, q, robot.stiffness, robot.tip_id, plane_contacts(braced, environment=False),
        sphere_radius=_SPHERE_RADIUS, gravity=holding.gravity, timestep=float(timestep),
        friction=common_friction(braced, holding), cone="elliptic", impratio=float(impratio), set_points=q_s,
    )  # fmt: skip
    return MujocoSession(xml, robot.stiffness, q, list(braced.state(q).b_i))


def _settle(sim: MujocoSession, w: Array, phase: str) -> tuple[int, bool]:
    """Ramp the dead tip wrench w in over _RAMP·τ, then step until settled; (steps, settled)."""
    steps = sim.settle_ramped(w, phase, ramp=_RAMP, min_hold=_MIN_HOLD, max_hold=_MAX_HOLD, tol=_SETTLE_TOL)
    return steps, sim.motion() < _SETTLE_TOL


def settle_unloaded(sim: MujocoSession, holding: Holding, count: int) -> Array:
    """Settle the session without load; each brace's contact force (B×3, N, world axes).

    Raises:
        MujocoValidationError: a preloaded brace has no contact (b_i is not on its surface at q).
    """
    _settle(sim, np.zeros(6), "unloaded settling")
    forces = []
    for i, p in enumerate(holding.brace_preloads(count)):
        f, ncon = sim.contact_force(i)
        if ncon == 0 and p > 0.0:
            raise MujocoValidationError(
                f"no sphere–surface contact of brace {i} under its preload: does b_{i} lie on its surface at q?"
            )
        forces.append(f)
    return np.array(forces)


def holding_inputs(
    braced: BracedRobot, q: ArrayLike, holding: Holding, wrench: ArrayLike, what: str
) -> tuple[Array, Array]:
    """The checked configuration (n,) and tool wrench (6,) of a MuJoCo ``what`` (InputError)."""
    if not isinstance(braced, BracedRobot):
        raise InputError(f"expected a BracedRobot, got {type(braced).__name__}")
    if not isinstance(holding, Holding):
        raise InputError(f"holding must be a bracekit.simulation.holding.Holding, got {type(holding).__name__}")
    check_mujoco_contacts(braced, holding, what)
    qa = braced.robot.check_q(q)
    w = as_array(wrench, "the tool wrench [f; m] (N, N·m)").reshape(-1)
    if w.size != 6:
        raise InputError(f"the tool wrench must be 6 numbers [fx, fy, fz, mx, my, mz], got {show(w)}")
    return qa, w


def check_mujoco_contacts(braced: BracedRobot, holding: Holding, what: str) -> None:
    """InputError unless the MuJoCo ``what`` models every brace: contact types MuJoCo models, rigid surfaces, one μ.

    MuJoCo's sphere on a plane models a rigid surface (a brace with k_env is checked by the environment
    block); the model gives every sphere–plane pair the same sliding friction, so the braces' μ_i must agree.
    """
    plane_contacts(braced)  # a contact type MuJoCo models
    for i, brace in enumerate(braced.braces):
        if brace.environment_stiffness is not None:
            raise InputError(f"the MuJoCo {what} models rigid surfaces; brace {i} has an environment stiffness")
    common_friction(braced, holding)


def check_determinate(braced: BracedRobot, qs: ArrayLike, holding: Holding, what: str) -> None:
    """InputError where the load contacts' forces are statically indeterminate at a configuration of `qs`.

    A load row that carries no load or depends on others (J_bᵀ X rank deficient: the joints cannot move the brace
    point along some constraint direction) leaves the split of a brace's force into normal and tangential parts
    free: any force X c with J_bᵀ X c = 0 can be added. Slip and lift-off then have no first-order prediction
    (MuJoCo's regularised contact picks one split), so the ``what`` is refused by name, not run.
    """
    count = len(braced.braces)
    frictions = [m if m else None for m in holding.brace_frictions(count)]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        contact_responses(
            braced,
            np.asarray(qs),
            preload=list(holding.brace_preloads(count)),
            gravity=holding.gravity,
            friction=frictions,
        )
    said = [str(w.message) for w in caught if issubclass(w.category, UnloadedContactWarning | RedundantContactWarning)]
    if said:
        raise InputError(
            f"the {what} need determinate contact forces, but at the checked configurations {said[0]} (J_bᵀ X is "
            "rank deficient): the split into normal and tangential force, and so slip and lift-off, is undefined"
        )


def common_friction(braced: BracedRobot, holding: Holding) -> float | None:
    """The one μ of every brace (None: frictionless); InputError when the braces' μ_i differ."""
    mus = {m if m else None for m in holding.brace_frictions(len(braced.braces))}
    if len(mus) != 1:
        raise InputError(
            "the MuJoCo holding and capacity checks give every brace the same friction; the braces have μ = "
            f"{', '.join('none' if m is None else f'{m:g}' for m in holding.brace_frictions(len(braced.braces)))}"
        )
    return mus.pop()


def predicted_limits(braced: BracedRobot, q: Array, holding: Holding, w: Array) -> Prediction:
    """The first-order prediction at q for the tool wrench w (6,) on every brace (each its own P_i and μ_i)."""
    count = len(braced.braces)
    frictions = [m if m else None for m in holding.brace_frictions(count)]
    resps = contact_responses(
        braced, q, preload=list(holding.brace_preloads(count)), gravity=holding.gravity, friction=frictions
    )
    cap = capacity_of(resps, w[None, :], effort_limits(braced.robot))
    slip = None if cap.brace_slip is None else np.asarray(cap.brace_slip[0, :, 0], dtype=float)
    return Prediction(resps, np.asarray(cap.brace_liftoff[0, :, 0], dtype=float), slip)


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
    """Settle the preloaded, gravity-loaded, frictional braces in MuJoCo and load them with s·w (module docstring).

    Args:
        braced: the braced robot (one or several braces of a type MuJoCo models, rigid surfaces; chain of
            revolute joints).
        q: the commanded configuration (n,), rad, with every b_i on its surface.
        holding: gravity, preloads P_i, friction μ (None or 0: frictionless, condim 1; one μ for every brace);
            its wrenches are not used.
        wrench: the tool wrench w (6,), [f; m] at the tip, world axes (N, N·m).
        scales: scales s of w to simulate; default ``fractions`` × the predicted margin (the first brace to
            fail), or (0.5, 1) when the margin is infinite.
        fractions: fractions of the predicted margin used when ``scales`` is None.
        impratio: MuJoCo's frictional-to-normal impedance ratio (≥ 1; larger: less creep).
        timestep: MuJoCo timestep (s); 1 ms lets the frictional contact on light distal links chatter.
        slip_tol: tangential displacement of a b_i (m) above which its contact counts as slipped.

    Returns:
        :class:`HoldingCheck` with the unloaded state and one case per scale.

    Raises:
        InputError: bad inputs, or a brace MuJoCo's sphere does not model (contact type, a compliant surface,
            braces with different μ).
        MujocoValidationError: the simulation goes unstable, or a contact is open without load.
        NumericalError: bracekit's preloaded equilibrium is unstable (from ``contact_responses``).
    """
    qa, w = holding_inputs(braced, q, holding, wrench, "holding check")
    if not (isinstance(impratio, int | float) and np.isfinite(impratio) and impratio >= 1.0):
        raise InputError(f"impratio must be a finite number >= 1, got {show(impratio)}")
    for value, name in ((timestep, "timestep (s)"), (slip_tol, "slip_tol (m)")):
        if not (isinstance(value, int | float) and np.isfinite(value) and value > 0.0):
            raise InputError(f"{name} must be a finite number > 0, got {show(value)}")
    pred = predicted_limits(braced, qa, holding, w)
    s_all = _scales(scales, fractions, pred.margin)
    count = len(braced.braces)
    sim = _holding_session(braced, qa, holding, pred.responses.q_s[0], timestep, impratio)
    with captured_warnings(sim.messages):
        f0 = settle_unloaded(sim, holding, count)
        b0 = [sim.b_point(i) for i in range(count)]
        start = mujoco.MjData(sim.m)
        mujoco.mj_copyData(start, sim.m, sim.d)
        cases = []
        for s in s_all:
            mujoco.mj_copyData(sim.d, sim.m, start)
            steps, settled = _settle(sim, s * w, f"loaded settling (scale {s:.3g})")
            cases.append(_case(sim, pred, w, s, holding, b0, slip_tol, steps, settled))
    return HoldingCheck(
        q=qa.copy(),
        wrench=w.copy(),
        preloads=holding.brace_preloads(count),
        friction=common_friction(braced, holding),
        gravity=bool(holding.gravity),
        prediction=pred,
        unloaded_forces=f0,
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


def _brace_force(
    sim: MujocoSession, resp: ContactResponse, i: int, sw: Array, mu: float | None, b0: Array, slip_tol: float
) -> BraceForce:
    """Brace i in MuJoCo against its first-order force under the load s·w."""
    nhat = resp.normal
    f_mj, ncon = sim.contact_force(i)
    fn_mj = float(f_mj @ nhat)
    db = sim.b_point(i) - b0
    disp = float(np.linalg.norm(db - (db @ nhat) * nhat))
    outcome: Outcome
    if ncon == 0 or fn_mj <= 0.0:
        outcome, f_mj, fn_mj = "lifted_off", np.zeros(3), 0.0
    elif mu is not None and disp > slip_tol:  # a frictionless point slides freely: only lift-off counts
        outcome = "slipped"
    else:
        outcome = "held"
    f_pred = np.asarray(resp.contact_wrench(sw)[:3], dtype=float)
    fn_pred = float(f_pred @ nhat)
    ft_mj = float(np.linalg.norm(f_mj - fn_mj * nhat))
    return BraceForce(
        predicted_force=f_pred,
        mujoco_force=f_mj,
        predicted_normal=fn_pred,
        mujoco_normal=fn_mj,
        predicted_tangential=float(np.linalg.norm(f_pred - fn_pred * nhat)),
        mujoco_tangential=ft_mj,
        cone_ratio=ft_mj / (mu * fn_mj) if mu is not None and fn_mj > 0.0 else None,
        slip_displacement=disp,
        outcome=outcome,
    )


def _case(
    sim: MujocoSession,
    pred: Prediction,
    w: Array,
    s: float,
    holding: Holding,
    b0: list[Array],
    slip_tol: float,
    steps: int,
    settled: bool,
) -> HoldingCase:
    count = len(b0)
    frictions = holding.brace_frictions(count)
    resps = [pred.response(i) for i in range(count)]
    braces = tuple(
        _brace_force(sim, resps[i], i, s * w, frictions[i] if frictions[i] else None, b0[i], slip_tol)
        for i in range(count)
    )
    failed = tuple(i for i, b in enumerate(braces) if b.outcome != "held")
    outcomes = {b.outcome for b in braces}
    outcome: Outcome = "lifted_off" if "lifted_off" in outcomes else ("slipped" if "slipped" in outcomes else "held")
    margin = pred.margin
    fraction = float(s / margin) if np.isfinite(margin) and margin > 0.0 else None
    expected, agreeing = _expected(fraction, pred, s)
    agrees = None if expected is None else (braces[pred.brace].outcome if expected != "held" else outcome) in agreeing
    if expected == "held" and not settled:  # still creeping at the end of the budget: not shown to hold
        agrees = False
    compare = outcome == "held" and settled and (fraction is None or fraction < 1.0)
    rel_err = change_err = torque_err = None
    if compare:
        f_mj = np.concatenate([b.mujoco_force for b in braces])
        f_pred = np.concatenate([b.predicted_force for b in braces])
        f_0 = np.concatenate([r.f_c0[:3] for r in resps])
        den = float(np.linalg.norm(f_pred))
        rel_err = float(np.linalg.norm(f_mj - f_pred)) / den if den > 0.0 else None
        den_c = float(np.linalg.norm(f_pred - f_0))
        change_err = float(np.linalg.norm(f_mj - f_pred)) / den_c if den_c > 0.0 else None
        tau_mj = sim.m.jnt_stiffness * (sim.m.qpos_spring - sim.d.qpos)  # K (q_s − q)
        tau_pred = np.asarray(resps[0].torque(s * w), dtype=float)  # τ of every brace together
        den_t = float(np.linalg.norm(tau_pred))
        torque_err = float(np.linalg.norm(tau_mj - tau_pred)) / den_t if den_t > 0.0 else None
    return HoldingCase(
        scale=float(s),
        fraction=fraction,
        wrench=s * w,
        braces=braces,
        focus=pred.brace,
        rel_err=rel_err,
        rel_err_change=change_err,
        torque_rel_err=torque_err,
        outcome=outcome,
        failed_braces=failed,
        expected=expected,
        agrees=agrees,
        settled=settled,
        steps=steps,
    )
