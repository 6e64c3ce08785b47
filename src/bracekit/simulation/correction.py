"""The Gauss–Newton correction of a run: the tip back on the task pose and every {b_i} back on its contact.

Residuals are in m and rad, world axes. The contact rows of brace i are X_iᵀ [b_i − b0_i; log3(R_b_i R_b0_iᵀ)]
against its anchor (b0_i, ⁰R_b0_i), stacked in the order of ``braced.braces`` (for one brace: eq:constraint's
rows of the paper's contact); the same code serves any number of braces.
"""

from __future__ import annotations

import importlib
import math
from collections.abc import Sequence
from typing import Any, TypedDict, Unpack, cast

import numpy as np
import pinocchio as pin
from numpy.typing import NDArray

from bracekit.errors import ConvergenceError
from bracekit.kinematics import LWA, BracedRobot, BracedState, skeleton
from bracekit.model.chain import DATA_JOINT_LIMIT
from bracekit.model.robot import Robot
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
    "min_norm_solve",
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


_EPS = float(np.finfo(float).eps)


def _private_gelsd() -> Any:
    """The LAPACK call (gelsd) inside np.linalg.lstsq, without its wrapper's cost (a run takes two per step).

    NumPy's internal: kept only where it exists, takes this call and gives lstsq's very numbers on a check
    at import; None otherwise (the public lstsq then).
    """
    found = getattr(getattr(importlib.import_module("numpy.linalg"), "_umath_linalg", None), "lstsq", None)
    if found is None:
        return None
    m, r = np.array([[2.0, 1.0, 0.0], [1.0, 3.0, 1.0], [0.0, 1.0, 1e-17]]), np.array([1.0, -2.0, 0.5])
    try:
        x = found(m, r[:, None], _EPS * 3, signature="ddd->ddid")[0][:, 0]
    except Exception:  # another signature in another NumPy: the public call
        return None
    return found if np.array_equal(x, np.linalg.lstsq(m, r, rcond=None)[0]) else None


_gelsd = _private_gelsd()


def min_norm_solve(m: Array, r: Array) -> Array:
    """``np.linalg.lstsq(m, r, rcond=None)[0]`` of a square m (k×k) and r (k,): the same LAPACK call and numbers.

    Where the call gives a non-finite x (it did not converge) np.linalg.lstsq itself runs and raises LinAlgError.
    """
    if _gelsd is not None:
        x = _gelsd(m, r[:, None], _EPS * m.shape[0], signature="ddd->ddid")[0][:, 0]
        if math.isfinite(x.sum()):
            return cast(Array, x)
    return cast(Array, np.linalg.lstsq(m, r, rcond=None)[0])


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
#: The kinematics of the tip, then of each brace: (⁰M (4×4), J (6×n)), as ``BracedRobot.state`` reads them.
Frames = list[tuple[Array, Array]]


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

    The iterations read the frames' kinematics from their own Pinocchio data, the calls and numbers of
    ``braced.state``; the state is built once, at the corrected q. Call it as ``correction(q, position)``
    (q (n,) the start, `position` (3,) m the tip's target); one instance per thread.
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
        self._roundoff = CORRECTION_ROUNDOFF * np.finfo(float).eps * np.sqrt(braced.n)
        robot = braced.robot
        self._robot, self._n = robot, robot.n
        self._ids = (robot.tip_id, *braced.brace_ids)
        self._data = robot.model.createData() if robot.n <= DATA_JOINT_LIMIT else None
        self._xs = braced.X_i
        self._moments = _moments(braced.X_i)

    def _frames(self, q: Array) -> tuple[Array, Frames]:
        """Q (checked as ``braced.state`` checks it) and the frames' kinematics at q."""
        n = self._n
        if not (type(q) is np.ndarray and q.dtype == np.float64 and q.shape == (n,) and math.isfinite(q.sum())):
            q = self._robot.check_q(q)
        data = self._data
        if data is None:
            return q, self._robot.frame_kinematics(q, self._ids)
        model = self._robot.model
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        return q, [(data.oMf[f].homogeneous, pin.getFrameJacobian(model, data, f, LWA)) for f in self._ids]

    def _residual(self, frames: Frames, position: Array) -> Array:
        """The residual: the task rows, then −(contact residual), from the frames' kinematics."""
        tip = frames[0][0]
        e, r_e = tip[:3, 3], tip[:3, :3]
        space, anchors = self.space, self.anchors
        contact = [] if anchors is None else _contact_residuals(self._xs, self._moments, _contacts(frames), anchors)
        if space.is_pose:  # [p_d − e; log3(R_d R_eᵀ); −(each contact's residual)]
            return np.concatenate([position - e, pin.log3(self.rotation @ r_e.T), *(-c for c in contact)])
        res = space.selection(r_e) @ space.error(position - e, r_e, self.rotation)
        return np.concatenate([res, *(-c for c in contact)]) if contact else res

    def _jacobian(self, frames: Frames) -> Array:
        """The residual's Jacobian (rows × n): S J_e, then the contact rows."""
        tip, j_e = frames[0]
        rows = j_e if self.space.is_pose else self.space.selection(tip[:3, :3]) @ j_e
        if self.anchors is None:
            return rows
        return np.concatenate([rows, *_contact_jacobians(self._xs, self._moments, _contacts(frames), self.anchors)])

    def __call__(self, q: Array, position: Array) -> BracedState:
        """The corrected state from q (n,) with the tip at `position` (3,) m; ConvergenceError if it cannot."""
        scale, tol = self.scale, self.tol
        previous = np.inf
        q, frames = self._frames(q)
        res, rows = self._residual(frames, position), None  # the rows where a step needs them
        for _ in range(self.max_iter):
            size = float((np.abs(res) / scale).max())  # np.max's reduction, without its wrapper
            if size < tol or (size < ACCEPT_TOL and size > 0.5 * previous):
                return self.braced.state_from_kinematics(q, frames)
            rows = self._jacobian(frames) if rows is None else rows
            floor = self._roundoff * max(1.0, float(np.abs(q).max())) * norm(rows / scale[:, None])
            if size < floor:  # with the test above: size < max(tol, floor), the round-off floor only where it decides
                return self.braced.state_from_kinematics(q, frames)
            previous = size
            step = rows.T @ min_norm_solve(rows @ rows.T, res)
            t_q, t_frames = self._frames(q + step)
            t_res = self._residual(t_frames, position)
            if size >= ACCEPT_TOL and norm(t_res / scale) > norm(res / scale):
                damped = self._damped_step(q, res, rows, position)
                if damped is None:
                    break
                t_q, t_frames, t_res = damped
            q, frames, res, rows = t_q, t_frames, t_res, None
        size = float(np.max(np.abs(res) / scale))
        blame = _blame(self.braced, res, scale, self.space)
        rows = self._jacobian(frames) if rows is None else rows
        raise ConvergenceError(
            f"the pose/contact correction did not converge in {self.max_iter} iterations; not closed: {blame} "
            f"(residual {size:.2e} of the robot's reach {self.length:.3g} m and of 1 rad); "
            f"{_where(rows, scale, self.space)}"
        )

    def _damped_step(self, q: Array, res: Array, rows: Array, position: Array) -> tuple[Array, Frames, Array] | None:
        """A Levenberg–Marquardt step that lowers ‖res / scale‖ (the first λ and line-search fraction that does).

        The step is Jᵀ(J Jᵀ + λ I)⁻¹ r of the scaled rows J = rows / scale and r = res / scale; None if none
        lowers it.
        """
        scale = self.scale
        j, r = rows / scale[:, None], res / scale
        jjt = j @ j.T
        base = norm(r)
        size = max(float(np.trace(jjt)), 1e-300)
        for damping in LM_DAMPING:
            step = j.T @ np.linalg.solve(jjt + damping * size * np.eye(r.size), r)
            for fraction in LINE_SEARCH:
                t_q, t_frames = self._frames(q + fraction * step)
                t_res = self._residual(t_frames, position)
                if norm(t_res / scale) < base:
                    return t_q, t_frames, t_res
        return None


def _contacts(frames: Frames) -> list[tuple[Array, Array, Array]]:
    """(b_i, ⁰R_b_i, J_b_i) of each brace from the frames' kinematics (the tip's first)."""
    return [(m[:3, 3], m[:3, :3], j) for m, j in frames[1:]]


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
