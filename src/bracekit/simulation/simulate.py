"""Integrate a redundancy-resolution strategy along a task (Section VI's kinematic simulation).

Each step: tip twist ẋ = feed-forward + pose-error feedback, q̇ from the strategy, an Euler step, then a
Gauss–Newton correction that puts the tip back on the task pose and, for braced strategies, {b} back on
the contact (to 1e-12 of the robot's reach and of 1 rad), so neither error accumulates. Measures are
recorded at every sample. A gradient-projection step that would jump over the region barrier (explicit
Euler can) is split in halves, at most MAX_SUBSTEP_DEPTH times, and counted in ``Trajectory.substeps``.

A run never passes a singularity silently. It stops (``completed=False``, the reason in ``failure``) when
a joint moves more between two samples than JOINT_STEP_SAFETY × its URDF velocity limit × dt (at most
MAX_JOINT_STEP; DEFAULT_JOINT_SPEED where the URDF gives no limit), or when σ_min/σ_max of a matrix the
strategy inverts (J, or A and J1 when n1 = 6) or of J̃ falls below PATH_SINGULAR_RATIO.
Gradient projection runs through the fused :class:`bracekit.resolution.GradientProjectionStep`, which gives the
strategy's own q̇ to ~1e-13.

No step leaves the URDF joint limits (by more than JOINT_LIMIT_TOL). A corrected step that would is, for
gradient projection, taken again with its null-space motion scaled by 1/2, 1/4, … (LIMIT_SCALES, the gain α
scaled, down to 0: the minimum-norm step); the first scale whose corrected step keeps every joint inside is
kept, and the run notes how many steps were scaled. If none does, or for a strategy without a null-space part
(the minimum-norm ones), the run stops with ``completed=False`` and a reason naming the joints, their values
and limits and the time (:class:`~bracekit.errors.JointLimitError`). Scaling the null space rather than solving
a QP with the limits as constraints keeps every accepted step a step of the strategy itself (eq:grad_proj with
a smaller α), leaves runs that stay inside their limits bit-identical, needs no solver dependency, and leaves
the task and the contact to the correction as before; a QP would change the resolution everywhere a bound
is near, not only where one is crossed. The joint-limit term of g (:class:`bracekit.objective.JointLimits`)
is what keeps a gradient-projection run away from its limits; this check is the guarantee behind it.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike, NDArray

from bracekit._linalg import angle_between, as_number
from bracekit.compliance.first_order import (
    COMPLIANCE_MODELS,
    compliance_index,
    end_effector_compliance,
    free_space_compliance,
    stacked_compliance,
)
from bracekit.compliance.measures import frobenius_condition, singular_value_measures
from bracekit.errors import (
    BarrierError,
    BracekitError,
    BracekitWarning,
    ClearanceWarning,
    ConvergenceError,
    InputError,
    JointLimitError,
    JointLimitWarning,
    NoRedundancyWarning,
    NumericalError,
    RedundantContactWarning,
    RegionWarning,
    SingularityError,
    UnloadedContactWarning,
)
from bracekit.kinematics import BracedRobot, BracedState, skeleton
from bracekit.kinematics.clearance import link_clearance
from bracekit.kinematics.multi import MultiBracedState
from bracekit.model.robot import Robot
from bracekit.objective import RegionBarrier
from bracekit.resolution.multi import MULTI_MATRIX_LABELS, MultiBraceObjective, sigma_ratios
from bracekit.resolution.qp import BracedQP
from bracekit.resolution.strategies import (
    MATRIX_LABELS,
    BracedGradientProjection,
    BracedMinNorm,
    Strategy,
    conditioning,
    inverted_matrices,
    singular_ratio,
    with_beta_x,
)
from bracekit.resolution.task_space import POSE, TaskSpace, redundancy
from bracekit.simulation.tasks import Task
from bracekit.tolerances import (
    ACCEPT_TOL,
    CORRECTION_ROUNDOFF,
    CORRECTION_TOL,
    DEFAULT_JOINT_SPEED,
    JOINT_STEP_SAFETY,
    MAX_JOINT_STEP,
    MAX_STEPS,
    NEAR_SINGULAR_DROP,
    NEAR_SINGULAR_RATIO,
    PATH_SINGULAR_RATIO,
)

Array = NDArray[np.float64]

#: Evaluations the start solve may take.
START_MAX_NFEV = 2000
#: A gradient-projection step that jumps out of the bracing region is halved at most this many times.
MAX_SUBSTEP_DEPTH = 4
#: Configurations on the straight joint path between two samples at which a joint jump is diagnosed.
JUMP_PROBES = 17
#: How far (rad, m for a prismatic joint) a corrected step may leave a joint's URDF range (the correction's round-off).
JOINT_LIMIT_TOL = 1e-9
#: The scales of the null-space motion a gradient-projection step that leaves the joint limits is retried with.
LIMIT_SCALES = (0.5, 0.25, 0.125, 0.0625, 0.0)


def _outside_limits(robot: Robot, q: Array) -> NDArray[np.intp]:
    """The joints (0-based) of q (n,) below their lower or above their upper limit by more than JOINT_LIMIT_TOL."""
    return np.flatnonzero((q < robot.lower - JOINT_LIMIT_TOL) | (q > robot.upper + JOINT_LIMIT_TOL))


def _limit_failure(robot: Robot, q: Array, t: float, scaled: bool) -> JointLimitError:
    """The error that ends a run whose step to time t (s) takes joints beyond their limits at q (n,)."""
    parts = []
    for j in _outside_limits(robot, q):
        unit = "m" if _prismatic(robot, int(j)) else "rad"
        side, limit = ("upper", robot.upper[j]) if q[j] > robot.upper[j] else ("lower", robot.lower[j])
        parts.append(
            f"joint {j + 1} reaches its {side} limit {limit:.4g} {unit} at t = {t:.2f} s (the step takes it to "
            f"{q[j]:.4g} {unit})"
        )
    how = (
        "even with its null-space motion scaled to 0 (the minimum-norm step): the task takes it there"
        if scaled
        else "the strategy has no null-space motion to keep it inside: the task takes it there"
    )
    return JointLimitError(f"{'; '.join(parts)}, {how}; move the task or the start, or use a robot with a wider range")


def _scaled_alpha(strategy: Strategy, scale: float) -> Strategy:
    """The gradient-projection strategy with α · scale (braced minimum norm in its task space at scale 0)."""
    if scale == 0.0:
        return BracedMinNorm(space=getattr(strategy, "space", POSE))
    return replace(strategy, alpha=float(strategy.alpha) * scale)  # type: ignore[attr-defined, type-var]


def _has_region_term(strategy: Strategy) -> bool:
    objective = getattr(strategy, "objective", None)
    return objective is not None and any(
        isinstance(t, RegionBarrier) and w > 0 for t, w in zip(objective.terms, objective.weights, strict=True)
    )


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


def contact_residual(state: BracedState, anchor: Array, anchor_rotation: Array) -> Array:
    """Violation of the contact along each constraint wrench (6 − l,): Xᵀ [b − b0; log3(R_b R_b0ᵀ)].

    For the frictionless point this is n̂ᵀ(b − b0), the distance of {b} from the plane through b0.
    """
    return state.X.T @ np.concatenate([state.b - anchor, pin.log3(state.R_b @ anchor_rotation.T)])


def contact_jacobian(state: BracedState, anchor_rotation: Array) -> Array:
    """∂(contact_residual)/∂q ((6 − l)×n): Xᵀ [J_b,v; Jlog3(R) Rᵀ J_b,ω] with R = R_b R_b0ᵀ.

    The moment rows use the exact derivative of log3: the allowed rotations of {b} away from the anchor
    grow to O(1 rad) along a run, where the plain rows Xᵀ J_b make the correction converge only linearly.
    A contact without constraint moments (frictionless point, point with friction) gives Xᵀ J_b.
    """
    x = state.X
    if not np.any(x[3:]):
        return x.T @ state.J_b
    r = state.R_b @ anchor_rotation.T
    return x[:3].T @ state.J_b[:3] + x[3:].T @ (pin.Jlog3(r) @ r.T @ state.J_b[3:])


def reach(robot: Robot) -> float:
    """Length (m) of the chain from the first joint to the tip at the neutral configuration (1 if zero).

    The scale of the correction's position residuals: the tip cannot be farther than this from joint 1.
    """
    pts = skeleton(robot, robot.neutral())[1:]
    length = float(np.sum(np.linalg.norm(np.diff(pts, axis=0), axis=1)))
    return length if length > 0 else 1.0


def correct(
    braced: BracedRobot,
    q: Array,
    position: Array,
    rotation: Array,
    anchor: tuple[Array, Array] | None,
    *,
    tol: float = CORRECTION_TOL,
    max_iter: int = 20,
    length: float | None = None,
    space: TaskSpace = POSE,
) -> BracedState:
    """Minimum-norm Gauss–Newton: the state nearest q with the tip at the pose (and {b} on the contact).

    With a task space other than the pose only its selected rows are corrected: S(⁰R_e) [p_d − e; ω]
    (:func:`task_error`) with the rows S J_e; the free rows are left where they are.

    Residuals are relative to the problem's scale: positions divided by `length` (m; the robot's
    :func:`reach` if not given), angles by 1 rad. Stops when the relative residual is below `tol`, below
    its round-off (CORRECTION_ROUNDOFF · eps · √n · max(1, ‖q‖∞) · ‖scaled Jacobian‖_F), or when it stops
    falling below ACCEPT_TOL; raises ConvergenceError otherwise.
    """
    scale_len = reach(braced.robot) if length is None else float(length)
    scale = np.array([scale_len] * 3 + [1.0] * (space.rows - 3))
    if anchor is not None:
        x = braced.X  # unit force and moment columns: a length and an angle residual
        scale = np.concatenate([scale, scale_len * np.linalg.norm(x[:3], axis=0) + np.linalg.norm(x[3:], axis=0)])
    roundoff = CORRECTION_ROUNDOFF * np.finfo(float).eps * np.sqrt(braced.n)
    previous = np.inf
    for _ in range(max_iter):
        st = braced.state(q)
        if space.is_pose:
            res = pose_error(st, position, rotation)
            rows = st.J_e
        else:
            sel = space.selection(st.R_e)
            res, rows = sel @ task_error(st, position, rotation, space), sel @ st.J_e
        if anchor is not None:
            res = np.concatenate([res, -contact_residual(st, *anchor)])
            rows = np.vstack([rows, contact_jacobian(st, anchor[1])])
        size = float(np.max(np.abs(res) / scale))
        floor = roundoff * max(1.0, float(np.max(np.abs(st.q)))) * float(np.linalg.norm(rows / scale[:, None]))
        if size < max(tol, floor) or (size < ACCEPT_TOL and size > 0.5 * previous):
            return st
        previous = size
        q = q + rows.T @ np.linalg.lstsq(rows @ rows.T, res, rcond=None)[0]
    raise ConvergenceError(
        f"the pose/contact correction did not converge in {max_iter} iterations (residual {size:.2e} of the "
        f"robot's reach {scale_len:.3g} m and of 1 rad); reduce the time step or move away from singularities"
    )


def joint_step_bound(robot: Robot, dt: float) -> Array:
    """Largest motion (n,) of each joint between two samples dt (s) apart: rad (m for a prismatic joint).

    JOINT_STEP_SAFETY × the URDF velocity limit × dt, with DEFAULT_JOINT_SPEED (rad/s) for a joint whose
    URDF gives 0 or inf, and never more than MAX_JOINT_STEP.
    """
    return np.minimum(JOINT_STEP_SAFETY * _joint_speeds(robot)[0] * dt, MAX_JOINT_STEP)


def _joint_speeds(robot: Robot) -> tuple[Array, NDArray[np.bool_]]:
    """The velocity limit of each joint (n,) and whether the URDF gave it (n,) (else DEFAULT_JOINT_SPEED)."""
    v = np.asarray(robot.model.velocityLimit, dtype=float).copy()
    given = np.isfinite(v) & (v > 0)
    v[~given] = DEFAULT_JOINT_SPEED
    return v, given


def _jump_failure(
    braced: BracedRobot,
    strategy: Strategy,
    before: Array,
    after: Array,
    bound: Array,
    dt: float,
    start: dict[str, float],
) -> NumericalError:
    """The error that ends a run whose joints moved more than `bound` (n,) between two samples.

    Names the joints (1-based, chain order), the motion and its bound, and the smallest σ_min/σ_max of the
    strategy's matrices at JUMP_PROBES configurations on the straight joint path between the samples. That
    is a singularity when below NEAR_SINGULAR_RATIO or NEAR_SINGULAR_DROP × its value at the run's start
    (`start`, the measures of the first sample).
    """
    step = np.abs(after - before)
    over = np.flatnonzero(step > bound)
    joints = ", ".join(str(j + 1) for j in over)
    units = {"m" if _prismatic(braced.robot, int(j)) else "rad" for j in over}
    unit = units.pop() if len(units) == 1 else "rad or m"
    lo, hi = float(np.min(bound[over])), float(np.max(bound[over]))
    limit = f"bound {hi:.3g} {unit}" if f"{lo:.3g}" == f"{hi:.3g}" else f"bounds {lo:.3g}–{hi:.3g} {unit}"
    given = _joint_speeds(braced.robot)[1]
    sources = []
    if np.any(bound[over] >= MAX_JOINT_STEP):
        sources.append(f"at most {MAX_JOINT_STEP:.3g} per step")
    if np.any(given[over] & (bound[over] < MAX_JOINT_STEP)):
        sources.append(f"{JOINT_STEP_SAFETY:g} × the URDF velocity limit × dt")
    if np.any(~given[over] & (bound[over] < MAX_JOINT_STEP)):
        sources.append(f"{JOINT_STEP_SAFETY:g} × {DEFAULT_JOINT_SPEED:.3g}/s × dt, no URDF velocity limit")
    message = (
        f"joint{'s' if over.size > 1 else ''} {joints} moved {np.max(step[over]):.3g} {unit} in one {dt:.3g} s step "
        f"({limit}: {'; '.join(sources)})"
    )
    keys = inverted_matrices(strategy.braced, braced.n1)
    probes = [braced.state(before + s * (after - before)) for s in np.linspace(0.0, 1.0, JUMP_PROBES)]
    ratios = {key: min(conditioning(p, (key,))[key] for p in probes) for key in keys}
    drop = {key: ratios[key] / max(start[f"sigma_ratio_{key}"], 1e-300) for key in keys}
    near = [key for key in keys if ratios[key] < NEAR_SINGULAR_RATIO or drop[key] < NEAR_SINGULAR_DROP]
    if near:
        key = min(near, key=drop.__getitem__)
        return SingularityError(
            f"{message}; the step passes a singularity of {MATRIX_LABELS[key]} (σ_min/σ_max down to "
            f"{ratios[key]:.1e} from {start[f'sigma_ratio_{key}']:.1e} at the start)"
        )
    worst = min(ratios, key=ratios.__getitem__)
    label = MATRIX_LABELS[worst]
    gain = " or |alpha|" if getattr(strategy, "objective", None) is not None else ""
    return NumericalError(
        f"{message}; no singularity between the samples (σ_min/σ_max ≥ {ratios[worst]:.1e}, of {label}): "
        f"the strategy's joint rates exceed the bound; reduce dt, slow the task{gain}"
    )


def _prismatic(robot: Robot, j: int) -> bool:
    """Whether joint j (0-based, chain order) is prismatic."""
    return str(robot.model.joints[j + 1].shortname()).startswith("JointModelP")


def _check_conditioning(row: dict[str, float], keys: tuple[str, ...]) -> None:
    """SingularityError if σ_min/σ_max of a matrix in `keys` (recorded in `row`) is below PATH_SINGULAR_RATIO."""
    low = [key for key in keys if row[f"sigma_ratio_{key}"] < PATH_SINGULAR_RATIO]
    if low:
        key = min(low, key=lambda k: row[f"sigma_ratio_{k}"])
        raise SingularityError(
            f"{MATRIX_LABELS[key]} is singular on the path (σ_min/σ_max = {row[f'sigma_ratio_{key}']:.1e} "
            f"< {PATH_SINGULAR_RATIO:g})"
        )


@dataclass
class Trajectory:
    """One strategy's run: samples at times t (N,), joint values q (N×n) and named measures (N,).

    ``failure`` says why a run that did not complete stopped: the step and time, and what failed (a joint
    jump, a singular matrix, a barrier, a correction that did not converge).
    """

    strategy: str
    braced: bool
    t: Array
    q: Array
    measures: dict[str, Array]
    completed: bool
    failure: str | None = None
    warnings: list[str] = field(default_factory=list)
    substeps: int = 0
    task_space: str = "pose"
    redundancy: int | None = None
    braces: list[dict[str, float]] | None = None

    @property
    def steps(self) -> int:
        """Steps taken (samples − 1)."""
        return int(self.t.size - 1)

    def ci_key(self, model: str) -> str:
        """The C_i series of this run: free-space compliance for the unbraced run, else C_e of `model`.

        With the run model ``preloaded`` it is ``Ci_preloaded`` for every run (the statics' own series, with
        gravity and the preload; in free space with gravity).
        """
        if model == "preloaded":
            return "Ci_preloaded"
        return f"Ci_{model}" if self.braced else "Ci_free"

    def summary(self, model: str = "constrained") -> dict[str, Any]:
        """The Table I metrics and run checks (SI units)."""
        m = self.measures
        # a model undefined for the run (projection with several braces) has no series: None below
        ci = m.get(self.ci_key(model), np.array([np.inf]))
        finite = bool(np.all(np.isfinite(ci)))  # a preloaded C_i is inf where the equilibrium is unstable
        return {
            "Ci_mean": float(np.mean(ci)) if finite else None,
            "Ci_min": float(np.min(ci)) if finite else None,
            "prod_sigma_t_mean": float(np.mean(m["prod_sigma_t"])),
            "prod_sigma_o_mean": float(np.mean(m["prod_sigma_o"])),
            "sigma_t_min": float(np.min(m["sigma_t_min"])),
            "sigma_o_min": float(np.min(m["sigma_o_min"])),
            "k_mean": float(np.mean(m["k"])),
            "k_free_mean": float(np.mean(m["k_free"])),
            "theta_z_max_rad": float(np.max(m["theta_z"])),
            "max_task_error_m": float(np.max(m["task_error"])),
            "max_contact_violation_m": float(np.max(m["contact_violation"])),
            "max_region_radius_m": float(np.max(m["region_radius"])),
            "min_surface_distance_m": float(np.min(m["surface_distance"])),
            "max_joint_limit_violation_rad": float(np.max(m["joint_limit_violation"])),
            "max_joint_step_rad": float(np.max(m["joint_step"])),
            "min_link_clearance_m": _finite_or_none(float(np.min(m["link_clearance"]))),
            "steps": self.steps,
            "substeps": self.substeps,
            "completed": self.completed,
            "failure": self.failure,
            "task_space": self.task_space,
            "redundancy": self.redundancy,
        } | ({} if self.braces is None else {"braces": self.braces})


def _finite_or_none(value: float) -> float | None:
    """`value`, or None where it is not finite (JSON holds no inf)."""
    return value if np.isfinite(value) else None


def measure(
    state: BracedState, beta_x: Array, centre: Array, task_error: float, braced: bool, joint_step: float = 0.0
) -> dict[str, float]:
    """The measures recorded at a sample (C_i in all models, J̃ singular values, k, θ_z, r, limits).

    Also σ_min/σ_max of J1, A, J and J̃ (``sigma_ratio_<key>``), ``joint_step``, the largest |Δq_i|
    since the previous sample (rad, m for a prismatic joint; 0 at the start), and ``link_clearance``, the
    least clearance of the link capsules from the surface as a solid obstacle (m, negative = penetration; inf
    only without capsules; :mod:`bracekit.kinematics.clearance`).
    """
    sv = singular_value_measures(state.J_braced)
    lower, upper = state.braced.robot.lower, state.braced.robot.upper
    surface = state.braced.brace.surface
    out = {
        "Ci_free": compliance_index(free_space_compliance(state), beta_x),
        "prod_sigma_t": sv.prod_sigma_t,
        "prod_sigma_o": sv.prod_sigma_o,
        "sigma_t_min": sv.sigma_t_min,
        "sigma_o_min": sv.sigma_o_min,
        "k": frobenius_condition(state.J_braced),
        "k_free": frobenius_condition(state.J_e),
        "theta_z": angle_between(surface.normal, state.z_b),
        "region_radius": float(np.linalg.norm(state.b - centre)),
        "contact_violation": abs(surface.signed_distance(state.b)),
        "surface_distance": surface.signed_distance(state.b),
        "joint_limit_violation": float(np.max(np.maximum(0.0, np.maximum(lower - state.q, state.q - upper)))),
        "task_error": task_error,
        "joint_step": joint_step,
        "link_clearance": link_clearance(state)[0],
    }
    for key, ratio in conditioning(state, tuple(MATRIX_LABELS)).items():
        out[f"sigma_ratio_{key}"] = ratio
    for model in COMPLIANCE_MODELS:
        out[f"Ci_{model}"] = compliance_index(end_effector_compliance(state, model), beta_x)  # type: ignore[arg-type]
    return out


def simulate(
    braced: BracedRobot,
    strategy: Strategy,
    task: Task,
    q0: ArrayLike,
    dt: float,
    beta_x: Callable[[float], Array],
    *,
    feedback_gain: float = 1.0,
    progress: Callable[[int], None] | None = None,
) -> Trajectory:
    """Run `strategy` along `task` from q0 with time step dt (s); never raises on a failed step.

    A step that meets a singularity (σ_min/σ_max below PATH_SINGULAR_RATIO at a sample, or a joint jump
    beyond :func:`joint_step_bound`), a barrier or a failed correction ends the run with
    ``completed=False`` and the reason in ``failure``. `beta_x(t)` gives the unit twist (6,) along which
    the compliance index is measured (and minimised by a gradient-projection strategy).

    The strategy's ``space`` (a :class:`~bracekit.resolution.task_space.TaskSpace`, the pose by default)
    says which rows of the task the run follows and corrects; the others are free. ``redundancy`` of the
    trajectory is the null space those rows leave at the start: (l + n2) − rank(S A) for a braced strategy,
    n − rank(S J) in free space. Gradient projection with none warns (NoRedundancyWarning): it cannot act.
    """
    dt = as_number(dt, "the time step dt", positive=True, unit="s")
    feedback_gain = as_number(feedback_gain, "the feedback gain", nonnegative=True, unit="1/s")
    for name, value, needed in (
        ("strategy", strategy, ("velocity", "braced", "name")),
        ("task", task, ("position", "velocity", "duration")),
    ):
        if any(not hasattr(value, attr) for attr in needed):
            raise InputError(f"{name} must be a bracekit {name.capitalize()}, got {type(value).__name__}")
    if not callable(beta_x):
        raise InputError(f"beta_x must be a function of time returning a unit twist (6,), got {type(beta_x).__name__}")
    if task.duration / dt > MAX_STEPS:
        raise InputError(
            f"dt = {dt:g} s gives {task.duration / dt:.3g} steps for a {task.duration:g} s task (more than "
            f"{MAX_STEPS}); give a larger dt"
        )
    steps = max(1, round(task.duration / dt))
    dt = task.duration / steps  # the last sample lands on the task's end
    if len(braced.braces) > 1:
        return _simulate_braces(braced, strategy, task, q0, dt, steps, beta_x, feedback_gain, progress)
    st = braced.state(q0)
    rotation = task.rotation if task.rotation is not None else st.R_e.copy()
    space = getattr(strategy, "space", POSE)
    if not isinstance(space, TaskSpace):
        raise InputError(f"the strategy's space must be a TaskSpace, got {space!r}")
    free_dims = redundancy(space, st.R_e, st.A if strategy.braced else st.J_e)
    anchor = (st.b.copy(), st.R_b.copy()) if strategy.braced else None
    centre = braced.brace.surface.point
    r_max = braced.brace.region_radius
    fast = None
    if type(strategy) is BracedGradientProjection:
        from bracekit.resolution.fused import GradientProjectionStep

        fast = GradientProjectionStep(braced, strategy)
    guard = r_max is not None and _has_region_term(strategy)
    substeps = 0
    length = reach(braced.robot)
    bound = joint_step_bound(braced.robot, dt)
    checked = inverted_matrices(strategy.braced, braced.n1)

    scalable = isinstance(strategy, BracedGradientProjection)
    scaled_steps: dict[float, Any] = {}
    limited = 0

    def rate(st: BracedState, t: float, xdot: Array, scale: float = 1.0) -> Array:
        """Q̇ of the strategy at st, with its null-space motion scaled by `scale` (gradient projection only)."""
        if fast is not None and scale > 0.0:  # the fused step: the same q̇ as the strategy's, to ~1e-13
            if scale == 1.0:
                return fast(st.q, xdot, beta_x(t))
            if scale not in scaled_steps:
                from bracekit.resolution.fused import GradientProjectionStep

                scaled_steps[scale] = GradientProjectionStep(braced, _scaled_alpha(strategy, scale))  # type: ignore[arg-type]
            return scaled_steps[scale](st.q, xdot, beta_x(t))
        current = with_beta_x(strategy if scale == 1.0 else _scaled_alpha(strategy, scale), beta_x(t))
        if current.needs_hessians:
            st = braced.state(st.q, hessians=True)
        return current.velocity(st, xdot)

    def advance(st: BracedState, t: float, h: float, depth: int = 0) -> BracedState:
        """One Euler step of length h from t, corrected; halved (up to 1/16) if it jumps out of the region.

        A step that leaves the joint limits is retried with the null-space motion scaled (LIMIT_SCALES) or
        ends the run (JointLimitError).
        """
        nonlocal substeps, limited
        err = task_error(st, task.position(t), rotation, space)
        xdot = np.concatenate([task.velocity(t), np.zeros(3)]) + feedback_gain * err
        qdot = rate(st, t, xdot)
        new = correct(braced, st.q + qdot * h, task.position(t + h), rotation, anchor, length=length, space=space)
        if _outside_limits(braced.robot, new.q).size:
            for scale in LIMIT_SCALES if scalable else ():
                qdot = rate(st, t, xdot, scale)
                new = correct(
                    braced, st.q + qdot * h, task.position(t + h), rotation, anchor, length=length, space=space
                )
                if not _outside_limits(braced.robot, new.q).size:
                    limited += 1
                    break
            else:
                raise _limit_failure(braced.robot, new.q, t + h, scalable)
        if guard and np.linalg.norm(new.b - centre) >= r_max:  # type: ignore[operator]
            if depth >= MAX_SUBSTEP_DEPTH:
                raise BarrierError(
                    f"the bracing point leaves the region (r = {np.linalg.norm(new.b - centre):.4g} m ≥ r_max) "
                    f"even with steps of {h:.3g} s; reduce dt or raise the region weight"
                )
            substeps += 1
            mid = advance(st, t, h / 2, depth + 1)
            return advance(mid, t + h / 2, h / 2, depth + 1)
        return new

    start_error = float(np.linalg.norm(task.position(0.0) - st.e))
    try:
        rows = [measure(st, beta_x(0.0), centre, start_error, strategy.braced)]
    except NumericalError as exc:  # nothing can be recorded at a start the measures cannot take
        raise type(exc)(f"the start of {strategy.name} (t = 0.000 s) cannot be measured: {exc}") from exc
    ts, qs = [0.0], [st.q.copy()]
    failure = None
    try:
        _check_conditioning(rows[0], checked)
    except SingularityError as exc:
        failure = f"start (t = 0.000 s): {exc}"
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", UnloadedContactWarning)
        for i in range(steps if failure is None else 0):
            t, t_next = i * dt, (i + 1) * dt
            try:
                before = st.q
                st = advance(st, t, dt)
                step = np.abs(st.q - before)
                if np.any(step > bound):
                    raise _jump_failure(braced, strategy, before, st.q, bound, dt, rows[0])
                task_err = float(np.linalg.norm(task.position(t_next) - st.e))
                row = measure(st, beta_x(t_next), centre, task_err, strategy.braced, float(np.max(step)))
                _check_conditioning(row, checked)
                rows.append(row)
            except BracekitError as exc:
                failure = f"step {i + 1} (t = {t_next:.3f} s): {exc}"
                break
            ts.append(t_next)
            qs.append(st.q.copy())
            if progress is not None:
                progress(1)
    measures = {key: np.array([r[key] for r in rows]) for key in rows[0]}
    notes = []
    unloaded = [w for w in caught if issubclass(w.category, UnloadedContactWarning)]
    if unloaded:
        notes.append(f"{strategy.name}: at {len(unloaded)} evaluation(s) {unloaded[0].message}")
        warnings.warn(notes[-1], UnloadedContactWarning, stacklevel=2)
    for w in caught:  # pass on anything else unchanged
        if not issubclass(w.category, UnloadedContactWarning):
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    limit = float(measures["joint_limit_violation"][0])
    if limit > 0:
        notes.append(f"{strategy.name}: the start exceeds the joint limits by {limit:.3g} rad")
        warnings.warn(notes[-1], JointLimitWarning, stacklevel=2)
    if limited:
        notes.append(
            f"{strategy.name}: {limited} step(s) had their null-space motion scaled down to keep the joints inside "
            "their limits"
        )
    inside = measures["region_radius"] < (r_max if r_max is not None else np.inf)
    depth = float(np.min(measures["surface_distance"], initial=0.0, where=inside))
    if depth < -1e-6:
        notes.append(
            f"{strategy.name}: the bracing point passes {-depth:.3g} m below the bracing surface inside the region "
            "(this run ignores the surface)"
        )
    clearance = float(np.min(measures["link_clearance"]))
    if clearance < 0:
        notes.append(
            f"{strategy.name}: a link passes {-clearance:.3g} m through the bracing plane into the obstacle "
            f"(at {int(np.sum(measures['link_clearance'] < 0))} of {len(rows)} samples; the obstacle and the link "
            "capsules of bracekit.kinematics.clearance)"
        )
        warnings.warn(notes[-1], ClearanceWarning, stacklevel=2)
    if substeps:
        notes.append(f"{strategy.name}: {substeps} step(s) were split to keep the bracing point in the region")
    if free_dims == 0 and isinstance(strategy, BracedGradientProjection):
        notes.append(
            f"{strategy.name}: the task space '{space.kind}' leaves no redundancy ({space.rows} task rows take every "
            "braced coordinate): gradient projection cannot act and equals braced minimum norm; free task rows "
            "(space 'position' or 'position+axis') leave it room"
        )
        warnings.warn(notes[-1], NoRedundancyWarning, stacklevel=2)
    if r_max is not None and np.max(measures["region_radius"]) >= r_max:
        notes.append(
            f"{strategy.name}: the bracing point left the bracing region "
            f"(max r = {np.max(measures['region_radius']):.4f} m > r_max = {r_max:.4f} m)"
        )
        warnings.warn(notes[-1], RegionWarning, stacklevel=2)
    return Trajectory(
        strategy=strategy.name,
        braced=strategy.braced,
        t=np.array(ts),
        q=np.array(qs),
        measures=measures,
        completed=failure is None,
        failure=failure,
        warnings=notes,
        substeps=substeps,
        task_space=space.describe(),
        redundancy=free_dims,
    )


#: The θ_z weight of the start solve when the caller gives none and the brace has a pad axis.
START_THETA_WEIGHT = 0.3
#: The start solve's conditioning term acts where σ_min/σ_max of A or J̃ falls below this (inactive above).
START_CONDITIONING_FLOOR = 0.02
#: The start solve's default weight of the conditioning term.
START_CONDITIONING_WEIGHT = 0.1
#: Matrices whose conditioning the start solve keeps above START_CONDITIONING_FLOOR (the braced inverses).
START_CONDITIONED = ("A", "J_braced")
#: Joint step (rad or m) of the finite differences of the conditioning term's Jacobian rows.
START_FD_STEP = 1e-7


def _conditioning_residual(state: BracedState, floor: float) -> Array:
    """log(floor / ρ) where ρ = σ_min/σ_max < floor, else 0, for each matrix of START_CONDITIONED.

    A barrier that is C¹ in its square and exactly zero wherever every ratio is at least `floor`.
    """
    ratios = conditioning(state, START_CONDITIONED)
    return np.array([np.log(floor / max(ratios[k], 1e-300)) if ratios[k] < floor else 0.0 for k in START_CONDITIONED])


def solve_start(
    braced: BracedRobot,
    position: ArrayLike,
    guess: ArrayLike,
    *,
    rotation: ArrayLike | None = None,
    region_weight: float = 1.0,
    theta_weight: float | None = None,
    posture_weight: float = 0.01,
    conditioning_weight: float = START_CONDITIONING_WEIGHT,
    conditioning_floor: float = START_CONDITIONING_FLOOR,
) -> BracedState:
    """A start configuration: tip at `position` (and `rotation` if given), {b} on the surface.

    Solved from `guess` (n,) by SciPy least squares: the tip pose and the contact are hard residuals
    (then polished to 1e-12 by Gauss–Newton), while the distance of {b} from the region centre, θ_z (only
    for a brace with a pad axis), the conditioning of the braced inverses and the distance from the guess
    are soft. The conditioning term is ``conditioning_weight · log(conditioning_floor / ρ)`` for each of
    σ_min/σ_max ρ of A and J̃ below `conditioning_floor` and zero elsewhere (its Jacobian rows by finite
    differences where it acts); it is added, and the solve continued, only if the solve without it ends
    with a ratio below the floor, so a start that is conditioned enough is the plain solve's.

    Args:
        braced: the braced robot.
        position: tip position at the start (3,), m.
        guess: the initial guess (n,).
        rotation: tip rotation at the start (3×3), or None for any.
        region_weight: weight of ‖b − region centre‖ (1/m).
        theta_weight: weight of θ_z (1/rad); None is START_THETA_WEIGHT for a brace with a pad axis and 0
            otherwise. Must be 0 for a brace without pad axis.
        posture_weight: weight of ‖q − guess‖.
        conditioning_weight: weight of the conditioning barrier (0 drops it).
        conditioning_floor: the σ_min/σ_max below which the barrier acts, in (0, 1).

    Raises:
        InputError: a position that is not 3 finite numbers (m), a rotation that is not a finite 3×3
            rotation matrix, a bad guess, a negative or non-finite weight, a floor outside (0, 1), or a
            θ_z weight for a brace without pad axis.
        ConvergenceError: the hard residuals are not met or {b} ends outside the bracing region.

    Warns (BracekitWarning) only about a start that meets the task and the contact but whose soft terms did
    not converge.
    """
    from scipy.optimize import least_squares

    target = _finite(position, (3,), "the start position (m)")
    rot = None if rotation is None else _finite(rotation, (3, 3), "the start rotation")
    if rot is not None and not (np.allclose(rot.T @ rot, np.eye(3), atol=1e-9) and np.linalg.det(rot) > 0):
        raise InputError("the start rotation must be a rotation matrix (orthonormal, determinant +1)")
    q_guess = braced.robot.check_q(guess)
    pad = braced.brace.pad_axis
    if theta_weight is None:
        theta_weight = START_THETA_WEIGHT if pad else 0.0
    for what, value in (
        ("region_weight", region_weight),
        ("theta_weight", theta_weight),
        ("posture_weight", posture_weight),
        ("conditioning_weight", conditioning_weight),
    ):
        if isinstance(value, bool) or not isinstance(value, int | float) or not (0.0 <= value < np.inf):
            raise InputError(f"{what} must be a finite number ≥ 0, got {value!r}")
    if theta_weight > 0 and not pad:
        raise InputError(
            f"theta_weight = {theta_weight:g} needs a brace with a pad axis, and {braced.brace.frame!r} (a link "
            "point) has none; give the brace a pad axis or theta_weight = 0"
        )
    if isinstance(conditioning_floor, bool) or not isinstance(conditioning_floor, int | float):
        raise InputError(f"conditioning_floor must be a number in (0, 1), got {conditioning_floor!r}")
    if not 0.0 < conditioning_floor < 1.0:
        raise InputError(f"conditioning_floor must be a number in (0, 1), got {conditioning_floor!r}")
    surface = braced.brace.surface
    lo, hi = braced.robot.lower, braced.robot.upper

    x_t, y_t = surface.frame[:, 0], surface.frame[:, 1]
    use_theta = theta_weight > 0

    def residual(q: Array, conditioned: bool) -> Array:
        st = braced.state(q)
        hard = [target - st.e, np.array([surface.signed_distance(st.b)])]
        if rot is not None:
            hard.append(pin.log3(rot @ st.R_e.T))
        soft = [region_weight * (st.b - surface.point)]
        if use_theta:  # ẑ_b's tangential components: ≈ θ_z for small angles and smooth at 0, unlike θ_z itself
            soft.append(theta_weight * np.array([x_t @ st.z_b, y_t @ st.z_b]))
        soft.append(posture_weight * (q - q_guess))
        if conditioned:
            soft.append(conditioning_weight * _conditioning_residual(st, conditioning_floor))
        return np.concatenate([1e3 * np.concatenate(hard), np.concatenate(soft)])

    def jacobian(q: Array, conditioned: bool) -> Array:
        st = braced.state(q)
        hard = [-st.J_e[:3], surface.normal @ st.J_b[:3]]
        if rot is not None:
            hard.append(-st.J_e[3:])  # first-order (exact at the solution)
        soft = [region_weight * st.J_b[:3]]
        if use_theta:
            soft.append(
                theta_weight * np.vstack([np.cross(st.z_b, x_t) @ st.J_b[3:], np.cross(st.z_b, y_t) @ st.J_b[3:]])
            )
        soft.append(posture_weight * np.eye(q.size))
        if conditioned:
            soft.append(conditioning_weight * _conditioning_jacobian(braced, st, conditioning_floor))
        return np.vstack([1e3 * np.vstack(hard), np.vstack(soft)])

    def solve(x0: Array, conditioned: bool) -> Any:
        return least_squares(
            residual,
            x0,
            jac=jacobian,
            bounds=(lo, hi),
            xtol=1e-12,
            ftol=1e-12,
            gtol=1e-12,
            max_nfev=START_MAX_NFEV,
            args=(conditioned,),
        )

    # without the barrier first: where it would be inactive at the solution, the start is that solve's exactly
    sol = solve(np.clip(q_guess, lo + 1e-6, hi - 1e-6), False)
    if conditioning_weight > 0 and np.any(_conditioning_residual(braced.state(sol.x), conditioning_floor)):
        sol = solve(sol.x, True)
    st = braced.state(sol.x)
    rotation_target = rot if rot is not None else st.R_e
    # the plane point under b: an anchor on the surface
    anchor_point = st.b - surface.normal * surface.signed_distance(st.b)
    try:
        st = correct(braced, st.q, target, rotation_target, (anchor_point, st.R_b))
    except ConvergenceError:
        raise ConvergenceError(
            f"no start configuration puts the tip at {np.round(target, 4).tolist()} m with the brace closed "
            f"(closest: {np.linalg.norm(target - st.e):.3g} m away); move the task or the surface, or change the guess"
        ) from None
    r_max = braced.brace.region_radius
    r = float(np.linalg.norm(st.b - surface.point))
    if r_max is not None and r >= r_max:
        raise ConvergenceError(
            f"no start configuration with the bracing point inside the region: r = {r:.4f} m ≥ r_max = {r_max} m; "
            "move the region centre, the task or the start guess"
        )
    if sol.status <= 0:  # only now is it known that the start meets the task and the contact
        warnings.warn(
            f"the start solve stopped after {sol.nfev} evaluations before its soft terms (r, θ_z, conditioning, "
            "distance to the guess) converged; the start meets the task and the contact but is not their optimum: "
            "give a closer guess",
            BracekitWarning,
            stacklevel=2,
        )
    return st


def _conditioning_jacobian(braced: BracedRobot, state: BracedState, floor: float) -> Array:
    """∂(_conditioning_residual)/∂q by central differences; zero rows where the barrier is inactive."""
    base = _conditioning_residual(state, floor)
    out = np.zeros((base.size, state.q.size))
    if not np.any(base):
        return out
    for i in range(state.q.size):
        step = np.zeros(state.q.size)
        step[i] = START_FD_STEP
        up = _conditioning_residual(braced.state(state.q + step), floor)
        down = _conditioning_residual(braced.state(state.q - step), floor)
        out[:, i] = (up - down) / (2.0 * START_FD_STEP)
    return out


def _finite(value: ArrayLike, shape: tuple[int, ...], what: str) -> Array:
    """`value` as a float array of `shape`; InputError if it has another size or a non-finite entry."""
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{what} must be numbers, got {value!r}") from None
    if a.size != int(np.prod(shape)) or not np.all(np.isfinite(a)):
        raise InputError(f"{what} must be {' × '.join(map(str, shape))} finite numbers, got {a.tolist()}")
    return a.reshape(shape)


# --- several braces -------------------------------------------------------------------------------------------


def braces_residual(state: MultiBracedState, anchors: Sequence[tuple[Array, Array]]) -> Array:
    """Violation of every contact (c,): X_iᵀ [b_i − b0_i; log3(R_b_i R_b0_iᵀ)] per brace, stacked in brace order.

    Each brace's rows are :func:`contact_residual` of that brace: for a point contact on a plane the
    frictionless rows are n̂ᵀ(b_i − b0_i), the distance of {b_i} from the plane through its anchor b0_i.
    """
    out = []
    for brace, b, r_b, (b0, r0) in zip(state.braced.braces, state.b_i, state.R_b_i, anchors, strict=True):
        out.append(brace.X().T @ np.concatenate([b - b0, pin.log3(r_b @ r0.T)]))
    return np.concatenate(out)


def braces_jacobian(state: MultiBracedState, anchors: Sequence[tuple[Array, Array]]) -> Array:
    """∂(braces_residual)/∂q (c×n): :func:`contact_jacobian` of each brace (exact Jlog3 on moment rows)."""
    out = []
    for brace, j_b, r_b, (_, r0) in zip(state.braced.braces, state.J_b_i, state.R_b_i, anchors, strict=True):
        x = brace.X()
        if not np.any(x[3:]):
            out.append(x.T @ j_b)
            continue
        r = r_b @ r0.T
        out.append(x[:3].T @ j_b[:3] + x[3:].T @ (pin.Jlog3(r) @ r.T @ j_b[3:]))
    return np.vstack(out)


def correct_braces(
    braced: BracedRobot,
    q: Array,
    position: Array,
    rotation: Array,
    anchors: Sequence[tuple[Array, Array]] | None,
    *,
    tol: float = CORRECTION_TOL,
    max_iter: int = 20,
    length: float | None = None,
    space: TaskSpace = POSE,
) -> MultiBracedState:
    """:func:`correct` for several braces: the stacked state nearest q on the task rows and on every contact.

    The residual stacks the task rows (as :func:`correct`) and each brace's :func:`braces_residual` rows
    against its anchor (b0_i, ⁰R_b0_i), scaled as :func:`correct` scales one brace's rows; the step is the
    minimum-norm Gauss–Newton step (least squares, so dependent contact rows are harmless).
    """
    scale_len = reach(braced.robot) if length is None else float(length)
    scale = np.array([scale_len] * 3 + [1.0] * (space.rows - 3))
    if anchors is not None:
        for brace in braced.braces:
            x = brace.X()
            scale = np.concatenate([scale, scale_len * np.linalg.norm(x[:3], axis=0) + np.linalg.norm(x[3:], axis=0)])
    roundoff = CORRECTION_ROUNDOFF * np.finfo(float).eps * np.sqrt(braced.n)
    previous = np.inf
    for _ in range(max_iter):
        st = braced.stacked_state(q)
        if space.is_pose:
            res, rows = pose_error(st, position, rotation), st.J_e  # type: ignore[arg-type]
        else:
            sel = space.selection(st.R_e)
            res, rows = sel @ space.error(position - st.e, st.R_e, rotation), sel @ st.J_e
        if anchors is not None:
            res = np.concatenate([res, -braces_residual(st, anchors)])
            rows = np.vstack([rows, braces_jacobian(st, anchors)])
        size = float(np.max(np.abs(res) / scale))
        floor = roundoff * max(1.0, float(np.max(np.abs(st.q)))) * float(np.linalg.norm(rows / scale[:, None]))
        if size < max(tol, floor) or (size < ACCEPT_TOL and size > 0.5 * previous):
            return st
        previous = size
        q = q + np.linalg.lstsq(rows, res, rcond=None)[0]
    raise ConvergenceError(
        f"the pose/contact correction of {len(braced.braces)} braces did not converge in {max_iter} iterations "
        f"(residual {size:.2e} of the robot's reach {scale_len:.3g} m and of 1 rad); reduce the time step or move "
        "away from singularities"
    )


def measure_braces(
    state: MultiBracedState,
    beta_x: Array,
    task_error: float,
    space: TaskSpace = POSE,
    joint_step: float = 0.0,
) -> dict[str, float]:
    """The measures of a sample with several braces (the counterpart of :func:`measure`).

    ``Ci_constrained`` of the stacked C_e and ``Ci_free``; Πσ, σ_min and k of J_e N (the several-brace
    counterpart of J̃; k needs n − rank G ≥ 6); per brace i ``region_radius_<i>`` = ‖b_i − surface_i.point‖,
    ``contact_violation_<i>`` = |distance of b_i from its plane|, ``surface_distance_<i>`` (signed) and
    ``theta_z_<i>`` (∠(n̂_i, ẑ_b_i)), with their max (min for the distance) under the one-brace names;
    σ_min/σ_max of G's independent rows, of S J_e N and of J_e (``sigma_ratio_G``, ``_SJN``, ``_J``).
    There is no ``Ci_projection`` (undefined for several braces) and ``link_clearance`` is inf (no obstacle
    model for several surfaces yet).
    """
    braces = state.braced.braces
    jn = state.braced_jacobian
    sv = singular_value_measures(jn)
    lower, upper = state.braced.robot.lower, state.braced.robot.upper
    out = {
        "Ci_free": compliance_index(free_space_compliance(state), beta_x),
        "Ci_constrained": compliance_index(stacked_compliance(state), beta_x),
        "prod_sigma_t": sv.prod_sigma_t,
        "prod_sigma_o": sv.prod_sigma_o,
        "sigma_t_min": sv.sigma_t_min,
        "sigma_o_min": sv.sigma_o_min,
        "k": frobenius_condition(jn),
        "k_free": frobenius_condition(state.J_e),
        "joint_limit_violation": float(np.max(np.maximum(0.0, np.maximum(lower - state.q, state.q - upper)))),
        "task_error": task_error,
        "joint_step": joint_step,
        "link_clearance": np.inf,
    }
    for i, (brace, b, r_b) in enumerate(zip(braces, state.b_i, state.R_b_i, strict=True)):
        surface = brace.surface
        if brace.pad_axis:  # θ_z exists only where {b_i}'s z is a pad direction
            out[f"theta_z_{i}"] = angle_between(surface.normal, r_b[:, 2])
        out[f"region_radius_{i}"] = float(np.linalg.norm(b - surface.point))
        out[f"surface_distance_{i}"] = surface.signed_distance(b)
        out[f"contact_violation_{i}"] = abs(out[f"surface_distance_{i}"])
    count = range(len(braces))
    out["theta_z"] = max((out[f"theta_z_{i}"] for i in count if f"theta_z_{i}" in out), default=0.0)
    out["region_radius"] = max(out[f"region_radius_{i}"] for i in count)
    out["contact_violation"] = max(out[f"contact_violation_{i}"] for i in count)
    out["surface_distance"] = min(out[f"surface_distance_{i}"] for i in count)
    for key, ratio in sigma_ratios(state, space).items():
        out[f"sigma_ratio_{key}"] = ratio
    out["sigma_ratio_J"] = singular_ratio(state.J_e)
    return out


def _braces_outside(braced: BracedRobot, state: MultiBracedState) -> list[int]:
    """The braces (0-based) whose {b_i} is at or beyond its region radius r_max_i."""
    return [
        i
        for i, (brace, b) in enumerate(zip(braced.braces, state.b_i, strict=True))
        if brace.region_radius is not None and np.linalg.norm(b - brace.surface.point) >= brace.region_radius
    ]


def _check_braces_conditioning(row: dict[str, float], keys: tuple[str, ...]) -> None:
    """SingularityError if σ_min/σ_max of a matrix in `keys` (G, SJN or J) is below PATH_SINGULAR_RATIO."""
    labels = {**MULTI_MATRIX_LABELS, "J": "J"}
    low = [key for key in keys if row[f"sigma_ratio_{key}"] < PATH_SINGULAR_RATIO]
    if low:
        key = min(low, key=lambda k: row[f"sigma_ratio_{k}"])
        raise SingularityError(
            f"{labels[key]} is singular on the path (σ_min/σ_max = {row[f'sigma_ratio_{key}']:.1e} "
            f"< {PATH_SINGULAR_RATIO:g})"
        )


def _simulate_braces(
    braced: BracedRobot,
    strategy: Strategy,
    task: Task,
    q0: ArrayLike,
    dt: float,
    steps: int,
    beta_x: Callable[[float], Array],
    feedback_gain: float,
    progress: Callable[[int], None] | None,
) -> Trajectory:
    """:func:`simulate` with several braces: q̇ over the braced motions N, every contact corrected.

    The steps, the correction (:func:`correct_braces`), the joint-limit scaling of gradient projection, the
    region substeps (any brace with a region, when the objective weighs d) and the singularity checks (σ_min /
    σ_max of G's independent rows and of S J_e N, or of J_e in free space) are those of the one-brace run.
    """
    if strategy.braced and not isinstance(strategy, BracedMinNorm | BracedGradientProjection | BracedQP):
        raise InputError(
            f"strategy {strategy.name!r} has no several-brace form: use BracedMinNorm, BracedGradientProjection "
            "or BracedQP"
        )
    space = getattr(strategy, "space", POSE)
    if not isinstance(space, TaskSpace):
        raise InputError(f"the strategy's space must be a TaskSpace, got {space!r}")
    st = braced.stacked_state(q0)
    rotation = task.rotation if task.rotation is not None else st.R_e.copy()
    jn = st.braced_jacobian if strategy.braced else st.J_e
    free_dims = redundancy(space, st.R_e, jn)
    anchors = [(b.copy(), r.copy()) for b, r in zip(st.b_i, st.R_b_i, strict=True)] if strategy.braced else None
    objective = getattr(strategy, "objective", None)
    left_out = MultiBraceObjective.from_objective(objective).left_out(objective) if objective is not None else ()
    guard = (
        objective is not None
        and MultiBraceObjective.from_objective(objective).region_weight > 0
        and any(b.region_radius is not None for b in braced.braces)
    )
    length = reach(braced.robot)
    bound = joint_step_bound(braced.robot, dt)
    checked = ("G", "SJN") if strategy.braced else ("J",)
    scalable = isinstance(strategy, BracedGradientProjection)
    substeps = 0
    limited = 0

    def rate(st: MultiBracedState, t: float, xdot: Array, scale: float = 1.0) -> Array:
        current = with_beta_x(strategy if scale == 1.0 else _scaled_alpha(strategy, scale), beta_x(t))
        return current.velocity(st, xdot)  # type: ignore[arg-type]

    def advance(st: MultiBracedState, t: float, h: float, depth: int = 0) -> MultiBracedState:
        nonlocal substeps, limited
        err = task_error(st, task.position(t), rotation, space)  # type: ignore[arg-type]
        xdot = np.concatenate([task.velocity(t), np.zeros(3)]) + feedback_gain * err
        qdot = rate(st, t, xdot)
        goal = task.position(t + h)
        new = correct_braces(braced, st.q + qdot * h, goal, rotation, anchors, length=length, space=space)
        if _outside_limits(braced.robot, new.q).size:
            for scale in LIMIT_SCALES if scalable else ():
                qdot = rate(st, t, xdot, scale)
                new = correct_braces(braced, st.q + qdot * h, goal, rotation, anchors, length=length, space=space)
                if not _outside_limits(braced.robot, new.q).size:
                    limited += 1
                    break
            else:
                raise _limit_failure(braced.robot, new.q, t + h, scalable)
        outside = _braces_outside(braced, new) if guard else []
        if outside:
            if depth >= MAX_SUBSTEP_DEPTH:
                raise BarrierError(
                    f"the bracing point of braces[{outside[0]}] leaves its region even with steps of {h:.3g} s; "
                    "reduce dt or raise the region weight"
                )
            substeps += 1
            mid = advance(st, t, h / 2, depth + 1)
            return advance(mid, t + h / 2, h / 2, depth + 1)
        return new

    def sample(st: MultiBracedState, t: float, joint_step: float = 0.0) -> dict[str, float]:
        return measure_braces(st, beta_x(t), float(np.linalg.norm(task.position(t) - st.e)), space, joint_step)

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", UnloadedContactWarning)
        warnings.simplefilter("always", RedundantContactWarning)
        try:
            rows = [sample(st, 0.0)]
        except NumericalError as exc:
            raise type(exc)(f"the start of {strategy.name} (t = 0.000 s) cannot be measured: {exc}") from exc
        ts, qs = [0.0], [st.q.copy()]
        failure = None
        try:
            _check_braces_conditioning(rows[0], checked)
        except SingularityError as exc:
            failure = f"start (t = 0.000 s): {exc}"
        for i in range(steps if failure is None else 0):
            t, t_next = i * dt, (i + 1) * dt
            try:
                before = st.q
                st = advance(st, t, dt)
                step = np.abs(st.q - before)
                if np.any(step > bound):
                    raise _jump_failure_braces(braced, before, st.q, bound, dt, checked, space, rows[0])
                row = sample(st, t_next, float(np.max(step)))
                _check_braces_conditioning(row, checked)
                rows.append(row)
            except BracekitError as exc:
                failure = f"step {i + 1} (t = {t_next:.3f} s): {exc}"
                break
            ts.append(t_next)
            qs.append(st.q.copy())
            if progress is not None:
                progress(1)
    measures = {key: np.array([r[key] for r in rows]) for key in rows[0]}
    notes = []
    for category in (UnloadedContactWarning, RedundantContactWarning):
        found = [w for w in caught if issubclass(w.category, category)]
        if found:
            notes.append(f"{strategy.name}: at {len(found)} evaluation(s) {found[0].message}")
            warnings.warn(notes[-1], category, stacklevel=3)
    for w in caught:  # pass on anything else unchanged
        if not issubclass(w.category, UnloadedContactWarning | RedundantContactWarning):
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    if left_out:
        notes.append(
            f"{strategy.name}: the objective terms {', '.join(left_out)} have no several-brace form yet and are "
            "left out (the objective is C_i of the stacked C_e and each brace's region barrier d_i)"
        )
    limit = float(measures["joint_limit_violation"][0])
    if limit > 0:
        notes.append(f"{strategy.name}: the start exceeds the joint limits by {limit:.3g} rad")
        warnings.warn(notes[-1], JointLimitWarning, stacklevel=3)
    if limited:
        notes.append(
            f"{strategy.name}: {limited} step(s) had their null-space motion scaled down to keep the joints inside "
            "their limits"
        )
    if substeps:
        notes.append(f"{strategy.name}: {substeps} step(s) were split to keep the bracing points in their regions")
    if free_dims == 0 and isinstance(strategy, BracedGradientProjection):
        notes.append(
            f"{strategy.name}: the task space '{space.kind}' leaves no redundancy with these braces: gradient "
            "projection cannot act and equals braced minimum norm"
        )
        warnings.warn(notes[-1], NoRedundancyWarning, stacklevel=3)
    per_brace = []
    for i, brace in enumerate(braced.braces):
        radius = float(np.max(measures[f"region_radius_{i}"]))
        per_brace.append(
            {
                "max_contact_violation_m": float(np.max(measures[f"contact_violation_{i}"])),
                "max_region_radius_m": radius,
            }
        )
        if brace.region_radius is not None and radius >= brace.region_radius:
            notes.append(
                f"{strategy.name}: the bracing point of braces[{i}] left its bracing region "
                f"(max r = {radius:.4f} m > r_max = {brace.region_radius:.4f} m)"
            )
            warnings.warn(notes[-1], RegionWarning, stacklevel=3)
    return Trajectory(
        strategy=strategy.name,
        braced=strategy.braced,
        t=np.array(ts),
        q=np.array(qs),
        measures=measures,
        completed=failure is None,
        failure=failure,
        warnings=notes,
        substeps=substeps,
        task_space=space.describe(),
        redundancy=free_dims,
        braces=per_brace,
    )


def _jump_failure_braces(
    braced: BracedRobot,
    before: Array,
    after: Array,
    bound: Array,
    dt: float,
    keys: tuple[str, ...],
    space: TaskSpace,
    start: dict[str, float],
) -> NumericalError:
    """:func:`_jump_failure` for several braces: the joints that jumped, and the singularity between them.

    A singularity of G, S J_e N or J_e (σ_min/σ_max at JUMP_PROBES configurations between the samples).
    """
    step = np.abs(after - before)
    over = np.flatnonzero(step > bound)
    message = (
        f"joint(s) {', '.join(str(j + 1) for j in over)} moved {np.max(step[over]):.3g} rad in one {dt:.3g} s step "
        f"(bound {float(np.min(bound[over])):.3g})"
    )
    ratios = dict.fromkeys(keys, np.inf)
    for s in np.linspace(0.0, 1.0, JUMP_PROBES):
        probe = braced.stacked_state(before + s * (after - before))
        found = {**sigma_ratios(probe, space), "J": singular_ratio(probe.J_e)}
        ratios = {key: min(ratios[key], found[key]) for key in keys}
    labels = {**MULTI_MATRIX_LABELS, "J": "J"}
    drop = {key: ratios[key] / max(start[f"sigma_ratio_{key}"], 1e-300) for key in keys}
    near = [key for key in keys if ratios[key] < NEAR_SINGULAR_RATIO or drop[key] < NEAR_SINGULAR_DROP]
    if near:
        key = min(near, key=drop.__getitem__)
        return SingularityError(
            f"{message}; the step passes a singularity of {labels[key]} (σ_min/σ_max down to {ratios[key]:.1e} "
            f"from {start[f'sigma_ratio_{key}']:.1e} at the start)"
        )
    return NumericalError(f"{message}; no singularity between the samples: reduce dt, slow the task or |alpha|")


def solve_start_braces(
    braced: BracedRobot,
    position: ArrayLike,
    guess: ArrayLike,
    *,
    rotation: ArrayLike | None = None,
    region_weight: float = 1.0,
    posture_weight: float = 0.01,
) -> MultiBracedState:
    """A start with several braces: tip at `position` (and `rotation` if given), every {b_i} on its surface.

    SciPy least squares from `guess` (n,) within the joint limits: the tip and each brace's plane distance are
    hard residuals (then polished by :func:`correct_braces` to every plane), ‖b_i − surface_i.point‖ of each
    brace (weight `region_weight`, 1/m) and ‖q − guess‖ (`posture_weight`) soft. ConvergenceError when the
    hard residuals are not met or a brace ends outside its region.
    """
    from scipy.optimize import least_squares

    target = _finite(position, (3,), "the start position (m)")
    rot = None if rotation is None else _finite(rotation, (3, 3), "the start rotation")
    q_guess = braced.robot.check_q(guess)
    lo, hi = braced.robot.lower, braced.robot.upper
    surfaces = [brace.surface for brace in braced.braces]

    def residual(q: Array) -> Array:
        st = braced.stacked_state(q)
        hard = [target - st.e, np.array([s.signed_distance(b) for s, b in zip(surfaces, st.b_i, strict=True)])]
        if rot is not None:
            hard.append(pin.log3(rot @ st.R_e.T))
        soft = [region_weight * (b - s.point) for s, b in zip(surfaces, st.b_i, strict=True)]
        return np.concatenate([1e3 * np.concatenate(hard), *soft, posture_weight * (q - q_guess)])

    sol = least_squares(residual, np.clip(q_guess, lo + 1e-6, hi - 1e-6), bounds=(lo, hi), xtol=1e-12, ftol=1e-12)
    st = braced.stacked_state(sol.x)
    anchors = [(b - s.normal * s.signed_distance(b), r) for s, b, r in zip(surfaces, st.b_i, st.R_b_i, strict=True)]
    try:
        st = correct_braces(braced, st.q, target, rot if rot is not None else st.R_e, anchors)
    except ConvergenceError:
        raise ConvergenceError(
            f"no start configuration puts the tip at {np.round(target, 4).tolist()} m with every brace closed "
            f"(closest: {np.linalg.norm(target - st.e):.3g} m away); move the task or the surfaces, or change the guess"
        ) from None
    outside = _braces_outside(braced, st)
    if outside:
        raise ConvergenceError(
            f"no start configuration with the bracing point of braces[{outside[0]}] inside its region; move its "
            "region centre, the task or the start guess"
        )
    return st
