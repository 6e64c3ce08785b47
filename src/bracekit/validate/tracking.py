"""Tracking check in MuJoCo: does each strategy's path make the tool as stiff as bracekit predicts?

The robot is the spring-jointed chain of :func:`~bracekit.validate.mujoco_check.build_mujoco_model` (the URDF's
masses and inertias, joint springs K and dampers D = τK) whose spring set points q_s(t) follow a strategy's run:

    q_s = q + K⁻¹ τ0,   τ0 = g(q) − J_bᵀ [P n̂; 0]   (braced; bracekit.statics.contact_response),
    q_s = q + K⁻¹ g(q)                               (free space; g = 0 without gravity),

so that gravity and the brace's preload P are held at the commanded q as bracekit's statics say. The set points
follow a clamped cubic spline through the run's samples, at the run's own speed (``time_scale`` 1), updated every
step; the dampers act on q̇ − q̇_s (D q̇_s is applied as a joint force, as an impedance servo does), so the robot
lags the path only through its inertia. The brace is a 0.1 mm sphere at b on the surface plane; while the set
points move it slides frictionless with a softer contact (or, with ``path_friction``, is dragged with μ).

At ``points`` samples of each run (evenly spaced in time) the set points stop, and a small dead tool force ±f β_x
(β_x = ``scenario.beta_x(t)``, unit; for a translational β_x a force along it) is ramped in over 2τ from the same
unloaded state. The compliance along β_x,

    c = β_xᵀ (Δx₊ − Δx₋) / (2f),   Δx = [Δp; Δθ] of the tip site (m, rad), at the same set points,

is compared with the first-order prediction β_xᵀ C β_x (gravity sag and the path's lag cancel in the difference;
the central difference removes the dead load's own first-order geometric term). C_i = ‖β_xᵀ C‖ is the largest
deflection along β_x per unit wrench; β_xᵀ C β_x (≤ C_i) is the deflection along β_x per unit force along β_x.
Each braced point is measured twice, at a 0.25 ms timestep with the stiff contact:

* frictionless: the pad relaxes frictionless (condim 1) and is measured that way, the paper's brace, against
  the ``constrained`` C_e (the model of the braced runs' C_i; the ``projection`` C_e is reported too);
* sticking: friction back on (condim 3, μ, elliptic cone), the pad sticks: against the constrained model of a
  sticking point (``point_with_friction``, three contact forces) on the preload's tangent stiffness
  (:func:`~bracekit.compliance.preloaded.preloaded_compliance`).

Free-space runs have no contact (the sphere does not collide) and are compared with J K⁻¹ Jᵀ. The report
says, per strategy, the mean measured and predicted compliance along β_x and whether the paper's ranking
(free space > braced minimum norm > braced gradient projection) holds in MuJoCo.
"""

from __future__ import annotations

import dataclasses
import os
import time

import mujoco
import numpy as np
from numpy.typing import NDArray
from scipy.interpolate import CubicSpline

from bracekit._linalg import as_number, show
from bracekit.compliance.first_order import ComplianceModel, end_effector_compliance, free_space_compliance
from bracekit.compliance.preloaded import loaded_free_space_compliance, simulated_model
from bracekit.errors import ContactError, InputError
from bracekit.kinematics import BracedRobot
from bracekit.simulation.run import RunResult, run_scenario
from bracekit.simulation.scenario_model import Scenario
from bracekit.simulation.simulate import Trajectory
from bracekit.statics import contact_response, contact_responses, gravity_torque
from bracekit.validate.compliance_check import first_order_state
from bracekit.validate.contacts import plane_contacts
from bracekit.validate.mjcf import build_mujoco_model
from bracekit.validate.preloaded_check import preloaded_tip_compliance
from bracekit.validate.session import captured_warnings
from bracekit.validate.tracking_report import (
    PAPER_RANKING,
    TRACKING_TOL,
    TrackingPoint,
    TrackingReport,
    TrackingStrategy,
)
from bracekit.validate.tracking_session import _MEASURE_TIMESTEP, _PathContact, _Sim

__all__ = [
    "DEFAULT_FORCE",
    "DEFAULT_FRICTION",
    "DEFAULT_PRELOAD",
    "PAPER_RANKING",
    "TRACKING_TOL",
    "TrackingPoint",
    "TrackingReport",
    "TrackingStrategy",
    "run_tracking_validation",
]

Array = NDArray[np.float64]

#: Tool force along β_x, N.
DEFAULT_FORCE = 1.0
#: Preload of the brace when the scenario gives none, N (keeps the contact closed under the tool force).
DEFAULT_PRELOAD = 5.0
#: Coulomb μ of the pad when the scenario gives none.
DEFAULT_FRICTION = 0.8
_SPHERE_RADIUS = 1e-4  # m
_IMPRATIO = 10.0  # frictional-to-normal impedance ratio: less creep of a sticking contact
_SLIP_TOL = 1e-5  # m: tangential motion of the material point b that counts as a slip


def _set_points(sc: Scenario, tr: Trajectory, preload: float, gravity: bool) -> Array:
    """q_s (N×n) along the run: the preload (braced) and gravity held at the run's q (module docstring)."""
    if tr.braced:
        try:
            return contact_responses(sc.braced, tr.q, preload=preload, gravity=gravity, geometric=False).q_s
        except ContactError:  # the one-brace statics refuse several braces
            return contact_responses(sc.braced, tr.q, preload=preload, gravity=gravity, geometric=False).q_s
    k = sc.robot.stiffness
    if not gravity:
        return tr.q.copy()
    return np.array([q + gravity_torque(sc.robot, q) / k for q in tr.q])


def _check_indices(n_samples: int, points: int) -> list[int]:
    return sorted({round(float(x)) for x in np.linspace(0, n_samples - 1, points)})


def _track_run(
    sc: Scenario,
    tr: Trajectory,
    model: ComplianceModel,
    *,
    points: int,
    force: float,
    preload: float,
    friction: float,
    gravity: bool,
    timestep: float,
    time_scale: float,
    path_friction: bool,
) -> TrackingStrategy:
    """Follow one run in MuJoCo and measure at its check points."""
    start = time.perf_counter()
    braced, robot = sc.braced, sc.robot
    sticking = BracedRobot(robot, [dataclasses.replace(b, contact="point_with_friction") for b in braced.braces])
    q_s = _set_points(sc, tr, preload, gravity)
    xml = build_mujoco_model(
        robot.model,
        tr.q[0],
        robot.stiffness,
        robot.tip_id,
        plane_contacts(braced, environment=False),
        sphere_radius=_SPHERE_RADIUS,
        gravity=True,  # the URDF's inertias; _Sim switches gravity off unless asked
        timestep=timestep,
        friction=friction,
        cone="elliptic",
        impratio=_IMPRATIO,
        set_points=q_s[0],
    )
    sim = _Sim(xml, braced, tr.q[0], tr.braced, gravity)
    stats = _PathContact() if tr.braced else None
    path_condim = sim.condim if path_friction else 1
    t = np.asarray(tr.t, dtype=float)
    if t.size > 1:
        path = CubicSpline(t, q_s, axis=0, bc_type="clamped")  # starts and ends at rest
        rate = path.derivative()
    out: list[TrackingPoint] = []
    with captured_warnings(sim.messages):
        sim.contact_mode(path_condim)
        sim.settle(q_s[0], np.zeros(6), "settling at the start")
        checks = set(_check_indices(t.size, points))
        saved = mujoco.MjData(sim.m)
        for i in range(t.size):
            if i > 0:
                sim.contact_mode(path_condim, moving=True)
                sim.follow(path, rate, float(t[i - 1]), float(t[i]), time_scale, stats)
            if i in checks:
                sim.contact_mode(path_condim)
                mujoco.mj_copyData(saved, sim.m, sim.d)
                fn_path = None
                if stats is not None:
                    fn_path = stats.segment_sum / stats.segment_steps if stats.segment_steps else preload
                out.append(
                    _check_point(sim, sc, tr, model, sticking, i, q_s[i], force, preload, friction, gravity, fn_path)
                )
                mujoco.mj_copyData(sim.d, sim.m, saved)
    path_json = None
    if stats is not None and stats.steps:
        path_json = {
            "steps": stats.steps,
            "open_fraction": stats.open_steps / stats.steps,
            "normal_force_mean_N": stats.force_sum / stats.steps,
            "normal_force_max_N": stats.force_max,
            "friction": path_friction,
        }
    return TrackingStrategy(tr.strategy, tr.braced, out, time.perf_counter() - start, path_json)


def _check_point(
    sim: _Sim,
    sc: Scenario,
    tr: Trajectory,
    model: ComplianceModel,
    sticking: BracedRobot,
    i: int,
    q_s: Array,
    force: float,
    preload: float,
    friction: float,
    gravity: bool,
    fn_path: float | None,
) -> TrackingPoint:
    """Measure the compliance along β_x at sample i (the set points stop at q_s) and predict it."""
    braced = sc.braced
    q = tr.q[i]
    t = float(tr.t[i])
    beta = np.asarray(sc.beta_x(t), dtype=float)
    beta = beta / np.linalg.norm(beta)
    w = force * beta
    st = first_order_state(braced, q)
    mujoco.mj_forward(sim.m, sim.d)
    tracking = float(np.linalg.norm(sim.d.site_xpos[sim.site] - st.e))
    joint = float(np.max(np.abs(sim.d.qpos - q)))
    ci_series = tr.measures.get(tr.ci_key(model))
    ci = None if ci_series is None else float(ci_series[i])
    what = f"{tr.strategy} at t = {t:g} s"
    if not tr.braced:
        measured, _, _, _ = sim.measure(q_s, w, beta, what)
        pred = float(beta @ free_space_compliance(st) @ beta)
        # the unbraced robot's loaded compliance does not depend on the braces: any one brace's view serves
        one = BracedRobot(braced.robot, braced.braces[0])
        tangent = float(beta @ loaded_free_space_compliance(one, q, gravity=gravity) @ beta)
        return TrackingPoint(
            i, t, q.copy(), beta, tracking, joint, None, measured, pred, None, tangent,
            None, None, ci, abs(measured - pred) / pred, None, False, None, False, None,
        )  # fmt: skip
    sim.contact_mode(1)  # the pad relaxes frictionless and is measured that way
    sim.settle(q_s, np.zeros(6), f"frictionless relaxing ({what})")
    relaxed = mujoco.MjData(sim.m)
    mujoco.mj_copyData(relaxed, sim.m, sim.d)
    measured, _, opened, _ = sim.measure(q_s, w, beta, f"frictionless pad, {what}")
    mujoco.mj_copyData(sim.d, sim.m, relaxed)
    sim.contact_mode(sim.condim)  # friction on: the pad sticks
    measured_st, slip, opened_st, settled = sim.measure(q_s, w, beta, f"sticking pad, {what}", strict=False)
    pred = float(beta @ end_effector_compliance(st, "constrained") @ beta)
    try:
        proj: float | None = float(beta @ end_effector_compliance(st, "projection") @ beta)
    except ContactError:  # the paper's projection model is defined for one brace
        proj = None
    tangent = float(beta @ preloaded_tip_compliance(braced, q, preload, gravity) @ beta)
    pred_st = float(beta @ preloaded_tip_compliance(sticking, q, preload, gravity) @ beta)
    predicted_slip = any(
        bool(np.any((f_n <= 0.0) | (f_t > friction * f_n)))
        for f_n, f_t in _predicted_contact_forces(braced, q, w, preload, gravity, friction)
    )
    return TrackingPoint(
        index=i,
        t=t,
        q=q.copy(),
        beta_x=beta,
        tracking_error=tracking,
        joint_error=joint,
        normal_force=fn_path,
        measured=measured,
        predicted=pred,
        predicted_projection=proj,
        predicted_tangent=tangent,
        measured_sticking=measured_st,
        predicted_sticking=pred_st,
        ci=ci,
        rel_err=abs(measured - pred) / pred,
        rel_err_sticking=abs(measured_st - pred_st) / pred_st,
        contact_opened=bool(opened),
        slip=slip,
        slipped=bool(slip > _SLIP_TOL or opened_st or not settled),
        predicted_slip=predicted_slip,
    )


def _predicted_contact_forces(
    braced: BracedRobot, q: Array, w: Array, preload: float, gravity: bool, friction: float
) -> list[tuple[Array, Array]]:
    """(f_n, ‖f_t‖) under ±w of every brace, first order (the one-brace statics, or the several-brace ones)."""
    loads = np.stack([w, -w])
    try:
        resp = contact_response(braced, q, preload=preload, gravity=gravity, friction=friction)
        per_brace = [resp.contact_wrench(loads)[:, :3]]
    except ContactError:
        multi = contact_responses(braced, q, preload=preload, gravity=gravity, friction=friction)
        per_brace = [(multi.f_c0[0, i] + loads @ multi.contact_gain[0, i].T)[:, :3] for i in range(len(braced.braces))]
    out = []
    for f_c, brace in zip(per_brace, braced.braces, strict=True):
        nh = brace.surface.normal
        f_n = f_c @ nh
        out.append((f_n, np.linalg.norm(f_c - f_n[:, None] * nh, axis=1)))
    return out


def run_tracking_validation(
    result_or_scenario: RunResult | Scenario | str | os.PathLike[str],
    points: int = 5,
    force: float = DEFAULT_FORCE,
    *,
    preload: float | None = None,
    friction: float | None = None,
    gravity: bool | None = None,
    timestep: float = 1e-3,
    time_scale: float = 1.0,
    path_friction: bool = False,
    strategies: list[str] | None = None,
) -> TrackingReport:
    """Follow each strategy's run in MuJoCo and compare its compliance along β_x with bracekit's (module docstring).

    Args:
        result_or_scenario: a :class:`RunResult` (its chosen compliance model's runs), or a Scenario, TOML path
            or shipped name, which is run first (``run_scenario(..., both_models=False)``).
        points: check points per run, evenly spaced in time (the first and last sample included), ≥ 1.
        force: the tool force f along β_x, N (> 0; small: the first-order error grows ∝ f).
        preload: brace preload P, N; default the scenario's, or DEFAULT_PRELOAD when it has none.
        friction: Coulomb μ of the pad (> 0); default the scenario's, or DEFAULT_FRICTION.
        gravity: default the scenario's ``[robot] gravity``.
        timestep: MuJoCo timestep, s (≤ 1 ms: the contact's time constant is 2 ms).
        time_scale: simulated time per unit of the run's time (1: the run's own speed; > 1 slower).
        path_friction: drag the pad with friction μ while the set points move (default: frictionless while
            moving, friction on at the check points; a dragged pad hops in MuJoCo, docs/validation.md).
        strategies: the runs to check (default all of the chosen model).

    Returns:
        :class:`TrackingReport`.

    Raises:
        InputError: bad arguments, or a brace MuJoCo's sphere does not model (not a frictionless point on a
            rigid surface).
        MujocoValidationError: the simulation goes unstable or does not settle.
    """
    start = time.perf_counter()
    if isinstance(result_or_scenario, RunResult):
        result = result_or_scenario
    elif isinstance(result_or_scenario, Scenario | str | os.PathLike):
        result = run_scenario(result_or_scenario, both_models=False)
    else:
        raise InputError(
            "run_tracking_validation needs a RunResult, a Scenario, a .toml path or a shipped name, "
            f"got {show(result_or_scenario)}"
        )
    sc = result.scenario
    if not isinstance(points, int) or isinstance(points, bool) or points < 1:
        raise InputError(f"points must be a whole number >= 1, got {show(points)}")
    f = as_number(force, "the tool force f", positive=True, unit="N")
    h = sc.holding
    p = as_number(
        (h.preload if h.preload > 0.0 else DEFAULT_PRELOAD) if preload is None else preload,
        "the brace preload P",
        positive=True,
        unit="N",
    )
    mu = as_number((h.friction or DEFAULT_FRICTION) if friction is None else friction, "the friction μ", positive=True)
    g = h.gravity if gravity is None else gravity
    if not isinstance(g, bool):
        raise InputError(f"gravity must be True or False, got {show(g)}")
    dt = as_number(timestep, "the timestep", positive=True, unit="s")
    if dt > 1e-3:
        raise InputError(f"timestep must be at most 1 ms (the contact's time constant is 2 ms), got {dt:g} s")
    scale = as_number(time_scale, "the time scale", positive=True)
    if not isinstance(path_friction, bool):
        raise InputError(f"path_friction must be True or False, got {show(path_friction)}")
    for brace in plane_contacts(sc.braced):  # contact types MuJoCo models, on rigid surfaces
        if brace.k_env is not None:
            raise InputError("the MuJoCo tracking check models rigid surfaces; a brace has an environment stiffness")
    runs = result.trajectories[result.compliance_model]
    names = list(runs) if strategies is None else list(strategies)
    unknown = [n for n in names if n not in runs]
    if unknown:
        raise InputError(f"no run named {', '.join(unknown)}; the runs are {', '.join(runs)}")
    report = TrackingReport(
        scenario=sc.name,
        compliance_model=result.compliance_model,
        settings={
            "points": points,
            "force_N": f,
            "preload_N": p,
            "friction": mu,
            "gravity": g,
            "timestep_s": dt,
            "time_scale": scale,
            "path_friction": path_friction,
            "contact": "sphere (radius 0.1 mm) on the plane, condim 3 with mu (elliptic cone, impratio 10); "
            "measured with condim 1 (frictionless) and condim 3 (sticking)",
            "set_points": "q_s = q + K^-1 (g(q) - J_b^T [P n; 0]) along the run, dampers referenced to dq_s/dt",
            "load": "dead tool force +-f*beta_x ramped in over 2 tau, settled until max|qdot|*tau < 1e-8 rad; "
            "compliance from the difference of the two loaded states",
            "measure_timestep_s": _MEASURE_TIMESTEP,
        },
    )
    for name in names:
        tr = runs[name]
        if not tr.q.shape[0]:
            continue
        report.strategies[name] = _track_run(
            sc, tr, simulated_model(result.compliance_model),
            points=points, force=f, preload=p, friction=mu, gravity=g, timestep=dt, time_scale=scale,
            path_friction=path_friction,
        )  # fmt: skip
    object.__setattr__(report, "wall_time", time.perf_counter() - start)
    return report
