"""Integrate a redundancy-resolution strategy along a task (Section VI's kinematic simulation).

Each step: tip twist ẋ = feed-forward + pose-error feedback, q̇ from the strategy, an Euler step, then a
Gauss–Newton correction that puts the tip back on the task pose and, for braced strategies, {b} back on
the contact (to 1e-12), so neither error accumulates. Measures are recorded at every sample. A
gradient-projection step that would jump over the region barrier (explicit Euler can) is split in halves,
at most MAX_SUBSTEP_DEPTH times, and counted in ``Trajectory.substeps``.
Gradient projection runs through the fused :class:`bracekit.fast.GradientProjectionStep`, which gives the
strategy's own q̇ to ~1e-13.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike, NDArray

from bracekit._linalg import angle_between
from bracekit.compliance.first_order import (
    COMPLIANCE_MODELS,
    ComplianceModel,
    compliance_index,
    end_effector_compliance,
    free_space_compliance,
)
from bracekit.compliance.measures import frobenius_condition, singular_value_measures
from bracekit.errors import (
    BarrierError,
    BracekitError,
    BracekitWarning,
    ConvergenceError,
    InputError,
    JointLimitWarning,
    RegionWarning,
    UnloadedContactWarning,
)
from bracekit.kinematics import BracedRobot, BracedState
from bracekit.objective import RegionBarrier
from bracekit.resolution.strategies import BracedGradientProjection, Strategy, with_beta_x
from bracekit.simulation.tasks import Task
from bracekit.tolerances import ACCEPT_TOL, CORRECTION_TOL

Array = NDArray[np.float64]

#: Evaluations the start solve may take.
START_MAX_NFEV = 2000
#: A gradient-projection step that jumps out of the bracing region is halved at most this many times.
MAX_SUBSTEP_DEPTH = 4


def _has_region_term(strategy: Strategy) -> bool:
    objective = getattr(strategy, "objective", None)
    return objective is not None and any(
        isinstance(t, RegionBarrier) and w > 0 for t, w in zip(objective.terms, objective.weights, strict=True)
    )


def pose_error(state: BracedState, position: Array, rotation: Array) -> Array:
    """[p_d − e; log3(R_d R_eᵀ)] (6,), m and rad, world axes."""
    return np.concatenate([position - state.e, pin.log3(rotation @ state.R_e.T)])


def contact_residual(state: BracedState, anchor: Array, anchor_rotation: Array) -> Array:
    """Violation of the contact along each constraint wrench (6 − l,): Xᵀ [b − b0; log3(R_b R_b0ᵀ)].

    For the frictionless point this is n̂ᵀ(b − b0), the distance of {b} from the plane through b0.
    """
    return state.X.T @ np.concatenate([state.b - anchor, pin.log3(state.R_b @ anchor_rotation.T)])


def correct(
    braced: BracedRobot,
    q: Array,
    position: Array,
    rotation: Array,
    anchor: tuple[Array, Array] | None,
    *,
    tol: float = CORRECTION_TOL,
    max_iter: int = 20,
) -> BracedState:
    """Minimum-norm Gauss–Newton: the state nearest q with the tip at the pose (and {b} on the contact).

    Stops at a residual below `tol`, or when it stops falling below ACCEPT_TOL (round-off); raises
    ConvergenceError otherwise.
    """
    previous = np.inf
    for _ in range(max_iter):
        st = braced.state(q)
        res = pose_error(st, position, rotation)
        rows = st.J_e
        if anchor is not None:
            res = np.concatenate([res, -contact_residual(st, *anchor)])
            rows = np.vstack([rows, st.X.T @ st.J_b])
        size = float(np.max(np.abs(res)))
        if size < tol or (size < ACCEPT_TOL and size > 0.5 * previous):
            return st
        previous = size
        q = q + rows.T @ np.linalg.lstsq(rows @ rows.T, res, rcond=None)[0]
    raise ConvergenceError(
        f"the pose/contact correction did not converge in {max_iter} iterations "
        f"(residual {size:.2e}); reduce the time step or move away from singularities"
    )


@dataclass
class Trajectory:
    """One strategy's run: samples at times t (N,), joint values q (N×n) and named measures (N,)."""

    strategy: str
    braced: bool
    t: Array
    q: Array
    measures: dict[str, Array]
    completed: bool
    failure: str | None = None
    warnings: list[str] = field(default_factory=list)
    substeps: int = 0

    @property
    def steps(self) -> int:
        """Steps taken (samples − 1)."""
        return int(self.t.size - 1)

    def ci_key(self, model: ComplianceModel) -> str:
        """The C_i series of this run: free-space compliance for the unbraced run, else C_e of `model`."""
        return f"Ci_{model}" if self.braced else "Ci_free"

    def summary(self, model: ComplianceModel = "constrained") -> dict[str, Any]:
        """The Table I metrics and run checks (SI units)."""
        m = self.measures
        ci = m[self.ci_key(model)]
        return {
            "Ci_mean": float(np.mean(ci)),
            "Ci_min": float(np.min(ci)),
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
            "steps": self.steps,
            "substeps": self.substeps,
            "completed": self.completed,
            "failure": self.failure,
        }


def measure(state: BracedState, beta_x: Array, centre: Array, task_error: float, braced: bool) -> dict[str, float]:
    """The measures recorded at a sample (C_i in all models, J̃ singular values, k, θ_z, r, limits)."""
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
    }
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

    A step that meets a singularity, a barrier or a failed correction ends the run with
    ``completed=False`` and the reason in ``failure``. `beta_x(t)` gives the unit twist (6,) along which
    the compliance index is measured (and minimised by a gradient-projection strategy).
    """
    if not (np.isfinite(dt) and dt > 0):
        raise InputError(f"time step dt must be a positive number of seconds, got {dt}")
    steps = max(1, round(task.duration / dt))
    dt = task.duration / steps  # the last sample lands on the task's end
    st = braced.state(q0)
    rotation = task.rotation if task.rotation is not None else st.R_e.copy()
    anchor = (st.b.copy(), st.R_b.copy()) if strategy.braced else None
    centre = braced.brace.surface.point
    r_max = braced.brace.region_radius
    fast = None
    if type(strategy) is BracedGradientProjection:
        from bracekit.resolution.fused import GradientProjectionStep

        fast = GradientProjectionStep(braced, strategy)
    guard = r_max is not None and _has_region_term(strategy)
    substeps = 0

    def advance(st: BracedState, t: float, h: float, depth: int = 0) -> BracedState:
        """One Euler step of length h from t, corrected; halved (up to 1/16) if it jumps out of the region."""
        nonlocal substeps
        err = pose_error(st, task.position(t), rotation)
        xdot = np.concatenate([task.velocity(t), np.zeros(3)]) + feedback_gain * err
        if fast is not None:  # the fused step: the same q̇ as the strategy's, to ~1e-13
            qdot = fast(st.q, xdot, beta_x(t))
        else:
            current = with_beta_x(strategy, beta_x(t))
            if strategy.needs_hessians:
                st = braced.state(st.q, hessians=True)
            qdot = current.velocity(st, xdot)
        new = correct(braced, st.q + qdot * h, task.position(t + h), rotation, anchor)
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

    ts, qs, rows = [0.0], [st.q.copy()], [measure(st, beta_x(0.0), centre, 0.0, strategy.braced)]
    failure = None
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", UnloadedContactWarning)
        for i in range(steps):
            t, t_next = i * dt, (i + 1) * dt
            try:
                st = advance(st, t, dt)
                task_err = float(np.linalg.norm(task.position(t_next) - st.e))
                rows.append(measure(st, beta_x(t_next), centre, task_err, strategy.braced))
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
    limit = float(np.max(measures["joint_limit_violation"]))
    if limit > 0:
        notes.append(f"{strategy.name}: joint limits exceeded by up to {limit:.3g} rad (limits are not enforced)")
        warnings.warn(notes[-1], JointLimitWarning, stacklevel=2)
    inside = measures["region_radius"] < (r_max if r_max is not None else np.inf)
    depth = float(np.min(measures["surface_distance"], initial=0.0, where=inside))
    if depth < -1e-6:
        notes.append(
            f"{strategy.name}: the bracing point passes {-depth:.3g} m below the bracing surface inside the region "
            "(this run ignores the surface)"
        )
    if substeps:
        notes.append(f"{strategy.name}: {substeps} step(s) were split to keep the bracing point in the region")
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
    )


def solve_start(
    braced: BracedRobot,
    position: ArrayLike,
    guess: ArrayLike,
    *,
    rotation: ArrayLike | None = None,
    region_weight: float = 1.0,
    theta_weight: float = 0.3,
    posture_weight: float = 0.01,
) -> BracedState:
    """A start configuration: tip at `position` (and `rotation` if given), {b} on the surface.

    Solved from `guess` (n,) by SciPy least squares: the tip pose and the contact are hard residuals
    (then polished to 1e-12 by Gauss–Newton), while the distance of {b} from the region centre, θ_z and
    the distance from the guess are soft. Raises ConvergenceError if the hard residuals are not met or
    {b} ends outside the bracing region.
    """
    from scipy.optimize import least_squares

    target = np.asarray(position, dtype=float).reshape(3)
    rot = None if rotation is None else np.asarray(rotation, dtype=float).reshape(3, 3)
    q_guess = braced.robot.check_q(guess)
    surface = braced.brace.surface
    lo, hi = braced.robot.lower, braced.robot.upper

    x_t, y_t = surface.frame[:, 0], surface.frame[:, 1]

    def residual(q: Array) -> Array:
        st = braced.state(q)
        hard = [target - st.e, [surface.signed_distance(st.b)]]
        if rot is not None:
            hard.append(pin.log3(rot @ st.R_e.T))
        # ẑ_b's tangential components: ≈ θ_z for small angles and smooth at 0, unlike θ_z itself
        soft = [
            region_weight * (st.b - surface.point),
            theta_weight * np.array([x_t @ st.z_b, y_t @ st.z_b]),
            posture_weight * (q - q_guess),
        ]
        return np.concatenate([1e3 * np.concatenate(hard), np.concatenate(soft)])

    def jacobian(q: Array) -> Array:
        st = braced.state(q)
        hard = [-st.J_e[:3], surface.normal @ st.J_b[:3]]
        if rot is not None:
            hard.append(-st.J_e[3:])  # first-order (exact at the solution)
        soft = [
            region_weight * st.J_b[:3],
            theta_weight * np.vstack([np.cross(st.z_b, x_t) @ st.J_b[3:], np.cross(st.z_b, y_t) @ st.J_b[3:]]),
            posture_weight * np.eye(q.size),
        ]
        return np.vstack([1e3 * np.vstack(hard), np.vstack(soft)])

    x0 = np.clip(q_guess, lo + 1e-6, hi - 1e-6)
    sol = least_squares(
        residual, x0, jac=jacobian, bounds=(lo, hi), xtol=1e-12, ftol=1e-12, gtol=1e-12, max_nfev=START_MAX_NFEV
    )
    if sol.status <= 0:
        warnings.warn(
            f"the start solve stopped after {sol.nfev} evaluations before its soft terms (r, θ_z, distance to the "
            "guess) converged; the start meets the task and the contact but is not their optimum: give a closer guess",
            BracekitWarning,
            stacklevel=2,
        )
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
    return st
