"""One MuJoCo session of a braced chain: load the MJCF, capture MuJoCo's warnings, load the tip, settle, read contacts.

Every MuJoCo check (:mod:`~bracekit.validate.mujoco_check`, :mod:`~bracekit.validate.holding_check`,
:mod:`~bracekit.validate.tracking`) runs on a :class:`MujocoSession` of the model of
:func:`~bracekit.validate.mjcf.build_mujoco_model`: the tip site, the contacts' sphere/plane pairs (one per
brace, in order), the damping time constant τ (the joints' damping is τ k_i), the dead tip wrench applied with
``mj_applyFT`` at the moving tip site, and the two settling rules:

* :meth:`MujocoSession.settle_until`: step until the remaining motion max|q̇|·τ < tol (rad) or a step budget
  runs out (the static deflection check);
* :meth:`MujocoSession.settle_ramped`: ramp the wrench in over ``ramp``·τ, hold at least ``min_hold``·τ and at
  most ``max_hold``·τ until max|q̇|·τ < tol (the holding and tracking checks).

Contact forces are read with ``mj_contactForce`` (contact frame → world axes) as the force the plane exerts on
the robot at the sphere (N). MuJoCo's own warning handler prints and appends to MUJOCO_LOG.TXT in the working
directory: :func:`captured_warnings` collects the messages instead while a check runs.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass

import mujoco
import numpy as np
from numpy.typing import NDArray

from bracekit.errors import MujocoValidationError
from bracekit.validate.mjcf import TIP_SITE, brace_geom_names

__all__ = ["CHUNK", "MujocoSession", "captured_warnings", "check_warnings"]

Array = NDArray[np.float64]

#: Steps between re-applications of the dead tip wrench and settling checks.
CHUNK = 10

_BAD_WARNINGS = {
    mujoco.mjtWarning.mjWARN_BADQPOS: "bad qpos",
    mujoco.mjtWarning.mjWARN_BADQVEL: "bad qvel",
    mujoco.mjtWarning.mjWARN_BADQACC: "bad qacc",
    mujoco.mjtWarning.mjWARN_CONTACTFULL: "contact buffer full",
    mujoco.mjtWarning.mjWARN_CNSTRFULL: "constraint buffer full",
    mujoco.mjtWarning.mjWARN_INERTIA: "bad inertia",
}


def check_warnings(d: mujoco.MjData, phase: str, messages: list[str]) -> None:
    """MujocoValidationError if MuJoCo warned of an unstable state during ``phase`` or the state is not finite."""
    hits = [txt for w, txt in _BAD_WARNINGS.items() if d.warning[int(w)].number > 0]
    if hits or not (np.all(np.isfinite(d.qpos)) and np.all(np.isfinite(d.qvel))):
        detail = f" MuJoCo said: {messages[0].strip()}" if messages else ""
        raise MujocoValidationError(
            f"MuJoCo simulation went unstable during {phase} ({', '.join(hits) or 'non-finite state'}); "
            f"reduce the load or the timestep.{detail}"
        )


@contextmanager
def captured_warnings(messages: list[str]) -> Iterator[list[str]]:
    """Collect MuJoCo's warning messages in ``messages`` (d.warning still counts them); restore the handler."""
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(messages.append)
    try:
        yield messages
    finally:
        mujoco.set_mju_user_warning(previous)


@dataclass(frozen=True)
class _Pair:
    """Contact i of the model: its sphere and plane geom ids, the sphere's own body (fixed to b_i's link), b_i in it."""

    sphere: int
    plane: int
    body: int
    b_local: Array


class MujocoSession:
    """A compiled MuJoCo model of the braced chain, its data at q0 and the handles of the checks.

    Attributes:
        m: MuJoCo's model.
        d: MuJoCo's data.
        tau: the damping time constant τ (s).
        site: the tip site's id.
        tip_body: the tip site's body id.
        pairs: one sphere/plane pair per contact.
        messages: MuJoCo's warnings (with :func:`captured_warnings`).
    """

    def __init__(
        self, xml: str, stiffness: Array, q0: Array, b_points: list[Array] | None = None, *, gravity: bool = True
    ) -> None:
        """Load ``xml`` (MujocoValidationError if MuJoCo rejects it) and set q = q0 at rest.

        Args:
            xml: MJCF of :func:`~bracekit.validate.mjcf.build_mujoco_model`.
            stiffness: the joint stiffnesses k_i (N·m/rad), to read τ from the damping τ k_i.
            q0: (n,) rad, the start configuration.
            b_points: the material points b_i (world, m) at q0 whose motion :meth:`b_point` follows; default
                the spheres' bodies' origins.
            gravity: False switches the model's gravity off (a model built with the URDF's inertias).
        """
        try:
            self.m = mujoco.MjModel.from_xml_string(xml)
        except ValueError as exc:
            raise MujocoValidationError(f"MuJoCo rejected the generated model: {exc}") from exc
        m = self.m
        if not gravity:
            m.opt.gravity[:] = 0.0
        self.d = mujoco.MjData(m)
        self.tau = float(m.dof_damping[0] / np.asarray(stiffness, dtype=float).reshape(-1)[0])  # damping = τ k_i
        self.site = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, TIP_SITE)
        self.tip_body = int(m.site_bodyid[self.site])
        self.messages: list[str] = []
        self.d.qpos[:] = q0
        self.d.qvel[:] = 0.0
        mujoco.mj_forward(m, self.d)
        pairs = []
        i = 0
        while True:
            sphere_name, plane_name = brace_geom_names(i)
            sphere = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, sphere_name)
            if sphere < 0:
                break
            plane = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, plane_name)
            body = int(m.geom_bodyid[sphere])
            b = self.d.xpos[body] if b_points is None else np.asarray(b_points[i], dtype=float)
            pairs.append(_Pair(sphere, plane, body, self.d.xmat[body].reshape(3, 3).T @ (b - self.d.xpos[body])))
            i += 1
        self.pairs = tuple(pairs)

    def check(self, phase: str) -> None:
        """MujocoValidationError if MuJoCo went unstable (:func:`check_warnings`)."""
        check_warnings(self.d, phase, self.messages)

    def apply(self, w: Array, a: float = 1.0) -> None:
        """Apply the dead tip wrench a·w = [f; m] (N, N·m, world axes) at the current tip-site position."""
        d = self.d
        d.qfrc_applied[:] = 0.0
        if a > 0.0 and np.any(w != 0.0):
            mujoco.mj_kinematics(self.m, d)
            f, tq = a * w[:3], a * w[3:]
            mujoco.mj_applyFT(self.m, d, f, tq, d.site_xpos[self.site].copy(), self.tip_body, d.qfrc_applied)

    def motion(self) -> float:
        """The remaining motion max|q̇|·τ (rad)."""
        return float(np.max(np.abs(self.d.qvel))) * self.tau

    def settle_until(self, wrench: Array, max_steps: int, tol: float, phase: str) -> tuple[int, bool]:
        """Step until max|q̇|·τ < tol (rad), re-applying the wrench every :data:`CHUNK` steps; (steps, settled)."""
        m, d = self.m, self.d
        steps = 0
        f, tq = wrench[:3].copy(), wrench[3:].copy()
        loaded = bool(np.any(wrench != 0.0))
        while steps < max_steps:
            d.qfrc_applied[:] = 0.0
            if loaded:
                mujoco.mj_kinematics(m, d)
                mujoco.mj_applyFT(m, d, f, tq, d.site_xpos[self.site].copy(), self.tip_body, d.qfrc_applied)
            nstep = min(CHUNK, max_steps - steps)
            mujoco.mj_step(m, d, nstep)
            steps += nstep
            self.check(phase)
            if self.motion() < tol:
                return steps, True
        return steps, False

    def settle_ramped(
        self,
        w: Array,
        phase: str,
        *,
        ramp: float,
        min_hold: float,
        max_hold: float,
        tol: float,
        check_each_chunk: bool = True,
    ) -> int:
        """Ramp the dead tip wrench w in over ``ramp``·τ, then step until max|q̇|·τ < tol; the steps taken.

        At least ``min_hold``·τ and at most ``max_hold``·τ after the ramp (steps of :data:`CHUNK`); MuJoCo's
        warnings are checked every chunk (``check_each_chunk``) or once at the end. The wrench stays applied
        and the data are forwarded at the end.
        """
        m, d = self.m, self.d
        dt = float(m.opt.timestep)
        loaded = bool(np.any(w != 0.0))
        n_ramp = int(np.ceil(ramp * self.tau / dt)) if loaded else 0
        least = n_ramp + int(np.ceil(min_hold * self.tau / dt))
        most = n_ramp + int(np.ceil(max_hold * self.tau / dt))
        steps = 0
        while steps < most:
            self.apply(w, 1.0 if n_ramp == 0 else min(1.0, steps / n_ramp))
            mujoco.mj_step(m, d, CHUNK)
            steps += CHUNK
            if check_each_chunk:
                self.check(phase)
            if steps >= least and self.motion() < tol:
                break
        if not check_each_chunk:
            self.check(phase)
        self.apply(w, 1.0)
        mujoco.mj_forward(m, d)
        return steps

    def b_point(self, i: int = 0) -> Array:
        """World position of the material point b_i (m)."""
        p = self.pairs[i]
        return np.asarray(self.d.xpos[p.body] + self.d.xmat[p.body].reshape(3, 3) @ p.b_local)

    def tip(self) -> tuple[Array, Array]:
        """Position (3,) and rotation (3×3) of the tip site, world."""
        return self.d.site_xpos[self.site].copy(), self.d.site_xmat[self.site].reshape(3, 3).copy()

    def contact_force(self, i: int = 0) -> tuple[Array, int]:
        """Force of plane i on its sphere (3,), N, world axes, and the number of its active contacts."""
        p = self.pairs[i]
        total, count, f6 = np.zeros(3), 0, np.zeros(6)
        for j in range(self.d.ncon):
            c = self.d.contact[j]
            if {int(c.geom1), int(c.geom2)} != {p.sphere, p.plane} or c.exclude != 0 or c.efc_address < 0:
                continue
            mujoco.mj_contactForce(self.m, self.d, j, f6)
            f = c.frame.reshape(3, 3).T @ f6[:3]  # contact frame (rows: normal, tangents) → world; on geom2
            total += f if int(c.geom2) == p.sphere else -f
            count += 1
        return total, count

    def normal_force(self, i: int = 0) -> tuple[float, int]:
        """Total normal force of plane i on its sphere (N, the contact frame's normal row) and the contact count."""
        p = self.pairs[i]
        total, count, f6 = 0.0, 0, np.zeros(6)
        for j in range(self.d.ncon):
            c = self.d.contact[j]
            if {int(c.geom1), int(c.geom2)} != {p.sphere, p.plane} or c.exclude != 0 or c.efc_address < 0:
                continue
            mujoco.mj_contactForce(self.m, self.d, j, f6)
            total += float(f6[0])
            count += 1
        return total, count
