"""The closed loop in MuJoCo: a worker guides the braced robot through the admittance law, the work loads the tool.

The robot is :func:`~bracekit.validate.mjcf.build_mujoco_model`'s chain with the URDF's inertias and gravity:
each joint a position servo of the model's stiffness K (MuJoCo's joint spring at the set point q_s) and damping
D = τK on q̇ − q̇_s (τ the scenario's ``damping_time``; D q̇_s is applied as a joint force), the brace a
0.1 mm sphere on the surface plane. Every control tick (1 ms, ``physics_dt`` MuJoCo steps):

1. the tool position e and velocity ė are read from MuJoCo, the worker's force F_h at the handle from the hand
   model (:mod:`bracekit.cobot.worker`), an ideal force sensor;
2. the admittance (:class:`~bracekit.control.Admittance`) turns F_h into a tool twist ẋ_a; the tool reference
   x_c integrates it, and ẋ = ẋ_a + k_f (x_c − e(q_c)) (position; the orientation held);
3. :class:`~bracekit.control.ControlStep` resolves ẋ by the strategy at the commanded q_c, keeping every brace:
   q_c ← q_c + q̇ dt, and the set points q_s hold gravity and press each brace with P.

While guided the pad glides on the surface frictionless (a skid); during a dwell the worker lets go, the command
is held, the pad is clamped (friction μ, elliptic cone) and the process wrench w is applied at the tool. The tool's
deflection is the tool's motion from its position just before the work to its mean over the second half of the
hold; its first-order prediction is C w with the preloaded compliance of a sticking pad at q_c (gravity and the
preload's geometric stiffness; :func:`~bracekit.validate.preloaded_check.preloaded_tip_compliance`), or of the
unbraced robot in free space (:func:`~bracekit.compliance.preloaded.loaded_free_space_compliance`).
"""

from __future__ import annotations

import dataclasses
import time
from typing import NamedTuple

import mujoco
import numpy as np
import pinocchio as pin
from numpy.typing import NDArray

from bracekit.cobot.config import CobotScenario
from bracekit.cobot.worker import Worker
from bracekit.compliance.preloaded import loaded_free_space_compliance
from bracekit.control import Admittance, ControlStep
from bracekit.kinematics import BracedRobot
from bracekit.validate.contacts import plane_contacts
from bracekit.validate.mjcf import build_mujoco_model
from bracekit.validate.preloaded_check import preloaded_tip_compliance
from bracekit.validate.session import MujocoSession, captured_warnings

Array = NDArray[np.float64]

__all__ = ["LIFT_TOL", "CobotRun", "Dwell", "run_strategy"]

_SPHERE_RADIUS = 1e-4  # m
_IMPRATIO = 10.0  # frictional-to-normal impedance ratio: less creep of the clamped pad
_SETTLE = 0.3  # s at the start before the worker grips
#: The height (m) of a material point b_i above its surface that counts as a lift-off (with a tick whose mean
#: normal force is ≤ 0): the contact's own MuJoCo steps flicker on and off at sub-micrometre separations.
LIFT_TOL = 1e-5
# the pad's contact while it glides (the validation's path contact: the stiff one drops out for single steps while
# b slides); the model's stiff contact while clamped for the work
_GLIDE_SOLREF = np.array([0.01, 1.0])
_GLIDE_SOLIMP = np.array([0.99, 0.99, 0.001, 0.5, 2.0])
_STIFFEN = 0.1  # s: the clamped contact's settings are blended in from the glide's (no bounce at the switch)


class Dwell(NamedTuple):
    """The work at one target: measured and predicted deflection (3,) m, relative error, slips (m), path error (m).

    ``clamp_slip``: the pad's slip while the clamp engaged (before the work); ``slip``: under the work.
    """

    target: int
    t_on: float
    deflection: Array
    predicted: Array
    max_deflection: float
    rel_err: float
    slip: float
    path_error: float
    clamp_slip: float


@dataclasses.dataclass
class CobotRun:
    """One strategy's closed loop: time series per tick and the dwells' measurements.

    Series (T rows): ``t`` (s); ``force`` worker force (T×3, N); ``e`` tool (T×3, m); ``e_cmd`` commanded tool
    (T×3, m); ``process`` process scale (T,); ``normal`` least brace normal force (T, N); ``tangential`` its
    tangential force (T, N); ``torque`` servo torques (T×n, N·m); ``dwell`` whether in a dwell (T, bool);
    ``tick_us`` control-step cost (T, µs).
    """

    strategy: str
    braced: bool
    t: Array
    force: Array
    e: Array
    e_cmd: Array
    process: Array
    normal: Array
    tangential: Array
    torque: Array
    dwell: NDArray[np.bool_]
    tick_us: Array
    dwells: list[Dwell]
    effort: Array
    damping_time: float
    contact_lost: str | None
    open_ticks: int
    qpos: Array


def _prediction(sc: CobotScenario, strategy_braced: bool, q: Array, preload: float) -> Array:
    """The first-order tool compliance (6×6) at q with the preload P (N) (module docstring)."""
    braced = sc.base.braced
    if not strategy_braced:
        return loaded_free_space_compliance(BracedRobot(braced.robot, braced.braces[0]), q, gravity=sc.gravity)
    sticking = BracedRobot(braced.robot, [dataclasses.replace(b, contact="point_with_friction") for b in braced.braces])
    return preloaded_tip_compliance(sticking, q, preload, sc.gravity)


def run_strategy(sc: CobotScenario, name: str, q0: Array) -> CobotRun:
    """Run the closed loop of strategy ``name`` from q0 (the braced start) over the scenario; deterministic."""
    braced = sc.base.braced
    strategy = sc.base.strategy(name)
    robot = braced.robot
    dt = sc.dt
    sub = round(dt / sc.physics_dt)
    step = ControlStep(braced, strategy, dt, beta_x=sc.base.beta_x(0.0), preloads=sc.preload, gravity=sc.gravity)
    axes = np.array([True] * 3 + [sc.base.task_space.is_pose] * 3)
    law = Admittance(sc.mass, sc.admittance_damping, dt, deadband=sc.deadband, axes=axes)
    first = step(q0, np.zeros(6))
    q_c, q_s = q0.copy(), first.set_point - (first.q_next - q0)
    xml = build_mujoco_model(
        robot.model, q0, robot.stiffness, robot.tip_id, plane_contacts(braced, environment=False),
        sphere_radius=_SPHERE_RADIUS, gravity=True, damping_time=sc.damping_time, timestep=sc.physics_dt,
        friction=sc.friction, cone="elliptic", impratio=_IMPRATIO, set_points=q_s,
    )  # fmt: skip
    sim = MujocoSession(xml, robot.stiffness, q0, list(braced.state(q0).b_i), gravity=sc.gravity)
    m, d = sim.m, sim.d
    geoms = [g for p in sim.pairs for g in (p.sphere, p.plane)]
    spheres = [p.sphere for p in sim.pairs]
    condim = int(m.geom_condim[spheres[0]])
    solref, solimp = m.geom_solref[spheres[0]].copy(), m.geom_solimp[spheres[0]].copy()
    if not strategy.braced:
        m.geom_contype[spheres] = 0
        m.geom_conaffinity[spheres] = 0
    _glide(m, geoms, True, solref, solimp, condim)
    damping = np.asarray(m.dof_damping, dtype=float).copy()
    k = np.asarray(robot.stiffness, dtype=float)
    normals = [b.surface.normal for b in braced.braces]
    planes = [b.surface.point for b in braced.braces]
    worker = Worker(sc, first.e)
    w_proc = sc.process.wrench
    steps = round((_SETTLE + sc.duration) / dt)
    rows = {key: np.zeros((steps, width)) for key, width in (("force", 3), ("e", 3), ("e_cmd", 3), ("torque", robot.n))}
    t_arr = np.arange(steps, dtype=np.float64) * dt
    proc, normal, tangential = np.zeros(steps), np.zeros(steps), np.zeros(steps)
    in_dwell, tick_us = np.zeros(steps, dtype=bool), np.zeros(steps)
    qpos = np.zeros((steps // 20 + 1, robot.n))
    x_c, r_c = first.e.copy(), first.R_e.copy()
    e_prev = sim.tip()[0]
    qdot_c = np.zeros(robot.n)
    clamped, previous = False, "settle"
    anchor_b: list[Array] = []
    slips: dict[int, list[float]] = {}  # per work start: [slip while clamping, slip under the work]
    lost: str | None = None
    dwell_marks: list[tuple[int, float, int]] = []  # (target, t_on, tick of the work's start)
    q_work: list[Array] = []
    f_work: list[float] = []
    work = -1
    open_ticks = 0
    with captured_warnings(sim.messages):
        for i in range(steps):
            t = i * dt
            e, _ = sim.tip()
            edot = (e - e_prev) / dt
            e_prev = e
            if t < _SETTLE:
                ph, force = None, np.zeros(3)
            else:
                ph = worker.phase(t - _SETTLE)
                if ph.name == "travel" and previous == "dwell":
                    worker.regrip(e)
                force = worker.force(ph, e, edot, dt)
            name_now = "settle" if ph is None else ph.name
            a = 0.0 if ph is None else worker.process(ph)
            if name_now == "dwell":
                qdot_c[:] = 0.0
                law.reset()
                if ph is not None and ph.since < _STIFFEN:  # the contact stiffens from the glide's over _STIFFEN
                    _stiffen(m, geoms, ph.since / _STIFFEN, solref, solimp)
                if not clamped:  # the pad is clamped for the work, the command held
                    m.geom_condim[geoms] = condim
                    clamped = True
                    anchor_b = [sim.b_point(j) for j in range(len(sim.pairs))]
                    assert ph is not None
                    work = i + round(sc.process.start / dt)
                    dwell_marks.append((ph.target, t, work))
                if i == work:  # the pad's slip under the work is measured from here
                    anchor_b = [sim.b_point(j) for j in range(len(sim.pairs))]
                if i == work:  # the linearisation point: MuJoCo's configuration and normal force before the load
                    q_work.append(d.qpos.copy())
                    f_work.append(float(np.mean(normal[i - round(0.1 / dt) : i])) if strategy.braced else 0.0)
            else:
                if clamped:
                    _glide(m, geoms, True, solref, solimp, condim)
                    clamped = False
                    x_c = braced.state(q_c).e.copy()  # the reference restarts at the command
                xd = law(np.concatenate([force, np.zeros(3)])).xdot if ph is not None else np.zeros(6)
                x_c = x_c + xd[:3] * dt
                clock = time.perf_counter()
                out = step(q_c, _twist(xd, x_c, r_c, q_c, step, sc.feedback))
                tick_us[i] = 1e6 * (time.perf_counter() - clock)
                qdot_c = out.qdot
                q_c, q_s = out.q_next, out.set_point
            previous = name_now
            m.qpos_spring[:] = q_s
            d.qfrc_applied[:] = damping * qdot_c
            load = np.concatenate([force, np.zeros(3)]) + a * w_proc
            if np.any(load):
                mujoco.mj_kinematics(m, d)
                mujoco.mj_applyFT(m, d, load[:3], load[3:], d.site_xpos[sim.site].copy(), sim.tip_body, d.qfrc_applied)
            forces = np.zeros((len(normals), 3))
            for _ in range(sub):  # the brace's force averaged over the tick's MuJoCo steps
                mujoco.mj_step(m, d)
                if strategy.braced:
                    for j in range(len(normals)):
                        forces[j] += sim.contact_force(j)[0] / sub
            sim.check(f"{name} at t = {t:.3f} s")
            rows["force"][i], rows["e"][i], rows["e_cmd"][i] = force, e, x_c
            rows["torque"][i] = k * (q_s - d.qpos) + damping * (qdot_c - d.qvel)
            proc[i], in_dwell[i] = a, name_now == "dwell"
            if i % 20 == 0:
                qpos[i // 20] = d.qpos
            if strategy.braced:
                fn, ft, gap = np.inf, 0.0, -np.inf
                for j, (nh, f) in enumerate(zip(normals, forces, strict=True)):
                    f_n = float(f @ nh)
                    if f_n < fn:
                        fn, ft = f_n, float(np.linalg.norm(f - f_n * nh))
                    gap = max(gap, float((sim.b_point(j) - planes[j]) @ nh))
                    if clamped:
                        db = sim.b_point(j) - anchor_b[j]
                        entry = slips.setdefault(work, [0.0, 0.0])
                        entry[int(i >= work)] = max(entry[int(i >= work)], float(np.linalg.norm(db - (db @ nh) * nh)))
                normal[i], tangential[i] = fn, ft
                if (fn <= 0.0 or gap > LIFT_TOL) and t >= _SETTLE:
                    open_ticks += 1
                    if lost is None:
                        lost = f"the brace lifted off at t = {t:.3f} s ({name_now})"
    marks = [(tg, ton, st, q, f) for (tg, ton, st), q, f in zip(dwell_marks, q_work, f_work, strict=False)]
    dwells = _dwells(sc, strategy.braced, marks, t_arr, rows["e"], slips)
    effort = np.asarray(robot.model.effortLimit, dtype=float)
    return CobotRun(
        name, strategy.braced, t_arr, rows["force"], rows["e"], rows["e_cmd"], proc, normal, tangential,
        rows["torque"], in_dwell, tick_us, dwells, effort, sim.tau, lost, open_ticks, qpos,
    )  # fmt: skip


def _glide(m: mujoco.MjModel, geoms: list[int], gliding: bool, solref: Array, solimp: Array, condim: int) -> None:
    """The pad gliding (frictionless, the softer path contact) or clamped (friction μ, the stiff contact)."""
    m.geom_condim[geoms] = 1 if gliding else condim
    m.geom_solref[geoms] = _GLIDE_SOLREF if gliding else solref
    m.geom_solimp[geoms] = _GLIDE_SOLIMP if gliding else solimp


def _stiffen(m: mujoco.MjModel, geoms: list[int], x: float, solref: Array, solimp: Array) -> None:
    """The contact's settings a fraction x ∈ [0, 1] of the way from the glide's to the clamped (stiff) ones."""
    m.geom_solref[geoms] = _GLIDE_SOLREF * (solref / _GLIDE_SOLREF) ** x  # time constant: geometric blend
    m.geom_solimp[geoms] = (1.0 - x) * _GLIDE_SOLIMP + x * solimp


def _twist(xd: Array, x_c: Array, r_c: Array, q_c: Array, step: ControlStep, gain: float) -> Array:
    """ẋ_a plus the feedback of the tool reference (position) and the held orientation, at the command q_c."""
    st = step.braced.state(q_c)
    fb = np.concatenate([x_c - st.e, pin.log3(r_c @ st.R_e.T)])
    return xd + gain * fb


def _dwells(
    sc: CobotScenario,
    braced: bool,
    marks: list[tuple[int, float, int, Array, float]],
    t: Array,
    e: Array,
    slips: dict[int, list[float]],
) -> list[Dwell]:
    """Deflection under the process wrench at each dwell, against C w (module docstring)."""
    p = sc.process
    dt = sc.dt
    before = max(1, round(0.1 / dt))
    out = []
    for target, t_on, start, q, preload in marks:
        hold0 = start + round(p.ramp / dt)
        hold1 = hold0 + round(p.hold / dt)
        if hold1 > len(t):
            continue
        ref = e[start - before : start].mean(axis=0)
        loaded = e[(hold0 + hold1) // 2 : hold1].mean(axis=0)
        meas = loaded - ref
        pred = (_prediction(sc, braced, q, preload) @ p.wrench)[:3]
        peak = float(np.max(np.linalg.norm(e[start:hold1] - ref, axis=1)))
        err = float(np.linalg.norm(meas - pred)) / max(float(np.linalg.norm(pred)), 1e-300)
        path = float(np.linalg.norm(ref - sc.operator.targets[target]))
        clamp_slip, slip = slips.get(start, [0.0, 0.0])
        out.append(Dwell(target, float(t_on), meas, pred, peak, err, slip, path, clamp_slip))
    return out
