"""One control tick of a braced robot: q̇ that realises a tool twist and keeps every brace, and the next set point.

:class:`ControlStep` is called once per control tick (1 kHz) with the measured or commanded configuration q (n,)
and a tool twist ẋ (6,) — e.g. an :class:`~bracekit.control.admittance.Admittance` command. It returns

* q̇ = q̇_r + q̇_c: q̇_r of the strategy (``strategy.velocity(state, ẋ)``, eq:general_inv / eq:grad_proj; the
  fused :class:`~bracekit.resolution.GradientProjectionStep` for one brace's gradient projection) and the
  contact correction q̇_c, the least-norm joint rate that removes the contacts' drift r (``contact_residual``
  of :mod:`bracekit.simulation.correction`, eq:constraint) in ``correction`` ticks while leaving the selected
  task rows unchanged: [S J_e; ∂r/∂q] q̇_c = [0; −r / (correction · dt)];
* the next configuration q⁺ = q + q̇ dt and its spring set point q_s = q⁺ + K⁻¹ τ0, τ0 = g(q) − Σ_i J_b_iᵀ [P_i n̂_i; 0]
  (the preloaded statics of :mod:`bracekit.statics.stacked` without the geometric term; τ0 taken at q, one tick
  old, so that a tick costs one Pinocchio pass): a position servo of stiffness K at q_s holds gravity and
  presses brace i with P_i at q⁺;
* the contact margins: the residual r (m, rad) and the distance of each b_i to its region's edge r_max − ‖b_i − p_i‖
  (m, +∞ without a region).

Anchors (b0_i, ⁰R_b0_i) are the contacts at the first call (or :meth:`ControlStep.reset`). One code path serves
one brace and several; a free-space strategy corrects nothing and presses nothing.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import NamedTuple, cast

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike, NDArray

from bracekit._linalg import as_number
from bracekit.errors import InputError
from bracekit.kinematics import BracedRobot, BracedState
from bracekit.resolution.fused import GradientProjectionStep, fused_step
from bracekit.resolution.strategies import Strategy, tip_twist, with_beta_x
from bracekit.resolution.task_space import POSE, TaskSpace
from bracekit.simulation.correction import contact_jacobian, contact_residual

Array = NDArray[np.float64]

__all__ = ["ControlResult", "ControlStep"]

#: A contact drift below this (m, rad) is round-off: no correction is computed.
_ROUNDOFF = 1e-13


def _least_norm(gram: Array, rhs: Array) -> Array:
    """The solution of gram · x = rhs by one solve, or by least squares when the rows are dependent.

    Two braces constraining one motion make the Gram matrix singular.
    """
    try:
        x: Array = np.asarray(np.linalg.solve(gram, rhs), dtype=np.float64)
        if np.all(np.isfinite(x)) and np.linalg.norm(gram @ x - rhs) <= 1e-9 * (np.linalg.norm(rhs) + 1e-300):
            return x
    except np.linalg.LinAlgError:
        pass
    return np.asarray(np.linalg.lstsq(gram, rhs, rcond=None)[0], dtype=float)


class ControlResult(NamedTuple):
    """One control tick.

    Attributes:
        qdot: joint rates (n,), rad/s: the strategy's q̇_r plus the contact correction q̇_c.
        q_next: q + q̇ dt (n,), rad.
        set_point: the servo set point q_s of q_next (n,), rad (preload and gravity held).
        residual: the contacts' drift r at q (c,), m and rad, stacked in brace order (empty in free space).
        region_margin: r_max_i − ‖b_i − p_i‖ per brace (N,), m; +∞ where a brace has no region.
        e: the tool position at q (3,), m, world. R_e: the tool orientation at q (3×3).
    """

    qdot: Array
    q_next: Array
    set_point: Array
    residual: Array
    region_margin: Array
    e: Array
    R_e: Array


class ControlStep:
    """q̇ for (q, ẋ) at a control rate, keeping every brace (module docstring).

    Args:
        braced: the braced robot (N ≥ 1 braces).
        strategy: any strategy (``velocity(state, ẋ)``; free space, braced minimum norm, gradient projection,
            braced_qp).
        dt: the control period (s), 1 ms for 1 kHz.
        beta_x: the unit twist (6,) of a compliance-index term (gradient projection), default the objective's.
        preloads: P_i ≥ 0 (N) per brace, or one for all, pressed by the set point (braced strategies only).
        gravity: hold gravity in the set point (Pinocchio's g(q)).
        correction: ticks over which a contact drift is removed (≥ 1; 1 is deadbeat).
        backend: the fused gradient-projection step's backend (``"auto"``: numba when installed, else NumPy).
    """

    def __init__(
        self,
        braced: BracedRobot,
        strategy: Strategy,
        dt: float = 1e-3,
        *,
        beta_x: ArrayLike | None = None,
        preloads: float | Sequence[float] = 0.0,
        gravity: bool = False,
        correction: float = 1.0,
        backend: str = "auto",
    ) -> None:
        if not isinstance(braced, BracedRobot):
            raise InputError(f"expected a BracedRobot, got {type(braced).__name__}")
        if any(not hasattr(strategy, a) for a in ("velocity", "braced", "name")):
            raise InputError(f"strategy must be a bracekit strategy, got {type(strategy).__name__}")
        self.braced = braced
        self.dt = as_number(dt, "the control period dt", positive=True, unit="s")
        self.correction = as_number(correction, "the correction ticks", positive=True)
        if self.correction < 1.0:
            raise InputError(f"the correction must take at least 1 tick, got {self.correction:g}")
        self.beta_x = None if beta_x is None else np.asarray(beta_x, dtype=float).reshape(6)
        self.strategy = strategy if self.beta_x is None else with_beta_x(strategy, self.beta_x)
        self.space: TaskSpace = getattr(strategy, "space", POSE)
        count = len(braced.braces)
        p = np.broadcast_to(np.asarray(preloads, dtype=float), (count,)) if np.ndim(preloads) == 0 else preloads
        pre = np.asarray(p, dtype=float).reshape(-1)
        if pre.size != count or not np.all(np.isfinite(pre)) or np.any(pre < 0.0):
            raise InputError(f"give one preload ≥ 0 N or one per brace ({count}), got {preloads!r}")
        self.preloads = pre if strategy.braced else np.zeros(count)
        self.gravity = bool(gravity)
        self.stiffness = np.asarray(braced.robot.stiffness, dtype=float)
        fast = fused_step(braced, self.strategy)
        if fast is not None and backend != "numpy":
            fast = GradientProjectionStep(braced, self.strategy, backend=backend)  # type: ignore[arg-type]
        if fast is not None and len(braced.braces) > 1 and not fast.uses_kernel:
            fast = None  # the reference step on this tick's state: one Pinocchio pass
        self._fast = fast
        self._data = braced.robot.model.createData()
        self._regions = [
            (i, float(b.region_radius), b.surface.point)
            for i, b in enumerate(braced.braces)
            if b.region_radius is not None
        ]
        self._no_margin = np.full(count, np.inf)
        self._pressing = self.gravity or bool(np.any(self.preloads))
        self.anchors: list[tuple[Array, Array]] | None = None

    def reset(self, q: ArrayLike) -> None:
        """Anchor every contact where it is at q (the drift r is measured from there)."""
        st = self.braced.state(np.asarray(q, dtype=float))
        self.anchors = [(c.b.copy(), c.R_b.copy()) for c in st.contacts]

    def set_point(self, state: BracedState, q: Array | None = None) -> Array:
        """q_s = q + K⁻¹ τ0, τ0 = g − Σ_i J_b_iᵀ [P_i n̂_i; 0] at the state (n,), rad; q defaults to the state's."""
        tau = np.zeros(self.braced.n)
        if self.gravity:
            tau += pin.computeGeneralizedGravity(self.braced.robot.model, self._data, state.q)
        for c, brace, p in zip(state.contacts, self.braced.braces, self.preloads, strict=True):
            if p > 0.0:
                tau -= c.J_b[:3].T @ (p * brace.surface.normal)
        return cast(Array, (state.q if q is None else q) + tau / self.stiffness)

    def __call__(self, q: ArrayLike, xdot: ArrayLike) -> ControlResult:
        """One tick at q (n,) rad with the tool twist ẋ (6,) [v; ω], m/s and rad/s, world axes."""
        qa = np.asarray(q, dtype=float)
        xd = tip_twist(xdot)
        strategy = self.strategy
        fast = self._fast
        if fast is not None:  # the fused step's Pinocchio pass gives the state: one pass per tick
            qdot = fast(qa, xd) if self.beta_x is None else fast(qa, xd, self.beta_x)
            kin = fast.last_kinematics(qa)
            st = self.braced.state(qa) if kin is None else self.braced.state_from_kinematics(qa, kin)
        else:
            st = self.braced.state(qa, hessians=bool(strategy.needs_hessians))
            qdot = strategy.velocity(st, xd)
        residual = np.zeros(0)
        if strategy.braced:
            if self.anchors is None:
                self.anchors = [(c.b.copy(), c.R_b.copy()) for c in st.contacts]
            residual = contact_residual(st, self.anchors)
            if np.abs(residual).max() > _ROUNDOFF:
                rows = self.space.selection(st.R_e) @ st.J_e if not self.space.is_pose else st.J_e
                stacked = np.vstack([rows, contact_jacobian(st, self.anchors)])
                rhs = np.concatenate([np.zeros(rows.shape[0]), -residual / (self.correction * self.dt)])
                qdot = qdot + stacked.T @ _least_norm(stacked @ stacked.T, rhs)
        q_next = qa + qdot * self.dt
        margin = self._no_margin.copy()
        for i, radius, centre in self._regions:
            d = st.contacts[i].b - centre
            margin[i] = radius - math.sqrt(d.dot(d))  # ‖b_i − p_i‖ as np.linalg.norm computes it
        set_point = self.set_point(st, q_next) if self._pressing else q_next
        return ControlResult(qdot, q_next, set_point, residual, margin, st.e.copy(), st.R_e.copy())
