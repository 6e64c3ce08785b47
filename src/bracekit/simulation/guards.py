"""What stops a run: joint limits, joint jumps, singular matrices and the bracing regions, for any brace count.

A run never passes a singularity silently. It stops when a joint moves more between two samples than
JOINT_STEP_SAFETY × its URDF velocity limit × dt (at most MAX_JOINT_STEP; DEFAULT_JOINT_SPEED where the URDF
gives no limit), or when σ_min/σ_max of a matrix the strategy inverts falls below PATH_SINGULAR_RATIO: J in
free space; with one brace A, J1 when n1 = 6, and J̃; with several the stacked constraint G and S J_e N
(:meth:`bracekit.kinematics.motions.BracedMotions.inverted`). No step leaves the URDF joint limits by more
than JOINT_LIMIT_TOL. The σ-ratios of the steps are taken WATCH_BATCH samples at a time
(:mod:`bracekit.simulation.stacked_ratios`): a run stops at the first singular sample of a batch and undoes
the steps after it, so it stops where a check after every step stops it.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from bracekit.errors import JointLimitError, NumericalError, SingularityError
from bracekit.kinematics import BracedRobot, BracedState
from bracekit.kinematics.motions import MATRIX_LABELS
from bracekit.model.robot import Robot
from bracekit.resolution.task_space import TaskSpace
from bracekit.simulation.correction import norm
from bracekit.simulation.stacked_ratios import Conditioning, stacked_conditioning
from bracekit.tolerances import (
    DEFAULT_JOINT_SPEED,
    JOINT_STEP_SAFETY,
    MAX_JOINT_STEP,
    NEAR_SINGULAR_DROP,
    NEAR_SINGULAR_RATIO,
    PATH_SINGULAR_RATIO,
)

Array = NDArray[np.float64]

#: A gradient-projection step that jumps out of a bracing region is halved at most this many times.
MAX_SUBSTEP_DEPTH = 4
#: Configurations on the straight joint path between two samples at which a joint jump is diagnosed.
JUMP_PROBES = 17
#: How far (rad, m for a prismatic joint) a corrected step may leave a joint's URDF range (the correction's round-off).
JOINT_LIMIT_TOL = 1e-9
#: Samples whose σ-ratio guard a run takes at once (one stacked SVD per matrix); a singular one undoes the later ones.
WATCH_BATCH = 64
#: The scales of the null-space motion a gradient-projection step that leaves the joint limits is retried with.
LIMIT_SCALES = (0.5, 0.25, 0.125, 0.0625, 0.0)

__all__ = [
    "JOINT_LIMIT_TOL",
    "JUMP_PROBES",
    "LIMIT_SCALES",
    "MAX_SUBSTEP_DEPTH",
    "WATCH_BATCH",
    "braces_outside",
    "check_conditioning",
    "first_singular",
    "joint_speeds",
    "joint_step_bound",
    "jump_failure",
    "limit_bounds",
    "limit_failure",
    "outside_limits",
    "point_label",
    "sigma_ratios",
    "stacked_sigma_ratios",
]


def limit_bounds(robot: Robot) -> tuple[Array, Array]:
    """(q_min − JOINT_LIMIT_TOL, q_max + JOINT_LIMIT_TOL) (n,) each: the range a corrected step may reach."""
    return robot.lower - JOINT_LIMIT_TOL, robot.upper + JOINT_LIMIT_TOL


def outside_limits(robot: Robot, q: Array, bounds: tuple[Array, Array] | None = None) -> NDArray[np.intp]:
    """The joints (0-based) of q (n,) below their lower or above their upper limit by more than JOINT_LIMIT_TOL.

    `bounds`: :func:`limit_bounds` of the robot, computed once by a caller that checks every step.
    """
    low, high = limit_bounds(robot) if bounds is None else bounds
    return np.flatnonzero((q < low) | (q > high))


def prismatic(robot: Robot, j: int) -> bool:
    """Whether joint j (0-based, chain order) is prismatic."""
    return str(robot.model.joints[j + 1].shortname()).startswith("JointModelP")


def limit_failure(robot: Robot, q: Array, t: float, scaled: bool) -> JointLimitError:
    """The error that ends a run whose step to time t (s) takes joints beyond their limits at q (n,)."""
    parts = []
    for j in outside_limits(robot, q):
        unit = "m" if prismatic(robot, int(j)) else "rad"
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


def joint_speeds(robot: Robot) -> tuple[Array, NDArray[np.bool_]]:
    """The velocity limit of each joint (n,) and whether the URDF gave it (n,) (else DEFAULT_JOINT_SPEED)."""
    v = np.asarray(robot.model.velocityLimit, dtype=float).copy()
    given = np.isfinite(v) & (v > 0)
    v[~given] = DEFAULT_JOINT_SPEED
    return v, given


def joint_step_bound(robot: Robot, dt: float) -> Array:
    """Largest motion (n,) of each joint between two samples dt (s) apart: rad (m for a prismatic joint).

    JOINT_STEP_SAFETY × the URDF velocity limit × dt, with DEFAULT_JOINT_SPEED (rad/s) for a joint whose
    URDF gives 0 or inf, and never more than MAX_JOINT_STEP.
    """
    return np.minimum(JOINT_STEP_SAFETY * joint_speeds(robot)[0] * dt, MAX_JOINT_STEP)


def sigma_ratios(state: BracedState, space: TaskSpace, keys: tuple[str, ...] | None = None) -> dict[str, float]:
    """σ_min/σ_max at the state of the matrices named in `keys` (every matrix a run records if None)."""
    return state.motions.conditioning(None if space.is_pose else space.selection(state.R_e), keys)


def stacked_sigma_ratios(states: Sequence[BracedState], space: TaskSpace, keys: tuple[str, ...]) -> Conditioning:
    """:func:`sigma_ratios` of every state (the same numbers), each matrix kind in one stacked SVD.

    With them (``decomposed``), each stack decomposed and its singular values, one field per matrix (for the
    run's measures).
    """
    rows = [None if space.is_pose else space.selection(st.R_e) for st in states]
    return stacked_conditioning(states, rows, keys)


def first_singular(ratios: Sequence[Mapping[str, float]], keys: tuple[str, ...]) -> tuple[int, SingularityError] | None:
    """The first of the samples' `ratios` that :func:`check_conditioning` refuses, with its error; None if none."""
    for i, found in enumerate(ratios):
        try:
            check_conditioning(found, keys)
        except SingularityError as exc:
            return i, exc
    return None


def check_conditioning(ratios: Mapping[str, float], keys: tuple[str, ...]) -> None:
    """SingularityError if σ_min/σ_max of a matrix in `keys` (`ratios` by key) is below PATH_SINGULAR_RATIO."""
    low = [key for key in keys if ratios[key] < PATH_SINGULAR_RATIO]
    if low:
        key = min(low, key=ratios.__getitem__)
        raise SingularityError(
            f"{MATRIX_LABELS[key]} is singular on the path (σ_min/σ_max = {ratios[key]:.1e} < {PATH_SINGULAR_RATIO:g})"
        )


def jump_failure(
    braced: BracedRobot,
    space: TaskSpace,
    keys: tuple[str, ...],
    before: Array,
    after: Array,
    bound: Array,
    dt: float,
    start: Mapping[str, float],
    gain: bool,
) -> NumericalError:
    """The error that ends a run whose joints moved more than `bound` (n,) between two samples.

    Names the joints (1-based, chain order), the motion and its bound, and the smallest σ_min/σ_max of the
    strategy's matrices (`keys`) at JUMP_PROBES configurations on the straight joint path between the samples.
    That is a singularity when below NEAR_SINGULAR_RATIO or NEAR_SINGULAR_DROP × its value at the run's start
    (`start`, the ratios of the first sample). `gain`: whether the strategy has a gain |alpha| to reduce.
    """
    step = np.abs(after - before)
    over = np.flatnonzero(step > bound)
    joints = ", ".join(str(j + 1) for j in over)
    units = {"m" if prismatic(braced.robot, int(j)) else "rad" for j in over}
    unit = units.pop() if len(units) == 1 else "rad or m"
    lo, hi = float(np.min(bound[over])), float(np.max(bound[over]))
    limit = f"bound {hi:.3g} {unit}" if f"{lo:.3g}" == f"{hi:.3g}" else f"bounds {lo:.3g}–{hi:.3g} {unit}"
    given = joint_speeds(braced.robot)[1]
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
    ratios = dict.fromkeys(keys, np.inf)
    for s in np.linspace(0.0, 1.0, JUMP_PROBES):
        found = sigma_ratios(braced.state(before + s * (after - before)), space, keys)
        ratios = {key: min(ratios[key], found[key]) for key in keys}
    drop = {key: ratios[key] / max(start[key], 1e-300) for key in keys}
    near = [key for key in keys if ratios[key] < NEAR_SINGULAR_RATIO or drop[key] < NEAR_SINGULAR_DROP]
    if near:
        key = min(near, key=drop.__getitem__)
        return SingularityError(
            f"{message}; the step passes a singularity of {MATRIX_LABELS[key]} (σ_min/σ_max down to "
            f"{ratios[key]:.1e} from {start[key]:.1e} at the start)"
        )
    worst = min(ratios, key=ratios.__getitem__)
    reduce = " or |alpha|" if gain else ""
    return NumericalError(
        f"{message}; no singularity between the samples (σ_min/σ_max ≥ {ratios[worst]:.1e}, of "
        f"{MATRIX_LABELS[worst]}): the strategy's joint rates exceed the bound; reduce dt, slow the task{reduce}"
    )


def braces_outside(braced: BracedRobot, state: BracedState) -> list[int]:
    """The braces (0-based) whose {b_i} is at or beyond its region radius r_max_i."""
    return [
        i
        for i, (brace, b) in enumerate(zip(braced.braces, state.b_i, strict=True))
        if brace.region_radius is not None and norm(b - brace.surface.point) >= brace.region_radius
    ]


def point_label(braced: BracedRobot, i: int) -> str:
    """How messages name brace i's contact point: 'the bracing point' (one brace) or '... of braces[i]'."""
    return "the bracing point" if len(braced.braces) == 1 else f"the bracing point of braces[{i}]"
