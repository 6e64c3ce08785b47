"""The start of a run: a configuration with the tip on the task and every {b_i} on its surface, any brace count.

SciPy least squares from a guess within the joint limits: the tip and the contacts are hard residuals
(then polished by the correction), the distance of each {b_i} from its region centre, θ_z of each brace with
a pad axis, the conditioning of the braced inverses and the distance from the guess are soft.
"""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import least_squares

from bracekit._linalg import show
from bracekit.errors import BracekitError, BracekitWarning, ConvergenceError, InputError
from bracekit.kinematics import BracedRobot, BracedState
from bracekit.resolution.task_space import POSE, TaskSpace
from bracekit.simulation.correction import correct
from bracekit.simulation.guards import braces_outside, point_label, sigma_ratios
from bracekit.simulation.validity import deepest_link

#: Largest weight of a soft term of the start solve (a larger one overflows the least-squares solve).
MAX_START_WEIGHT = 1e6

Array = NDArray[np.float64]

#: Evaluations the start solve may take.
START_MAX_NFEV = 2000

__all__ = ["START_THETA_WEIGHT", "solve_start"]


#: The θ_z weight of the start solve when the caller gives none and the brace has a pad axis.
START_THETA_WEIGHT = 0.3
#: The start solve's conditioning term acts where σ_min/σ_max of A or J̃ falls below this (inactive above).
START_CONDITIONING_FLOOR = 0.02
#: The start solve's default weight of the conditioning term.
START_CONDITIONING_WEIGHT = 0.1
#: Joint step (rad or m) of the finite differences of the conditioning term's Jacobian rows.
START_FD_STEP = 1e-7


def conditioned(state: BracedState) -> tuple[str, ...]:
    """The matrices whose conditioning the start keeps above the floor: the braced inverses, J1 aside.

    One brace: the whole A (not only the task rows S A a step inverts: a margin in every task space) and J̃;
    several: G (independent rows) and S J_e N (:meth:`BracedMotions.inverted`).
    """
    return tuple("A" if key == "SA" else key for key in state.motions.inverted(True) if key != "J1")


def _conditioning_residual(state: BracedState, floor: float, space: TaskSpace = POSE) -> Array:
    """log(floor / ρ) where ρ = σ_min/σ_max < floor, else 0, for each matrix of :func:`conditioned`.

    A barrier that is C¹ in its square and exactly zero wherever every ratio is at least `floor`. The ratios
    are those the run watches in its task space `space` (:func:`bracekit.simulation.guards.sigma_ratios`).
    """
    keys = conditioned(state)
    ratios = sigma_ratios(state, space, keys)
    return np.array([np.log(floor / max(ratios[k], 1e-300)) if ratios[k] < floor else 0.0 for k in keys])


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
    space: TaskSpace = POSE,
) -> BracedState:
    """A start configuration: tip at `position` (and `rotation` if given), every {b_i} on its surface.

    Solved from `guess` (n,) by SciPy least squares: the tip pose and the contacts are hard residuals
    (then polished to 1e-12 by Gauss–Newton), while the distance of each {b_i} from its region centre, θ_z of
    each brace with a pad axis, the conditioning of the braced inverses and the distance from the guess are
    soft. The conditioning term is ``conditioning_weight · log(conditioning_floor / ρ)`` for each σ_min/σ_max
    ρ of the braced inverses (:func:`conditioned`) below `conditioning_floor` and zero elsewhere (its Jacobian
    rows by finite differences where it acts); it is added, and the solve continued, only if the solve
    without it ends with a ratio below the floor, so a start that is conditioned enough is the plain solve's.

    Args:
        braced: the braced robot.
        position: tip position at the start (3,), m.
        guess: the initial guess (n,).
        rotation: tip rotation at the start (3×3), or None for any.
        region_weight: weight of ‖b_i − region centre‖ (1/m).
        theta_weight: weight of θ_z (1/rad) of each brace with a pad axis; None is START_THETA_WEIGHT for one
            brace with a pad axis and 0 otherwise. Must be 0 when no brace has a pad axis.
        posture_weight: weight of ‖q − guess‖.
        conditioning_weight: weight of the conditioning barrier (0 drops it).
        conditioning_floor: the σ_min/σ_max below which the barrier acts, in (0, 1).
        space: the task space of the runs from this start (the rows of S J_e N with several braces).

    Raises:
        InputError: a position that is not 3 finite numbers (m), a rotation that is not a finite 3×3
            rotation matrix, a bad guess, a negative or non-finite weight, a floor outside (0, 1), or a
            θ_z weight without a pad axis.
        ConvergenceError: the hard residuals are not met or a {b_i} ends outside its bracing region.

    Warns (BracekitWarning) only about a start that meets the task and the contacts but whose soft terms did
    not converge.
    """
    target = _finite(position, (3,), "the start position (m)")
    rot = None if rotation is None else _finite(rotation, (3, 3), "the start rotation")
    if rot is not None and not (np.allclose(rot.T @ rot, np.eye(3), atol=1e-9) and np.linalg.det(rot) > 0):
        raise InputError("the start rotation must be a rotation matrix (orthonormal, determinant +1)")
    q_guess = braced.robot.check_q(guess)
    pads = [i for i, brace in enumerate(braced.braces) if brace.pad_axis]
    if theta_weight is None:
        theta_weight = START_THETA_WEIGHT if pads and len(braced.braces) == 1 else 0.0
    for what, value in (
        ("region_weight", region_weight),
        ("theta_weight", theta_weight),
        ("posture_weight", posture_weight),
        ("conditioning_weight", conditioning_weight),
    ):
        if isinstance(value, bool) or not isinstance(value, int | float) or not (0.0 <= value <= MAX_START_WEIGHT):
            raise InputError(f"{what} must be a number from 0 to {MAX_START_WEIGHT:g}, got {show(value)}")
    if theta_weight > 0 and not pads:
        frames = ", ".join(repr(b.frame) for b in braced.braces)
        raise InputError(
            f"theta_weight = {theta_weight:g} needs a brace with a pad axis, and {frames} (a link point) has none; "
            "give the brace a pad axis or theta_weight = 0"
        )
    if isinstance(conditioning_floor, bool) or not isinstance(conditioning_floor, int | float):
        raise InputError(f"conditioning_floor must be a number in (0, 1), got {conditioning_floor!r}")
    if not 0.0 < conditioning_floor < 1.0:
        raise InputError(f"conditioning_floor must be a number in (0, 1), got {conditioning_floor!r}")
    surfaces = [brace.surface for brace in braced.braces]
    normals = np.array([s.normal for s in surfaces])
    lo, hi = braced.robot.lower, braced.robot.upper
    tangents = [(surfaces[i].frame[:, 0], surfaces[i].frame[:, 1]) for i in pads] if theta_weight > 0 else []

    def residual(q: Array, conditioned: bool) -> Array:
        st = braced.state(q)
        hard = [target - st.e, np.array([s.signed_distance(b) for s, b in zip(surfaces, st.b_i, strict=True)])]
        if rot is not None:
            hard.append(_orientation_residual(st.R_e, rot, space))
        soft = [region_weight * (b - s.point) for s, b in zip(surfaces, st.b_i, strict=True)]
        for i, (x_t, y_t) in zip(pads, tangents, strict=False):  # ẑ_b's tangential components: ≈ θ_z, smooth at 0
            z_b = st.contacts[i].z_b
            soft.append(theta_weight * np.array([x_t @ z_b, y_t @ z_b]))
        soft.append(posture_weight * (q - q_guess))
        if conditioned:
            soft.append(conditioning_weight * _conditioning_residual(st, conditioning_floor, space))
        return np.concatenate([1e3 * np.concatenate(hard), np.concatenate(soft)])

    def jacobian(q: Array, conditioned: bool) -> Array:
        st = braced.state(q)
        hard = [-st.J_e[:3], np.einsum("ij,ijk->ik", normals, np.array([j[:3] for j in st.J_b_i]))]
        if rot is not None:  # first-order (exact at the solution)
            hard.append(-st.J_e[3:] if space.is_pose else -space.selection(st.R_e)[3:, 3:] @ st.J_e[3:])
        soft = [region_weight * j[:3] for j in st.J_b_i]
        for i, (x_t, y_t) in zip(pads, tangents, strict=False):
            c = st.contacts[i]
            soft.append(theta_weight * np.vstack([_cross(c.z_b, x_t) @ c.J_b[3:], _cross(c.z_b, y_t) @ c.J_b[3:]]))
        soft.append(posture_weight * np.eye(q.size))
        if conditioned:
            soft.append(conditioning_weight * _conditioning_jacobian(braced, st, conditioning_floor, space))
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
    if conditioning_weight > 0 and np.any(_conditioning_residual(braced.state(sol.x), conditioning_floor, space)):
        sol = solve(sol.x, True)
    st = braced.state(sol.x)
    rotation_target = rot if rot is not None else st.R_e
    # the plane point under each b_i: anchors on the surfaces
    anchors = [(b - s.normal * s.signed_distance(b), r) for s, b, r in zip(surfaces, st.b_i, st.R_b_i, strict=True)]
    try:
        st = _polish(braced, st, target, rotation_target, anchors, space)
    except ConvergenceError as exc:
        every = "the brace" if len(surfaces) == 1 else "every brace"
        what = str(exc).split("not closed: ", 1)[-1].rsplit(" (residual ", 1)[0]
        gaps = ", ".join(
            f"{point_label(braced, i)} {abs(s.signed_distance(b)):.3g} m off its surface"
            for i, (s, b) in enumerate(zip(surfaces, st.b_i, strict=True))
        )
        gaps += _blocked(braced, st)
        raise ConvergenceError(
            f"no start configuration puts the tip at {np.round(target, 4).tolist()} m ({space.describe()}) with "
            f"{every} closed: the correction did not close {what} (tip {np.linalg.norm(target - st.e):.3g} m away, "
            f"{gaps}); "
            "move the task or the surface, or change the guess"
        ) from None
    outside = braces_outside(braced, st)
    if outside:
        i = outside[0]
        r = float(np.linalg.norm(st.b_i[i] - surfaces[i].point))
        raise ConvergenceError(
            f"no start configuration with {point_label(braced, i)} inside the region: r = {r:.4f} m ≥ r_max = "
            f"{braced.braces[i].region_radius} m; move the region centre, the task or the start guess"
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


def _cross(a: Array, b: Array) -> Array:
    """The cross product a × b of two 3-vectors: ``np.cross``'s products and differences, without its axes."""
    a0, a1, a2 = a.tolist()
    b0, b1, b2 = b.tolist()
    return np.array([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])


def _conditioning_jacobian(braced: BracedRobot, state: BracedState, floor: float, space: TaskSpace) -> Array:
    """∂(_conditioning_residual)/∂q by central differences; zero rows where the barrier is inactive."""
    base = _conditioning_residual(state, floor, space)
    out = np.zeros((base.size, state.q.size))
    if not np.any(base):
        return out
    for i in range(state.q.size):
        step = np.zeros(state.q.size)
        step[i] = START_FD_STEP
        up = _conditioning_residual(braced.state(state.q + step), floor, space)
        down = _conditioning_residual(braced.state(state.q - step), floor, space)
        out[:, i] = (up - down) / (2.0 * START_FD_STEP)
    return out


#: Distance (rad or m) from a joint limit at which a failed start names the joint as held by its limit.
AT_LIMIT = 1e-6


def _blocked(braced: BracedRobot, st: BracedState) -> str:
    """What may hold a failed start back: joints at a limit, a link inside the surface's solid ("" if none)."""
    robot = braced.robot
    out = ""
    at = np.flatnonzero((st.q - robot.lower < AT_LIMIT) | (robot.upper - st.q < AT_LIMIT))
    if at.size:
        out += "; at a joint limit: " + ", ".join(f"joint {i + 1} ({robot.joint_names[i]})" for i in at)
    try:
        clearance, joint = deepest_link(braced, st.q)
    except BracekitError:  # the clearance model has one surface as obstacle
        return out
    if np.isfinite(clearance) and clearance < 0.0 and 0 <= joint < robot.n:
        name = robot.joint_names[joint]
        out += f"; the link of joint {joint + 1} ({name}) {-clearance:.3g} m inside the surface's solid"
    return out


def _polish(
    braced: BracedRobot,
    st: BracedState,
    target: Array,
    rotation: Array,
    anchors: list[tuple[Array, Array]],
    space: TaskSpace,
) -> BracedState:
    """The least-squares start polished onto the task's rows and the contacts by the correction.

    The rows the task leaves free are first held where the least-squares solve left them (the full pose with
    every contact); where those rows make the correction's system singular (a free orientation the task does
    not need), the correction acts on the task's own rows and the contacts only. Either start meets the task
    and every contact to the correction's tolerance.
    """
    if not space.is_pose:
        try:
            return correct(braced, st.q, target, rotation, anchors)
        except ConvergenceError:
            pass
    return correct(braced, st.q, target, rotation, anchors, space=space)


def _orientation_residual(rotation: Array, target: Array, space: TaskSpace) -> Array:
    """The orientation rows of the task (rad): log3(R_d R_eᵀ), the tool axis' 2 rows, or none.

    Pose: all 3; 'position+axis': S ω of :meth:`TaskSpace.error`; 'position': none.
    """
    if space.is_pose:
        return np.asarray(pin.log3(target @ rotation.T))
    omega = space.error(np.zeros(3), rotation, target)[3:]
    return np.asarray(space.selection(rotation)[3:, 3:] @ omega)


def _finite(value: ArrayLike, shape: tuple[int, ...], what: str) -> Array:
    """`value` as a float array of `shape`; InputError if it has another size or a non-finite entry."""
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{what} must be numbers, got {value!r}") from None
    if a.size != int(np.prod(shape)) or not np.all(np.isfinite(a)):
        raise InputError(f"{what} must be {' × '.join(map(str, shape))} finite numbers, got {a.tolist()}")
    return a.reshape(shape)
