"""The MuJoCo session of the tracking check: the chain follows a run's set points, then is measured at rest.

:class:`_Sim` extends :class:`~bracekit.validate.session.MujocoSession` with the set points' motion (dampers on
q̇ − q̇_s), the contacts' two modes (a softer contact while the set points move, the stiff one to measure) and
the compliance along β_x from ±w (:meth:`_Sim.measure`). Every brace has its sphere and plane.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np
import pinocchio as pin
from numpy.typing import NDArray
from scipy.interpolate import CubicSpline

from bracekit.errors import MujocoValidationError
from bracekit.kinematics import BracedRobot
from bracekit.validate.session import MujocoSession

__all__: list[str] = []

Array = NDArray[np.float64]

_RAMP = 2.0  # ramp time of the tool force, in units of τ
_MIN_HOLD, _MAX_HOLD = 2.0, 20.0  # settling time, in units of τ
_SETTLE_TOL = 1e-8  # rad: remaining motion max|q̇|·τ
# timestep of the measurements: at 1 ms the stiff contact on the light links chatters and a sticking pad walks
_MEASURE_TIMESTEP = 2.5e-4
# contact settings while the set points move: the stiff measuring contact (solref 0.002) drops out for single
# steps while b slides (about 6 % of the steps on the paper run); these keep it closed
_PATH_SOLREF = np.array([0.01, 1.0])
_PATH_SOLIMP = np.array([0.99, 0.99, 0.001, 0.5, 2.0])


# --------------------------------------------------------------------------------------------------
# Simulation
# --------------------------------------------------------------------------------------------------
@dataclass
class _PathContact:
    """Contact statistics of the brace while the set points move (braced runs)."""

    steps: int = 0
    open_steps: int = 0
    force_sum: float = 0.0
    force_max: float = 0.0
    segment_sum: float = 0.0
    segment_steps: int = 0

    def add(self, fn: float, ncon: int) -> None:
        self.steps += 1
        self.segment_steps += 1
        self.segment_sum += fn
        self.open_steps += int(ncon == 0 or fn <= 0.0)
        self.force_sum += fn
        self.force_max = max(self.force_max, fn)


class _Sim(MujocoSession):
    """The MuJoCo session of one run: set points, the dampers' reference velocity and the contacts' two modes."""

    def __init__(self, xml: str, braced: BracedRobot, q0: Array, contact: bool, gravity: bool) -> None:
        b_points = list(braced.state(q0).b_i)
        super().__init__(xml, braced.robot.stiffness, q0, b_points, gravity=gravity)
        m = self.m
        self.dt = float(m.opt.timestep)
        self.damping = np.asarray(m.dof_damping, dtype=float).copy()
        self.spheres = [p.sphere for p in self.pairs]
        self.geoms = [g for p in self.pairs for g in (p.sphere, p.plane)]
        self.condim = int(m.geom_condim[self.spheres[0]])
        self.contact = contact
        self.solref = m.geom_solref[self.spheres[0]].copy()
        self.solimp = m.geom_solimp[self.spheres[0]].copy()
        if not contact:
            m.geom_contype[self.spheres] = 0
            m.geom_conaffinity[self.spheres] = 0
        self.normals = [b.surface.normal for b in braced.braces]

    def contact_mode(self, condim: int, moving: bool = False) -> None:
        """Every sphere–plane pair: condim (1 frictionless, 3 with μ), timestep and contact softness.

        While moving: the path's timestep and the softer path contact; otherwise the measuring timestep and the
        stiff contact of :func:`~bracekit.validate.mjcf.build_mujoco_model`.
        """
        self.m.geom_condim[self.geoms] = condim
        self.m.opt.timestep = self.dt if moving or not self.contact else min(self.dt, _MEASURE_TIMESTEP)
        self.m.geom_solref[self.geoms] = _PATH_SOLREF if moving else self.solref
        self.m.geom_solimp[self.geoms] = _PATH_SOLIMP if moving else self.solimp

    def least_normal_force(self) -> tuple[float, int]:
        """The least normal force over the contacts (N) and the least number of active contacts of a pair."""
        forces = [self.normal_force(i) for i in range(len(self.pairs))]
        return min(f for f, _ in forces), min(c for _, c in forces)

    def follow(
        self, path: CubicSpline, rate: CubicSpline, t0: float, t1: float, scale: float, stats: _PathContact | None
    ) -> None:
        """Move the set points along `path` (run time t0 → t1, simulated `scale` times slower), every step.

        The dampers act on q̇ − q̇_s: the set points' velocity ``rate`` / scale is applied as D q̇_s.
        """
        m, d = self.m, self.d
        dt = float(m.opt.timestep)
        steps = max(1, round(scale * (t1 - t0) / dt))
        if stats is not None:
            stats.segment_sum, stats.segment_steps = 0.0, 0
        for j in range(1, steps + 1):
            t = t0 + (t1 - t0) * j / steps
            m.qpos_spring[:] = path(t)
            d.qfrc_applied[:] = self.damping * rate(t) / scale
            mujoco.mj_step(m, d)
            if stats is not None:
                stats.add(*self.least_normal_force())
        d.qfrc_applied[:] = 0.0
        self.check("the path")

    def settle(self, q_s: Array, w: Array, phase: str, strict: bool = True) -> bool:
        """Hold the set points q_s, ramp the dead tip wrench w in over _RAMP·τ and step until settled.

        Returns whether it settled; when ``strict``, not settling raises MujocoValidationError.
        """
        self.m.qpos_spring[:] = q_s
        self.settle_ramped(
            w, phase, ramp=_RAMP, min_hold=_MIN_HOLD, max_hold=_MAX_HOLD, tol=_SETTLE_TOL, check_each_chunk=False
        )
        rest = self.motion()
        settled = rest < 100.0 * _SETTLE_TOL
        if strict and not settled:
            raise MujocoValidationError(
                f"MuJoCo did not settle during {phase} within {_MAX_HOLD:g}τ (max|q̇|·τ = {rest:.2g} rad); "
                "the brace may be slipping or chattering"
            )
        return settled

    def measure(
        self, q_s: Array, w: Array, beta: Array, what: str, strict: bool = True
    ) -> tuple[float, float, bool, bool]:
        """Compliance along β_x from ±w at the set points q_s: β_xᵀ (Δx₊ − Δx₋) / (2|w|).

        Settles unloaded, then under +w and (from the unloaded state) under −w. Returns the compliance, the
        largest tangential motion of b under either load (m), whether the contact opened under either, and
        whether both loaded states settled (``strict``: raise if not).
        """
        self.settle(q_s, np.zeros(6), f"unloaded settling ({what})")
        unloaded = mujoco.MjData(self.m)
        mujoco.mj_copyData(unloaded, self.m, self.d)
        b0 = [self.b_point(i) for i in range(len(self.pairs))]
        x, slip, opened, settled = [], 0.0, False, True
        for sign in (1.0, -1.0):
            mujoco.mj_copyData(self.d, self.m, unloaded)
            settled = self.settle(q_s, sign * w, f"loaded settling ({what})", strict) and settled
            p, r = self.tip()
            x.append((p, r))
            for i, nh in enumerate(self.normals):
                db = self.b_point(i) - b0[i]
                slip = max(slip, float(np.linalg.norm(db - (db @ nh) * nh)))
            fn, ncon = self.least_normal_force()
            opened = opened or (self.m.geom_contype[self.spheres[0]] != 0 and (ncon == 0 or fn <= 0.0))
        (p1, r1), (p2, r2) = x
        dx = np.concatenate([p1 - p2, pin.log3(r1 @ r2.T)])
        return float(beta @ dx) / (2.0 * float(np.linalg.norm(w))), slip, opened, settled
