"""Integrate a redundancy-resolution strategy along a task (Section VI's kinematic simulation), any brace count.

Each step: tip twist ẋ = feed-forward + pose-error feedback, q̇ from the strategy (over the state's braced
motions, :mod:`bracekit.kinematics.motions`), an Euler step, then the Gauss–Newton correction that puts the
tip back on the task and, for braced strategies, every {b_i} back on its contact
(:mod:`bracekit.simulation.correction`), so neither error accumulates. A gradient-projection step that would
jump over a region barrier (explicit Euler can) is split in halves, at most MAX_SUBSTEP_DEPTH times, and
counted in ``Trajectory.substeps``. The guards of :mod:`bracekit.simulation.guards` stop a run at a joint
jump, a singular matrix (checked WATCH_BATCH samples at a time, the steps after a singular sample undone) or
a joint limit. Gradient projection runs through the fused :class:`bracekit.resolution.GradientProjectionStep`,
which gives the strategy's own q̇ to ~1e-13: compiled where numba is installed, else in NumPy, which the run's
notes then say; the minimum-norm strategies through :class:`bracekit.resolution.min_norm.MinNormStep` (their
q̇ to ~1e-13 from the state's own Jacobians).

No step leaves the URDF joint limits (by more than JOINT_LIMIT_TOL). A corrected step that would is, for
gradient projection, taken again with its null-space motion scaled by 1/2, 1/4, … (LIMIT_SCALES, the gain α
scaled, down to 0: the minimum-norm step); the first scale whose corrected step keeps every joint inside is
kept, and the run notes how many steps were scaled. If none does, or for a strategy without a null-space part
(the minimum-norm ones), the run stops with ``completed=False`` and a reason naming the joints, their values
and limits and the time (:class:`~bracekit.errors.JointLimitError`). Scaling the null space rather than solving
a QP with the limits as constraints keeps every accepted step a step of the strategy itself (eq:grad_proj with
a smaller α), leaves runs that stay inside their limits bit-identical, needs no solver dependency, and leaves
the task and the contact to the correction as before; a QP would change the resolution everywhere a bound
is near, not only where one is crossed. The joint-limit terms of g are what keep a gradient-projection run
away from its limits; this check is the guarantee behind it.

The measures of every sample (:mod:`bracekit.simulation.samples`) are taken after the steps, from the
states the correction returned, over the whole path at once (:mod:`bracekit.simulation.path_measures`).
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from dataclasses import replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from bracekit._linalg import as_number, show
from bracekit.errors import (
    BarrierError,
    BracekitError,
    InputError,
    NumericalError,
    RedundantContactWarning,
    SingularityError,
    UnloadedContactWarning,
)
from bracekit.kinematics import BracedRobot, BracedState
from bracekit.objective import RegionBarrier
from bracekit.resolution.fused import NO_NUMBA, Backend, GradientProjectionStep, fused_step
from bracekit.resolution.min_norm import min_norm_step
from bracekit.resolution.strategies import BracedGradientProjection, BracedMinNorm, Strategy, with_beta_x
from bracekit.resolution.task_space import POSE, TaskSpace, redundancy
from bracekit.simulation.correction import Correction, norm, reach, task_error
from bracekit.simulation.guards import (
    LIMIT_SCALES,
    MAX_SUBSTEP_DEPTH,
    WATCH_BATCH,
    braces_outside,
    check_conditioning,
    first_singular,
    joint_step_bound,
    jump_failure,
    limit_bounds,
    limit_failure,
    outside_limits,
    point_label,
    sigma_ratios,
    stacked_sigma_ratios,
)
from bracekit.simulation.notes import run_notes
from bracekit.simulation.path_measures import Known, measure_path, path_ratios
from bracekit.simulation.samples import Samples
from bracekit.simulation.stacked_ratios import Decomposed, Watched
from bracekit.simulation.tasks import Task
from bracekit.simulation.trajectory import Trajectory
from bracekit.tolerances import MAX_STEPS

Array = NDArray[np.float64]

__all__ = ["STEP_BACKEND_NOTE", "simulate"]

#: The run's note when the gradient-projection step ran in NumPy because numba cannot be imported (the same q̇
#: to ~1e-13, slower).
STEP_BACKEND_NOTE = (
    "the gradient-projection step ran in NumPy (numba cannot be imported; `pip install bracekit[fast]` gives the "
    "compiled step)"
)


def scaled_alpha(strategy: Strategy, scale: float) -> Strategy:
    """The gradient-projection strategy with α · scale (braced minimum norm in its task space at scale 0)."""
    if scale == 0.0:
        return BracedMinNorm(space=getattr(strategy, "space", POSE))
    return replace(strategy, alpha=float(strategy.alpha) * scale)  # type: ignore[attr-defined, type-var]


def region_guard(braced: BracedRobot, strategy: Strategy) -> bool:
    """Whether a step that leaves a bracing region is split: the objective weighs a region barrier d."""
    objective = getattr(strategy, "objective", None)
    if objective is None or all(b.region_radius is None for b in braced.braces):
        return False
    return any(isinstance(t, RegionBarrier) and w > 0 for t, w in zip(objective.terms, objective.weights, strict=True))


def _check_inputs(
    strategy: Strategy, task: Task, beta_x: Callable[[float], Array], dt: float, progress: object = None
) -> int:
    """The number of steps for `task` at dt; InputError for a strategy, task or β_x that is not one."""
    for name, value, needed in (
        ("strategy", strategy, ("velocity", "braced", "name")),
        ("task", task, ("position", "velocity", "duration")),
    ):
        if any(not hasattr(value, attr) for attr in needed):
            raise InputError(f"{name} must be a bracekit {name.capitalize()}, got {type(value).__name__}")
    if not callable(beta_x):
        raise InputError(f"beta_x must be a function of time returning a unit twist (6,), got {type(beta_x).__name__}")
    if progress is not None and not callable(progress):
        raise InputError(f"progress must be None or a function called with a step count, got {show(progress)}")
    if task.duration / dt > MAX_STEPS:
        raise InputError(
            f"dt = {dt:g} s gives {task.duration / dt:.3g} steps for a {task.duration:g} s task (more than "
            f"{MAX_STEPS}); give a larger dt"
        )
    space = getattr(strategy, "space", POSE)
    if not isinstance(space, TaskSpace):
        raise InputError(f"the strategy's space must be a TaskSpace, got {space!r}")
    return max(1, round(task.duration / dt))


def _known(decomposed: list[tuple[Watched[Decomposed], int]], task_key: str | None) -> Known | None:
    """The guard's stacks of the braced task Jacobian (`task_key`) and J_e over the kept samples.

    None for a matrix a batch did not decompose.
    """
    kept = [(found, count) for found, count in decomposed if count]

    def joined(parts: list[tuple[Decomposed | None, int]]) -> Decomposed | None:
        if not parts or any(d is None for d, _ in parts):
            return None
        done = [(d, c) for d, c in parts if d is not None]
        return Decomposed(np.concatenate([d.stack[:c] for d, c in done]), np.concatenate([d.s[:c] for d, c in done]))

    task = None if task_key is None else joined([(found.get(task_key), count) for found, count in kept])
    return Known(task, joined([(found.J_e, count) for found, count in kept]))


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
    beyond :func:`~bracekit.simulation.guards.joint_step_bound`), a barrier or a failed correction ends the
    run with ``completed=False`` and the reason in ``failure``. `beta_x(t)` gives the unit twist (6,) along
    which the compliance index is measured (and minimised by a gradient-projection strategy).

    The strategy's ``space`` (a :class:`~bracekit.resolution.task_space.TaskSpace`, the pose by default)
    says which rows of the task the run follows and corrects; the others are free. ``redundancy`` of the
    trajectory is the null space those rows leave at the start: (braced coordinates) − rank(S A) for a braced
    strategy, n − rank(S J) in free space. Gradient projection with none warns (NoRedundancyWarning).
    """
    dt = as_number(dt, "the time step dt", positive=True, unit="s")
    feedback_gain = as_number(feedback_gain, "the feedback gain", nonnegative=True, unit="1/s")
    steps = _check_inputs(strategy, task, beta_x, dt, progress)
    dt = task.duration / steps  # the last sample lands on the task's end
    space: TaskSpace = getattr(strategy, "space", POSE)
    st = braced.state(q0)
    rotation = task.rotation if task.rotation is not None else st.R_e.copy()
    free_dims = redundancy(space, st.R_e, st.motions.A if strategy.braced else st.J_e)
    anchors = [(c.b.copy(), c.R_b.copy()) for c in st.contacts] if strategy.braced else None
    checked = st.motions.inverted(strategy.braced)
    # the compiled step where numba is installed (compiled once and cached on disk; the reference's q̇ to
    # ~1e-13), else the NumPy step, which the run's notes then say (STEP_BACKEND_NOTE)
    backend: Backend = "auto"
    fast = fused_step(braced, strategy, backend)
    lean = min_norm_step(braced, strategy)  # the minimum-norm strategies' q̇ from the state's Jacobians
    scaled_steps: dict[float, GradientProjectionStep] = {}
    guard = region_guard(braced, strategy)
    scalable = isinstance(strategy, BracedGradientProjection)
    correct = Correction(braced, rotation, anchors, length=reach(braced.robot), space=space)
    bound = joint_step_bound(braced.robot, dt)
    limits = limit_bounds(braced.robot)
    counts = {"substeps": 0, "limited": 0}
    low, high = limits
    objective = getattr(strategy, "objective", None) is not None
    # p_d(t) and β_x(t), each evaluated once per time: a step and the samples' measures take them at the same t
    positions: dict[float, Array] = {}
    betas: dict[float, Array] = {}

    def position(t: float) -> Array:
        found = positions.get(t)
        if found is None:
            found = positions[t] = task.position(t)
        return found

    def beta(t: float) -> Array:
        found = betas.get(t)
        if found is None:
            found = betas[t] = beta_x(t)
        return found

    def rate(st: BracedState, t: float, xdot: Array, scale: float = 1.0) -> Array:
        """Q̇ of the strategy at st, with its null-space motion scaled by `scale` (gradient projection only)."""
        if fast is not None and scale > 0.0:  # the fused step: the same q̇ as the strategy's, to ~1e-13
            if scale == 1.0:  # on the correction's pass where st is the state it returned
                return fast(st.q, xdot, beta(t), correct.last_pass(st.q))
            if scale not in scaled_steps:
                scaled_steps[scale] = GradientProjectionStep(braced, scaled_alpha(strategy, scale), backend)  # type: ignore[arg-type]
            return scaled_steps[scale](st.q, xdot, beta(t))
        if lean is not None:
            return lean(st, xdot)
        current = strategy if scale == 1.0 else scaled_alpha(strategy, scale)
        if objective:
            current = with_beta_x(current, beta(t))
        if current.needs_hessians:
            st = braced.state(st.q, hessians=True)
        return current.velocity(st, xdot)

    def advance(st: BracedState, t: float, h: float, depth: int = 0) -> BracedState:
        """One Euler step of length h from t, corrected; halved (up to 1/16) if it jumps out of a region.

        A step that leaves the joint limits is retried with the null-space motion scaled (LIMIT_SCALES) or
        ends the run (JointLimitError).
        """
        err = task_error(st, position(t), rotation, space)
        xdot = np.concatenate([task.velocity(t), np.zeros(3)]) + feedback_gain * err
        goal = position(t + h)
        new = correct(st.q + rate(st, t, xdot) * h, goal)
        if ((new.q < low) | (new.q > high)).any():  # outside_limits(…).size, without its index array
            for scale in LIMIT_SCALES if scalable else ():
                qdot = rate(st, t, xdot, scale)
                new = correct(st.q + qdot * h, goal)
                if not outside_limits(braced.robot, new.q, limits).size:
                    counts["limited"] += 1
                    break
            else:
                raise limit_failure(braced.robot, new.q, t + h, scalable)
        outside = braces_outside(braced, new) if guard else []
        if outside:
            if depth >= MAX_SUBSTEP_DEPTH:
                i = outside[0]
                brace = braced.braces[i]
                r = float(np.linalg.norm(new.b_i[i] - brace.surface.point))
                raise BarrierError(
                    f"{point_label(braced, i)} leaves {'the' if len(braced.braces) == 1 else 'its'} region "
                    f"(r = {r:.4g} m ≥ r_max) even with steps of {h:.3g} s; reduce dt or raise the region weight"
                )
            counts["substeps"] += 1
            mid = advance(st, t, h / 2, depth + 1)
            return advance(mid, t + h / 2, h / 2, depth + 1)
        return new

    def samples_of(
        states: list[BracedState],
        first: int,
        ratios: list[dict[str, float]],
        jumps: list[float],
        known: Known | None = None,
    ) -> tuple[Samples | None, int, BracekitError | None]:
        times = [(first + i) * dt for i in range(len(states))]
        errors = [norm(position(t) - st.e) for t, st in zip(times, states, strict=True)]
        return measure_path(braced, states, [beta(t) for t in times], errors, ratios, jumps, known)

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", UnloadedContactWarning)
        warnings.simplefilter("always", RedundantContactWarning)
        ratios = sigma_ratios(st, space)
        head, _, refused = samples_of([st], 0, [ratios], [0.0])
        if refused is not None:  # nothing can be recorded at a start the measures cannot take
            if not isinstance(refused, NumericalError):
                raise refused
            raise type(refused)(
                f"the start of {strategy.name} (t = 0.000 s) cannot be measured: {refused}"
            ) from refused
        start = ratios
        states, ratio_rows, jumps = [st], [ratios], [0.0]
        failure = None
        try:
            check_conditioning(ratios, checked)
        except SingularityError as exc:
            failure = f"start (t = 0.000 s): {exc}"
        # the steps' σ-ratio guard, WATCH_BATCH samples at a time, with every ratio a sample records (the measures
        # need them all): (state, joint step, warnings and counts after it)
        recorded = tuple(start)
        pending: list[tuple[BracedState, float, int, dict[str, int]]] = []
        # the stacks the guard decomposed, with the samples kept of each batch: the measures' k and k_free
        task_key = st.motions.task_key(space.is_pose)
        decomposed: list[tuple[Watched[Decomposed], int]] = []

        def one_by_one() -> tuple[list[dict[str, float]], tuple[int, BracekitError] | None]:
            """The pending samples' ratios up to the first that fails its check (a matrix the guard cannot form)."""
            found: list[dict[str, float]] = []
            for k, (state, *_) in enumerate(pending):
                try:
                    ratios = sigma_ratios(state, space, checked)
                    check_conditioning(ratios, checked)
                except BracekitError as exc:
                    return found, (k, exc)
                rest = tuple(key for key in recorded if key not in ratios)  # raise here as after the run
                found.append({**ratios, **sigma_ratios(state, space, rest)})
            return found, None

        def settle() -> str | None:
            """Guard the pending steps: keep them up to the first singular one, whose failure it returns.

            The steps after a singular one are undone: their states, warnings and counts are dropped, so the
            run is the one a guard after every step gives.
            """
            stacks: Watched[Decomposed] = Watched()
            try:
                found, stacks = stacked_sigma_ratios([p[0] for p in pending], space, recorded)
                bad: tuple[int, BracekitError] | None = first_singular(found, checked)
            except (BracekitError, np.linalg.LinAlgError):  # a matrix not formed or decomposed: sample by sample
                found, bad = one_by_one()
                stacks = Watched()
            kept = len(pending) if bad is None else bad[0]
            decomposed.append((stacks, kept))
            for (state, jump, _, _), row in zip(pending[:kept], found[:kept], strict=True):
                states.append(state)
                ratio_rows.append(row)
                jumps.append(jump)
                if progress is not None:
                    progress(1)
            if bad is None:
                pending.clear()
                return None
            _, _, mark, after = pending[bad[0]]
            del caught[mark:]
            counts.update(after)
            pending.clear()
            step = len(states)
            return f"step {step} (t = {step * dt:.3f} s): {bad[1]}"

        for i in range(steps if failure is None else 0):
            t_next = (i + 1) * dt
            try:
                before = st.q
                st = advance(st, i * dt, dt)
                step = np.abs(st.q - before)
                if (step > bound).any():
                    gain = getattr(strategy, "objective", None) is not None
                    raise jump_failure(braced, space, checked, before, st.q, bound, dt, start, gain)
            except BracekitError as exc:
                failure = settle() or f"step {i + 1} (t = {t_next:.3f} s): {exc}"
                break
            except Exception:  # from a step after a sample not yet guarded: that sample's singularity first
                failure = settle()
                if failure is None:
                    raise
                break
            pending.append((st, float(step.max()), len(caught), dict(counts)))
            if len(pending) == WATCH_BATCH:
                failure = settle()
                if failure is not None:
                    break
        if failure is None:
            failure = settle()
        # the measures, from the corrected states, all at once; the run stops at the first it cannot measure
        ratio_rows[1:] = path_ratios(states[1:], space, tuple(start), ratio_rows[1:])
        tail, count, refused = samples_of(states[1:], 1, ratio_rows[1:], jumps[1:], _known(decomposed, task_key))
        if refused is not None:
            i = count + 1
            failure = f"step {i} (t = {i * dt:.3f} s): {refused}"
            states = states[:i]
    assert head is not None
    samples = head if tail is None else Samples.concat([head, tail])
    notes, per_brace = run_notes(braced, strategy, samples, caught, counts, free_dims, space)
    if fast is not None and fast.fallback_reason == NO_NUMBA:
        notes.append(f"{strategy.name}: {STEP_BACKEND_NOTE}")
    return Trajectory(
        strategy=strategy.name,
        braced=strategy.braced,
        t=np.arange(len(states), dtype=np.float64) * dt,
        q=np.array([s.q for s in states]),
        measures=samples.as_dict(),
        completed=failure is None,
        failure=failure,
        warnings=notes,
        substeps=counts["substeps"],
        task_space=space.describe(),
        redundancy=free_dims,
        braces=per_brace,
        samples=samples,
    )
