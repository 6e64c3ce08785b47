"""The Gauss–Newton correction of a run: the tip back on the task pose and every {b_i} back on its contact.

Residuals are in m and rad, world axes. The contact rows of brace i are X_iᵀ [b_i − b0_i; log3(R_b_i R_b0_iᵀ)]
against its anchor (b0_i, ⁰R_b0_i), stacked in the order of ``braced.braces`` (for one brace: eq:constraint's
rows of the paper's contact); the same code serves any number of braces.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from types import ModuleType
from typing import TypedDict, Unpack

import numpy as np
import pinocchio as pin
from numpy.typing import NDArray

from bracekit.errors import ConvergenceError, InputError
from bracekit.kinematics import LWA, BracedRobot, BracedState, skeleton
from bracekit.model.chain import DATA_JOINT_LIMIT
from bracekit.model.robot import Robot
from bracekit.resolution.fused_several import FramePass
from bracekit.resolution.task_space import POSE, TaskSpace
from bracekit.tolerances import ACCEPT_TOL, CORRECTION_ROUNDOFF, CORRECTION_TOL

Array = NDArray[np.float64]
#: The contact anchors of a run: (b0_i (3,), ⁰R_b0_i (3×3)) of each brace, in brace order.
Anchors = Sequence[tuple[Array, Array]]
_NO_ANGLE = np.zeros(3)

__all__ = [
    "Anchors",
    "Correction",
    "CorrectionOptions",
    "contact_jacobian",
    "contact_residual",
    "correct",
    "norm",
    "pose_error",
    "reach",
    "task_error",
]


def norm(x: Array) -> float:
    """‖x‖₂ of a vector, ‖x‖_F of a matrix, as ``np.linalg.norm(x)`` computes it.

    √(x·x) over x raveled, the same operations without the wrapper's cost (a run takes several per step).
    """
    flat = x.ravel(order="K")
    return math.sqrt(float(flat.dot(flat)))


def pose_error(state: BracedState, position: Array, rotation: Array) -> Array:
    """[p_d − e; log3(R_d R_eᵀ)] (6,), m and rad, world axes."""
    return np.concatenate([position - state.e, pin.log3(rotation @ state.R_e.T)])


def task_error(state: BracedState, position: Array, rotation: Array, space: TaskSpace = POSE) -> Array:
    """The error (6,) of the rows `space` prescribes: :func:`pose_error` for the pose, else [p_d − e; ω].

    ω is 0 for ``"position"`` and, for ``"position+axis"``, the rotation θ k̂ taking the tool axis
    a = ⁰R_e a_tip to a_d = R_d a_tip (:meth:`TaskSpace.error`), perpendicular to a.
    """
    if space.is_pose:
        return pose_error(state, position, rotation)
    return space.error(position - state.e, state.R_e, rotation)


def contact_residual(state: BracedState, anchors: Anchors) -> Array:
    """Violation of every contact (c,): X_iᵀ [b_i − b0_i; log3(R_b_i R_b0_iᵀ)] per brace, stacked in brace order.

    For a frictionless point this is n̂ᵀ(b_i − b0_i), the distance of {b_i} from the plane through b0_i.
    """
    parts = _contact_residuals(state.X_i, _moments(state.X_i), _of(state), anchors)
    return parts[0] if len(parts) == 1 else np.concatenate(parts)


def contact_jacobian(state: BracedState, anchors: Anchors) -> Array:
    """∂(contact_residual)/∂q (c×n): X_iᵀ [J_b_i,v; Jlog3(R) Rᵀ J_b_i,ω] per brace with R = R_b_i R_b0_iᵀ.

    The moment rows use the exact derivative of log3: the allowed rotations of {b_i} away from the anchor
    grow to O(1 rad) along a run, where the plain rows X_iᵀ J_b_i make the correction converge only linearly.
    A contact without constraint moments (frictionless point, point with friction) gives X_iᵀ J_b_i.
    """
    return np.vstack(_contact_jacobians(state.X_i, _moments(state.X_i), _of(state), anchors))


#: Each brace's (b_i (3,), ⁰R_b_i (3×3), J_b_i (6×n)), in brace order.
Contacts = Sequence[tuple[Array, Array, Array]]
#: Rows of each brace, in brace order.
Parts = list[Array]


def _of(state: BracedState) -> list[tuple[Array, Array, Array]]:
    """(b_i, ⁰R_b_i, J_b_i) of each brace of a state."""
    return [(c.b, c.R_b, c.J_b) for c in state.contacts]


def _moments(xs: Sequence[Array]) -> list[bool]:
    """Whether each brace's X_i has constraint moments (else log3 is weighted by zeros and not computed)."""
    return [bool(x[3:].any()) for x in xs]


def _contact_residuals(xs: Sequence[Array], moments: Sequence[bool], contacts: Contacts, anchors: Anchors) -> Parts:
    """Each brace's rows of :func:`contact_residual` from its X_i and (b_i, ⁰R_b_i, J_b_i)."""
    return [
        x.T @ np.concatenate([b - b0, pin.log3(r_b @ r0.T) if moment else _NO_ANGLE])
        for x, moment, (b, r_b, _), (b0, r0) in zip(xs, moments, contacts, anchors, strict=True)
    ]


def _contact_jacobians(xs: Sequence[Array], moments: Sequence[bool], contacts: Contacts, anchors: Anchors) -> Parts:
    """Each brace's rows of :func:`contact_jacobian` from its X_i and (b_i, ⁰R_b_i, J_b_i)."""
    out = []
    for x, moment, (_, r_b, j_b), (_, r0) in zip(xs, moments, contacts, anchors, strict=True):
        if not moment:
            out.append(x.T @ j_b)
            continue
        r = r_b @ r0.T
        out.append(x[:3].T @ j_b[:3] + x[3:].T @ (pin.Jlog3(r) @ r.T @ j_b[3:]))
    return out


def reach(robot: Robot) -> float:
    """Length (m) of the chain from the first joint to the tip at the neutral configuration (1 if zero).

    The scale of the correction's position residuals: the tip cannot be farther than this from joint 1.
    """
    pts = skeleton(robot, robot.neutral())[1:]
    length = float(np.sum(np.linalg.norm(np.diff(pts, axis=0), axis=1)))
    return length if length > 0 else 1.0


class CorrectionOptions(TypedDict, total=False):
    """The keyword options of :class:`Correction` and :func:`correct`."""

    tol: float
    max_iter: int
    length: float | None
    space: TaskSpace


def correct(
    braced: BracedRobot,
    q: Array,
    position: Array,
    rotation: Array,
    anchors: Anchors | None,
    **options: Unpack[CorrectionOptions],
) -> BracedState:
    """Damped Gauss–Newton: the state nearest q with the tip at the pose and every {b_i} on its contact.

    ``Correction(braced, rotation, anchors, **options)(q, position)`` (the options: ``tol``, ``max_iter``,
    ``length``, ``space``); a run that corrects every step keeps one :class:`Correction`.
    """
    return Correction(braced, rotation, anchors, **options)(q, position)


#: Damping factors λ/‖J‖² of the Levenberg–Marquardt fallback, tried in order.
LM_DAMPING = (1e-6, 1e-4, 1e-2, 1.0)
#: Step fractions of the line search along each damped step.
LINE_SEARCH = (1.0, 0.5, 0.25, 0.125, 0.0625)
#: One point of a correction, as :func:`~bracekit.simulation._correction_kernel.evaluate` gives it: (status,
#: scaled size, scaled norm); its residual, rows and step are in the correction's buffers (:class:`Correction`).
Point = tuple[int, float, float]
#: The kernel's task-space codes (its POSE, POSITION, POSITION_AXIS) and statuses (STEP, DONE, FLOOR).
_KINDS = {"pose": 0, "position": 1, "position+axis": 2}
_STEP, _DONE = 0, 1


def kernel() -> ModuleType:
    """The correction's kernel module (:mod:`bracekit.simulation._correction_kernel`), imported on first use.

    Its ``COMPILED`` says whether it runs compiled (numba); else the correction takes :func:`numpy_point` (a run's
    notes then say so).
    """
    from bracekit.simulation import _correction_kernel

    return _correction_kernel


def numpy_point() -> Callable[..., Point]:
    """The correction's point in NumPy (:mod:`bracekit.simulation._correction_numpy`), where numba is absent."""
    from bracekit.simulation import _correction_numpy

    return _correction_numpy.evaluate


class Correction:
    """Damped Gauss–Newton: the state nearest q with the tip at the pose and every {b_i} on its contact.

    With a task space other than the pose only its selected rows are corrected: S(⁰R_e) [p_d − e; ω]
    (:func:`task_error`) with the rows S J_e; the free rows are left where they are. `anchors` None leaves
    the contacts free (an unbraced run). The step is the minimum-norm Gauss–Newton one, so dependent contact
    rows (two braces constraining the same motion) are harmless; a step that would raise the scaled residual
    norm is replaced by Levenberg–Marquardt steps (damping λ, scaled rows) with a backtracking line search, so
    the residual never grows: the correction returns at or below where it started or raises.

    Residuals are relative to the problem's scale: positions divided by `length` (m; the robot's
    :func:`reach` if not given), angles by 1 rad. Stops when the relative residual is below `tol`, below
    its round-off (CORRECTION_ROUNDOFF · eps · √n · max(1, ‖q‖∞) · ‖scaled Jacobian‖_F), or when it stops
    falling below ACCEPT_TOL; raises ConvergenceError otherwise, naming what did not close (the tip or which
    contact) and its residual.

    Each point takes one Pinocchio pass (the calls and numbers of ``braced.state``, into the correction's own
    arrays) and one call of the compiled kernel (:mod:`bracekit.simulation._correction_kernel`: the residual,
    the stopping test, the rows and the minimum-norm step, the formulas of :func:`task_error`,
    :func:`contact_residual` and :func:`contact_jacobian`; without numba the same point in NumPy,
    :func:`numpy_point`, which the run's notes name); the state is built once, at the corrected q. Call it
    as ``correction(q, position)`` (q (n,) the start, `position` (3,) m the tip's target); one instance per
    thread.
    """

    def __init__(
        self,
        braced: BracedRobot,
        rotation: Array,
        anchors: Anchors | None,
        *,
        tol: float = CORRECTION_TOL,
        max_iter: int = 20,
        length: float | None = None,
        space: TaskSpace = POSE,
    ) -> None:
        self.braced, self.rotation, self.anchors, self.space = braced, rotation, anchors, space
        self.tol, self.max_iter = tol, max_iter
        self.length = reach(braced.robot) if length is None else float(length)
        scale = np.array([self.length] * 3 + [1.0] * (space.rows - 3))
        if anchors is not None:  # unit force and moment columns: a length and an angle residual
            scale = np.concatenate([scale, *(self.length * f + m for f, m in braced.wrench_column_norms)])
        self.scale = scale
        self._roundoff = float(CORRECTION_ROUNDOFF * np.finfo(float).eps * np.sqrt(braced.n))
        robot = braced.robot
        self._robot, self._n = robot, robot.n
        self._ids = (robot.tip_id, *braced.brace_ids)
        data = robot.model.createData() if robot.n <= DATA_JOINT_LIMIT else None
        #: Pinocchio's model and the correction's own data (None: the chain's kinematics)
        self._pin = None if data is None else (robot.model, data)
        self._at: tuple[Array, Array] | None = None  # the q of the returned state's pass, and its values
        # the kernel's inputs: the frames' kinematics of the last pass (new arrays each call: the returned state
        # holds views of them), and the constants of the problem
        self._mats, self._jacs = np.zeros((len(self._ids), 4, 4)), np.zeros((len(self._ids), 6, robot.n))
        xs = braced.X_i if anchors is not None else []
        self._widths = np.array([x.shape[1] for x in xs], dtype=np.int64)
        self._xs = np.zeros((len(xs), 6, max((x.shape[1] for x in xs), default=1)))
        self._anchors = np.zeros((len(xs), 4, 4))
        for i, (x, (b0, r0)) in enumerate(zip(xs, anchors or [], strict=True)):
            self._xs[i, :, : x.shape[1]] = x
            self._anchors[i, :3, :3], self._anchors[i, :3, 3] = r0, b0
        target = np.array(rotation, dtype=np.float64, order="C")
        axis = np.zeros(3) if space.axis is None else np.array(space.axis, dtype=np.float64)
        self._problem = (target, self._anchors, self._xs, self._widths, scale, _KINDS[space.kind], axis)
        self._limits = (ACCEPT_TOL, self._roundoff)
        # two sets of (residual, rows, step): the current point's and a trial's (swapped when a trial is taken)
        self._buffers = [(np.zeros(scale.size), np.zeros((scale.size, robot.n)), np.zeros(robot.n)) for _ in "ab"]
        self._kernel = kernel().evaluate if kernel().COMPILED else numpy_point()

    def _pass(self, q: Array) -> Array:
        """Q (checked as ``braced.state`` checks it), with the frames' kinematics at q in the pass's arrays."""
        n = self._n  # every q_i finite (np.isfinite: no overflow warning for a finite q of huge values)
        if not (
            type(q) is np.ndarray and q.dtype == np.float64 and q.shape == (n,) and bool(np.isfinite(q).all())
        ):
            q = self._robot.check_q(q)
        if not q.flags.c_contiguous:
            q = q.copy()
        mats, jacs = self._mats, self._jacs
        if self._pin is None:
            for i, (m, j) in enumerate(self._robot.frame_kinematics(q, self._ids)):
                mats[i], jacs[i] = m, j
            return q
        model, data = self._pin
        pin.computeJointJacobians(model, data, q)
        place, jacobian = pin.updateFramePlacement, pin.getFrameJacobian  # the frames asked, not all the model's
        for i, f in enumerate(self._ids):
            mats[i] = place(model, data, f).homogeneous
            jacs[i] = jacobian(model, data, f, LWA)
        return q

    def last_pass(self, q: Array) -> FramePass | None:
        """The last pass (its Data, ⁰M and J of the tip and each brace) if it was at this very array q, else None.

        A state this correction returned was built on the pass at its q: a step at that state can take the pass
        instead of making its own (:class:`~bracekit.resolution.GradientProjectionStep`).
        """
        if self._pin is None or self._at is None or self._at[0] is not q or not np.array_equal(q, self._at[1]):
            return None
        return FramePass(self._pin[1], self._mats, self._jacs)

    def _evaluate(self, q: Array, position: Array, previous: float, slot: int, tol: float | None = None) -> Point:
        """The kernel at the last pass (at q): the point's status and sizes.

        Its residual, rows and step go into buffer set `slot` (rows and step as far as its status needed them).
        """
        tol = self.tol if tol is None else tol
        point: Point = self._kernel(
            self._mats, self._jacs, q, position, *self._problem, *self._limits, tol, previous, *self._buffers[slot]
        )
        return point

    def _state(self, q: Array) -> BracedState:
        """The state at q from the last pass (at q), on views of the pass's arrays (this call's own).

        The pass is kept for :meth:`last_pass` with q and a copy of its values (a q changed in place since is not
        at this pass).
        """
        self._at = (q, q.copy())
        return self.braced.state_from_kinematics(q, list(zip(self._mats, self._jacs, strict=True)))

    def __call__(self, q: Array, position: Array) -> BracedState:
        """The corrected state from q (n,) with the tip at `position` (3,) m; ConvergenceError if it cannot."""
        if not (type(position) is np.ndarray and position.dtype == np.float64 and position.flags.c_contiguous):
            position = np.ascontiguousarray(position, dtype=np.float64)
        if position.shape != (3,):
            raise InputError(f"the tip's target position must be 3 numbers (m), got shape {position.shape}")
        self._at = None  # no pass to hand over until this call returns a state
        self._mats, self._jacs = np.empty(self._mats.shape), np.empty(self._jacs.shape)
        q = self._pass(q)
        now = 0  # the buffer set of the current point; the trial's is 1 - now
        status, size, scaled = self._evaluate(q, position, math.inf, now)
        for _ in range(self.max_iter):
            if status != _STEP:  # below tol, stalled below ACCEPT_TOL, or below the round-off floor
                return self._state(q)
            t_q = self._pass(q + self._buffers[now][2])  # the minimum-norm step rowsᵀ (rows rowsᵀ)⁺ res
            trial = self._evaluate(t_q, position, size, 1 - now)
            if size >= ACCEPT_TOL and trial[2] > scaled:
                damped = self._damped_step(q, now, scaled, size, position)
                if damped is None:
                    break
                t_q, trial = damped
            q, (status, size, scaled), now = t_q, trial, 1 - now
        if status != _STEP:  # the last step's point met the test: accepted, as at the top of the loop
            return self._state(q)
        res, rows, _ = self._buffers[now]
        scale = self.scale
        size = float(np.max(np.abs(res) / scale))
        blame = _blame(self.braced, res, scale, self.space)
        if status == _DONE:  # its test stopped before its rows: the rows at q
            self._evaluate(self._pass(q), position, math.inf, now, tol=-1.0)
        raise ConvergenceError(
            f"the pose/contact correction did not converge in {self.max_iter} iterations; not closed: {blame} "
            f"(residual {size:.2e} of the robot's reach {self.length:.3g} m and of 1 rad); "
            f"{_where(rows, scale, self.space)}"
        )

    def _damped_step(
        self, q: Array, now: int, base: float, previous: float, position: Array
    ) -> tuple[Array, Point] | None:
        """A Levenberg–Marquardt step from q that lowers ‖res / scale‖ (`base`), with its point; None if none does.

        res and rows: q's, in buffer set `now`; the trials go into the other. The first λ and line-search
        fraction that lowers the norm. The step is Jᵀ(J Jᵀ + λ I)⁻¹ r of the scaled rows J = rows / scale and
        r = res / scale; `previous` is the size at q, for the stopping test of the new point.
        """
        scale = self.scale
        res, rows, _ = self._buffers[now]
        j, r = rows / scale[:, None], res / scale
        jjt = j @ j.T
        size = max(float(np.trace(jjt)), 1e-300)
        for damping in LM_DAMPING:
            step = j.T @ np.linalg.solve(jjt + damping * size * np.eye(r.size), r)
            for fraction in LINE_SEARCH:
                t_q = self._pass(q + fraction * step)
                trial = self._evaluate(t_q, position, previous, 1 - now)
                if trial[2] < base:
                    return t_q, trial
        return None


#: σ_min/σ_max of the scaled rows below which a correction's failure is put down to a singular matrix.
SINGULAR_ROWS = 1e-6


def _where(rows: Array, scale: Array, space: TaskSpace) -> str:
    """What to do: the task rows S J_e alone singular (the task itself), the task with the contacts, or neither."""
    scaled = rows / scale[:, None]

    def ratio(m: Array) -> float:
        s = np.linalg.svd(m, compute_uv=False)
        return float(s[-1] / s[0]) if s.size and s[0] > 0 else 0.0

    task = ratio(scaled[: space.rows])
    if task < SINGULAR_ROWS:
        return (
            f"the task itself is singular here (σ_min/σ_max of its rows S J_e {task:.1e}): no motion of the joints "
            "follows it; move the task away from this pose"
        )
    both = ratio(scaled)
    if both < SINGULAR_ROWS:
        return (
            f"the task with the contacts is singular (σ_min/σ_max {both:.1e}) although the task alone is not "
            f"({task:.1e}): a braced singularity; raise the braced-conditioning weight (conditioning) where the "
            "redundancy can steer away, else move the task or the brace, or reduce the time step"
        )
    return "reduce the time step or move away from singularities"


def _blame(braced: BracedRobot, res: Array, scale: Array, space: TaskSpace) -> str:
    """What did not close: the tip's task rows and/or each contact, with its largest scaled residual."""
    parts = []
    task = float(np.max(np.abs(res[: space.rows]) / scale[: space.rows]))
    if task > ACCEPT_TOL:
        parts.append(f"the tip ({space.describe()} rows, residual {task:.2e})")
    start = space.rows
    for i, x in enumerate(braced.X_i):
        if start >= res.size:
            break
        part = float(np.max(np.abs(res[start : start + x.shape[1]]) / scale[start : start + x.shape[1]]))
        if part > ACCEPT_TOL:
            who = "the contact" if len(braced.braces) == 1 else f"the contact of braces[{i}]"
            parts.append(f"{who} at {braced.braces[i].frame!r} (residual {part:.2e})")
        start += x.shape[1]
    return ", ".join(parts) if parts else "none, but the residual stopped falling"
