"""Capacity in MuJoCo: the scale of a tool wrench at which the brace lifts off or slips under a slow load ramp.

bracekit's first-order statics (:func:`bracekit.statics.capacity_of`) predict the scale s of a tool wrench w at
which the brace lifts off (f_n reaches 0) or slips (‖f_t‖ reaches μ f_n). :func:`mujoco_capacity_ramp` ramps the
dead tip wrench s(t)·w slowly on the MuJoCo model of :mod:`bracekit.validate.holding_check` (bracekit's set
points, gravity, the elliptic Coulomb cone) and records MuJoCo's scale; :func:`static_capacity_scale` gives the
nonlinear statics' scale along the same ramp. A wrench that neither lifts off nor slips at any scale is ramped
to a stated multiple and must hold. Units: N, N·m, m; world axes.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import mujoco
import numpy as np
from numpy.typing import ArrayLike
from scipy.optimize import brentq

from bracekit._linalg import Array, as_array, show
from bracekit.errors import InputError, MujocoValidationError, StaticSolveError
from bracekit.kinematics import BracedRobot
from bracekit.simulation.holding import Holding
from bracekit.statics import load_contact_wrenches
from bracekit.statics.stacked import brace_index
from bracekit.validate.contacts import plane_contacts
from bracekit.validate.holding_check import (
    HOLDING_SETTINGS,
    Outcome,
    _holding_session,
    common_friction,
    holding_inputs,
    predicted_limits,
    settle_unloaded,
)
from bracekit.validate.holding_records import _finite
from bracekit.validate.session import CHUNK, MujocoSession, captured_warnings
from bracekit.validate.statics import solve_statics

__all__ = ["RAMP_SETTINGS", "CapacityRamp", "mujoco_capacity_ramp", "static_capacity_scale"]


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
        preloads: P_i of each brace (N). friction: μ or None (frictionless: lift-off only). gravity: whether
            gravity was on.
        mode: the predicted failure tested, ``lifted_off`` or ``slipped``; ``held`` for a wrench that neither
            lifts off nor slips at any scale (ramped to ``stop_scale``).
        brace: the brace predicted to fail first (the one of ``mode``).
        liftoff_margin, slip_margin: first-order scales of lift-off and slip, the least over the braces (inf:
            never; slip None without μ).
        predicted_scale: the first-order scale of ``mode`` (:func:`bracekit.statics.capacity_of`; inf: holds).
        static_scale: the scale of ``mode`` in the nonlinear rigid statics (None if the solve failed).
        static_message: why the static scale is missing, else None.
        mujoco_scale: s at MuJoCo's first event along the ramp (None: no event before ``stop_scale``).
        mujoco_outcome: that event: ``lifted_off`` (contact open or normal force 0) or ``slipped`` (the
            contact force reached the Coulomb cone); None without an event (``held`` for a ``held`` mode).
        mujoco_brace: the brace of MuJoCo's first event (None without one).
        slide_scale: with μ, s at which the tangential displacement of b exceeded ``slide_tol`` (None: never).
        creep: tangential displacement of b at the event, or at the end of the ramp without one (m).
        rel_err: |predicted_scale − mujoco_scale| / mujoco_scale (None without a MuJoCo scale).
        rel_err_static: |static_scale − mujoco_scale| / mujoco_scale (None when either is missing).
        rate: ramp rate ds/dt (1/s); stop_scale: the ramp's last scale; settle_time: τ (s); timestep: s.
        steps: MuJoCo steps of the ramp.
    """

    q: Array
    wrench: Array
    preloads: tuple[float, ...]
    friction: float | None
    gravity: bool
    mode: Outcome
    brace: int
    liftoff_margin: float
    slip_margin: float | None
    predicted_scale: float
    static_scale: float | None
    static_message: str | None
    mujoco_scale: float | None
    mujoco_outcome: Outcome | None
    mujoco_brace: int | None
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
            "preload_N": self.preloads[self.brace],
            "preloads_N": list(self.preloads),
            "friction": self.friction,
            "gravity": self.gravity,
            "mode": self.mode,
            "brace": self.brace,
            "liftoff_margin": _finite(self.liftoff_margin),
            "slip_margin": None if self.slip_margin is None else _finite(self.slip_margin),
            "predicted_scale": _finite(self.predicted_scale),
            "static_scale": self.static_scale,
            "static_message": self.static_message,
            "mujoco_scale": self.mujoco_scale,
            "mujoco_outcome": self.mujoco_outcome,
            "mujoco_brace": self.mujoco_brace,
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


def _load_statics(braced: BracedRobot, q: Array, holding: Holding, w: Array) -> list[Array]:
    """Each brace's contact force (3,) in the nonlinear rigid statics under the tool wrench w (N, world axes).

    The chain has bracekit's set points (gravity and each P_i n̂_i at q) and a bilateral load contact X_L,i per
    brace (:func:`bracekit.statics.load_contact_wrenches`: the sticking point with μ_i, else [n̂_i; 0]),
    solved over every contact at once (:func:`~bracekit.validate.statics.solve_statics`).
    """
    robot = braced.robot
    count = len(braced.braces)
    frictions = holding.brace_frictions(count)
    contacts = [
        replace(c, X=load_contact_wrenches(brace, mu if mu else None))
        for c, brace, mu in zip(
            plane_contacts(braced, list(holding.brace_preloads(count)), environment=False), braced.braces, frictions,
            strict=True,
        )
    ]  # fmt: skip
    res = solve_statics(robot.model, q, robot.stiffness, robot.tip_id, contacts, w, gravity=holding.gravity)
    return [np.asarray(f[:3], dtype=float) for f in res.contact_wrenches]


def _margin_of(f: Array, nhat: Array, mode: Outcome, mu: float | None) -> float:
    """f_n (``lifted_off``) or μ f_n − ‖f_t‖ (``slipped``) of one contact force f (N)."""
    fn = float(f @ nhat)
    if mode == "lifted_off":
        return fn
    assert mu is not None
    return mu * fn - float(np.linalg.norm(f - fn * nhat))


def static_capacity_scale(
    braced: BracedRobot,
    q: ArrayLike,
    holding: Holding,
    wrench: ArrayLike,
    mode: Outcome,
    guess: float,
    brace: int | None = None,
) -> float:
    """The scale s of ``wrench`` at which brace ``brace`` lifts off or slips (``mode``) in the nonlinear statics.

    Every brace stays in contact with its load contact X_L,i (:func:`_load_statics`); the scale is the root of
    f_n,i(s) (``lifted_off``) or μ_i f_n,i(s) − ‖f_t,i(s)‖ (``slipped``) of brace i = ``brace`` (None: the only
    brace), bracketed from ``guess`` (e.g. the first-order scale) and found by Brent's method to 1e-7 relative.

    Raises:
        InputError: bad inputs, or ``slipped`` without friction.
        StaticSolveError: a static solve fails, or no sign change up to 8 × ``guess``.
    """
    qa = braced.robot.check_q(q)
    w = as_array(wrench, "the tool wrench [f; m] (N, N·m)").reshape(6)
    i = brace_index(brace, len(braced.braces))
    mu_i = holding.brace_frictions(len(braced.braces))[i]
    mu = mu_i if mu_i else None
    if mode == "slipped" and mu is None:
        raise InputError("a slip scale needs a friction coefficient μ > 0 in the holding")
    if not (np.isfinite(guess) and guess > 0.0):
        raise InputError(f"guess must be a finite scale > 0, got {show(guess)}")
    nhat = braced.braces[i].surface.normal

    def margin(s: float) -> float:
        return _margin_of(_load_statics(braced, qa, holding, s * w)[i], nhat, mode, mu)

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
    qa, w = holding_inputs(braced, q, holding, wrench, "capacity ramp")
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
    mu = common_friction(braced, holding)
    pred = predicted_limits(braced, qa, holding, w)
    predicted, brace = pred.margin, pred.brace
    if not predicted > 0.0:
        raise MujocoValidationError(
            f"bracekit's statics say brace {brace} fails without load under the wrench {show(w)} (scale {predicted:g})"
        )
    unbreakable = not np.isfinite(predicted)
    mode: Outcome = pred.mode or "held"

    static_scale: float | None = None
    static_message: str | None = None
    if static and unbreakable:
        static_message = _static_holds(braced, qa, holding, w, float(hold_scale))
    elif static:
        try:
            static_scale = static_capacity_scale(braced, qa, holding, w, mode, predicted, brace)
        except StaticSolveError as exc:
            static_message = str(exc)

    count = len(braced.braces)
    sim = _holding_session(braced, qa, holding, pred.responses.q_s[0], timestep, impratio)
    with captured_warnings(sim.messages):
        settle_unloaded(sim, holding, count)
        target, stop = (float(hold_scale),) * 2 if unbreakable else (float(predicted), 2.0 * float(predicted))
        normals = pred.responses.normals
        ramp = _ramp(sim, w, target, stop, float(ramp_time), mu, normals, float(cone_tol), float(slide_tol))
    s_mj, outcome, mj_brace, slide, creep, rate, stop, steps = ramp
    if unbreakable and outcome is None:
        outcome = "held"  # ramped to hold_scale × w without an event

    def rel(x: float | None) -> float | None:
        return None if x is None or s_mj is None else abs(x - s_mj) / s_mj

    slip = pred.slip
    return CapacityRamp(
        q=qa.copy(),
        wrench=w.copy(),
        preloads=holding.brace_preloads(count),
        friction=mu,
        gravity=bool(holding.gravity),
        mode=mode,
        brace=brace,
        liftoff_margin=float(np.min(pred.liftoff)),
        slip_margin=None if slip is None else float(np.min(slip)),
        predicted_scale=float(predicted),
        static_scale=static_scale,
        static_message=static_message,
        mujoco_scale=s_mj,
        mujoco_outcome=outcome,
        mujoco_brace=mj_brace,
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
    """Whether the nonlinear rigid statics (sticking load contacts) still hold every brace at ``scale`` × w."""
    frictions = holding.brace_frictions(len(braced.braces))
    try:
        forces = _load_statics(braced, q, holding, scale * w)
    except StaticSolveError as exc:
        return f"nonlinear statics at {scale:g} x w: {exc}"
    held = []
    for i, (f, brace, mu) in enumerate(zip(forces, braced.braces, frictions, strict=True)):
        nhat = brace.surface.normal
        fn = float(f @ nhat)
        ft = float(np.linalg.norm(f - fn * nhat))
        name = f"brace {i} "
        if fn <= 0.0:
            return f"nonlinear statics lift off {name}below {scale:g} x w (normal force {fn:.3g} N there)"
        if mu and ft > mu * fn:
            return f"nonlinear statics slip {name}below {scale:g} x w (|f_t| / f_n = {ft / fn:.3g} > mu there)"
        held.append(f"brace {i}: f_n = {fn:.4g} N, |f_t| = {ft:.3g} N")
    return f"nonlinear statics hold at {scale:g} x w ({'; '.join(held)})"


def _ramp(
    sim: MujocoSession,
    w: Array,
    target: float,
    stop: float,
    ramp_time: float,
    mu: float | None,
    normals: Array,
    cone_tol: float,
    slide_tol: float,
) -> tuple[float | None, Outcome | None, int | None, float | None, float, float, float, int]:
    """The load ramp of :func:`mujoco_capacity_ramp`: (scale, outcome, brace, slide scale, creep, rate, stop, steps).

    s grows at the rate that reaches ``target`` after ``ramp_time`` τ and the ramp ends past ``stop``. Every
    brace (its normal n̂_i a row of ``normals``) is watched; the first to lift off or slip is named.
    """
    m, d = sim.m, sim.d
    dt = float(m.opt.timestep)
    rate = target / (ramp_time * sim.tau)
    count = normals.shape[0]
    b0 = [sim.b_point(i) for i in range(count)]
    scale: float | None = None
    outcome: Outcome | None = None
    brace: int | None = None
    slide: float | None = None
    creep = 0.0
    steps = 0
    last_ratio = np.zeros(count)  # ‖f_t‖/f_n of each brace in the last chunk in contact
    while True:
        s = rate * steps * dt
        if s > stop:
            break
        d.qfrc_applied[:] = 0.0
        mujoco.mj_kinematics(m, d)
        mujoco.mj_applyFT(m, d, s * w[:3], s * w[3:], d.site_xpos[sim.site].copy(), sim.tip_body, d.qfrc_applied)
        mujoco.mj_step(m, d, CHUNK)
        steps += CHUNK
        sim.check(f"the load ramp (scale {s:.3g})")
        s_now = rate * steps * dt
        events = [_watch(sim, i, normals[i], b0[i], mu, last_ratio) for i in range(count)]
        if outcome is None:
            creep = max(disp for disp, _, _ in events)
        lost = [i for i, (_, open_, _) in enumerate(events) if open_]
        if lost:
            if outcome is None:
                # a contact lost at the edge of its cone slid off within one chunk: that is a slip
                i = lost[0]
                sliding = mu is not None and last_ratio[i] >= (1.0 - _EDGE_TOL) * mu
                scale, outcome, brace = s_now, "slipped" if sliding else "lifted_off", i
            break
        if mu is None:
            continue
        for i, (disp, _, ratio) in enumerate(events):
            last_ratio[i] = ratio
            if outcome is None and (ratio >= (1.0 - cone_tol) * mu or disp > slide_tol):
                scale, outcome, brace = s_now, "slipped", i
        if max(disp for disp, _, _ in events) > slide_tol:
            slide = s_now
            break
    return scale, outcome, brace, slide, creep, rate, stop, steps


def _watch(
    sim: MujocoSession, i: int, nhat: Array, b0: Array, mu: float | None, last_ratio: Array
) -> tuple[float, bool, float]:
    """Brace i now: tangential displacement of b_i (m), whether its contact is open, ‖f_t‖/f_n (or the last)."""
    f, ncon = sim.contact_force(i)
    fn = float(f @ nhat)
    db = sim.b_point(i) - b0
    disp = float(np.linalg.norm(db - (db @ nhat) * nhat))
    if ncon == 0 or fn <= 0.0:
        return disp, True, float(last_ratio[i])
    return disp, False, float(np.linalg.norm(f - fn * nhat)) / fn if mu is not None else 0.0
