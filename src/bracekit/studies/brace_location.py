"""Where to brace: the compliance at the tip for bracing points along the robot (the paper's future work).

At a fixed configuration q, candidate bracing points are placed along each link (on the segment from the
link's joint to the next joint), a plane with the given normal is put through each point, and the tip's
compliance index C_i along β_x is evaluated with the candidate added to a set of braces already in place (none:
the candidate alone, against the free robot; one: where to put a second brace). One study serves every set.
Units: m, m/N.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike, NDArray

from bracekit._linalg import as_array, as_count
from bracekit.compliance.first_order import compliance_index, end_effector_compliance, free_space_compliance, unit6
from bracekit.compliance.measures import frobenius_condition
from bracekit.contact import Brace, ContactType, Surface, contact_type
from bracekit.errors import (
    ContactError,
    InputError,
    NumericalError,
    RedundantContactWarning,
    SingularityError,
    UnloadedContactWarning,
)
from bracekit.kinematics import BracedRobot, BracedState
from bracekit.model.robot import Robot
from bracekit.spatial import unit

Array = NDArray[np.float64]

#: Upper bound on the candidates per link.
MAX_POINTS_PER_LINK = 50


@dataclass(frozen=True)
class BraceCandidate:
    """One candidate bracing point, braced together with the study's fixed braces (none: the point alone).

    ``link`` carries the point, ``joint`` is the number of joints that move it (base to that link; for one
    brace the paper's n1), ``fraction`` its place on the segment to the next joint (0 = at the joint),
    ``point`` its world position (m). ``Ci_before`` is C_i without the candidate: the fixed braces' stacked
    constrained C_i, or the free robot's when there are none; ``Ci_constrained`` the stacked constrained C_i
    with the candidate added (m/N, or the units of β_x's rows). ``Ci_projection``: the paper's projection
    model (eq:Ce with C̃1), for a set of one brace only (None otherwise: it needs the chain split).
    ``k_braced``: k of the braced task Jacobian, J̃ for one brace and J_e N for several (None where singular).
    ``redundant``: the candidate's constraint rows depend on the fixed braces' (its rows are dropped, so
    C_i is unchanged). ``unloaded``: no joint can push the point along the normal.
    """

    link: str
    joint: int
    fraction: float
    point: Array
    Ci_before: float
    Ci_constrained: float
    Ci_projection: float | None
    k_braced: float | None
    redundant: bool
    unloaded: bool

    @property
    def reduction(self) -> float | None:
        """1 − C_i,constrained / C_i,before: what the candidate adds; None when C_i,before is zero."""
        return None if self.Ci_before <= 1e-15 else 1.0 - self.Ci_constrained / self.Ci_before


def _links(model: pin.Model) -> dict[int, str]:
    """Joint index → the name of the link it carries (its first BODY frame, else the joint's name)."""
    out: dict[int, str] = {}
    for f in model.frames:
        if f.type == pin.FrameType.BODY and int(f.parentJoint) not in out:
            out[int(f.parentJoint)] = f.name
    return out


def _plane_normal(normal: ArrayLike, what: str) -> Array:
    """A plane's normal (3,) as given (not scaled); ContactError unless 3 finite numbers, not all zero."""
    n_hat = as_array(normal, what, error=ContactError)
    Surface(np.zeros(3), n_hat)  # a normal that makes a plane (3 finite numbers, not all zero)
    return n_hat.reshape(-1)


def _beta(beta_x: ArrayLike | None, n_hat: Array) -> Array:
    """β_x (6,) as given, or [n̂/‖n̂‖; 0] when None; InputError unless 6 finite numbers, not all zero."""
    if beta_x is None:
        with np.errstate(over="ignore", under="ignore"):
            size = np.linalg.norm(n_hat)
        unit_normal = n_hat / size if np.isfinite(size) and size > 1e-150 else unit(n_hat)
        return np.concatenate([unit_normal, np.zeros(3)])
    beta = as_array(beta_x, "beta_x", finite=False).reshape(-1)
    unit6(beta, "beta_x")  # 6 finite numbers, not all zero
    return beta


def _planned(robot: Robot, count: int) -> list[tuple[str, str, int, float, Array]]:
    """(frame name, link, joint index j, fraction, offset in the link's joint frame (m)) of each candidate.

    `count` candidates on each link j = 1..n−1 (Pinocchio joint indices: links with joints beyond them), on
    the segment from joint j to joint j+1; one candidate is put in the middle.
    """
    model = robot.model
    links = _links(model)
    fractions = np.linspace(0.0, 1.0, count, endpoint=count == 1) + (0.5 if count == 1 else 0.0)
    planned = []
    for j in range(1, robot.n):  # joints 1..n-1 carry links with joints beyond them
        nxt = np.asarray(model.jointPlacements[j + 1].translation, dtype=float)
        link = links.get(j, model.names[j])
        planned += [(f"_candidate_{j}_{f:.3f}", link, j, float(f), f * nxt) for f in fractions]
    return planned


def _study_inputs(
    robot: object, q: ArrayLike, points_per_link: object, contact: str | ContactType
) -> tuple[int, NDArray[np.float64], ContactType]:
    """(candidates per link, q (n,) rad, contact type) of a study; InputError for a bad input."""
    if not isinstance(robot, Robot):
        raise InputError(f"the study needs a bracekit Robot, got {type(robot).__name__}")
    count = as_count(points_per_link, "points_per_link", low=1, high=MAX_POINTS_PER_LINK)
    return count, robot.check_q(q), contact_type(contact)


def brace_location_study(
    robot: Robot,
    q: ArrayLike,
    *,
    normal: ArrayLike = (0.0, 0.0, 1.0),
    fixed: Sequence[tuple[str, ArrayLike]] = (),
    beta_x: ArrayLike | None = None,
    points_per_link: int = 3,
    contact: str | ContactType = "frictionless_point",
) -> list[BraceCandidate]:
    """Where to brace, with the braces of ``fixed`` already in place: candidates along the robot, best first.

    Candidate points are placed on every link that has at least one joint between it and the tip
    (``points_per_link`` on the segment to the next joint; coincident ones dropped), each on its own plane
    through the point with normal ``normal``. Each candidate is braced together with the fixed braces (each a
    model frame on the plane through it with its normal) and ranked by the stacked constrained C_i =
    ‖β_xᵀ C_e‖ (:func:`~bracekit.compliance.first_order.end_effector_compliance`, the fixed braces' rows
    first), lowest first. A candidate whose rows depend on the fixed braces' is kept and marked ``redundant``;
    candidates the model refuses (a frame it cannot brace, a non-finite G) are left out. The kinematics are
    evaluated once for all candidates (their frames are added to one copy of the model).

    Args:
        robot: the robot (n joints).
        q: joint values (n,), chain order.
        normal: normal of every candidate's plane (world; its length does not matter).
        fixed: the braces in place, (frame name, plane normal) each; none: the candidates alone.
        beta_x: twist of the compliance index (6,); [n̂; 0] of the first fixed brace's normal (of ``normal``
            without fixed braces) by default.
        points_per_link: candidates per link, 1 to MAX_POINTS_PER_LINK (1: the middle of the link).
        contact: contact type of every brace (name or instance).
    """
    count, qa, kind = _study_inputs(robot, q, points_per_link, contact)
    n_c = _plane_normal(normal, "the surface normal")
    held = _fixed(robot, fixed, kind)
    beta = _beta(beta_x, held[0].surface.normal if held else n_c)
    planned = _planned(robot, count)
    frames = robot.with_point_frames([(name, link, offset, None) for name, link, _, _, offset in planned])
    ids = [frames.tip_id] + [frames.frame_id(b.frame) for b in held] + [frames.frame_id(p[0]) for p in planned]
    kinematics = frames.frame_kinematics(qa, ids)
    first = [
        Brace(b.frame, Surface(kin[0][:3, 3], b.surface.normal), kind)
        for b, kin in zip(held, kinematics[1 : 1 + len(held)], strict=True)
    ]
    base = kinematics[: 1 + len(first)]
    ci_before: float | None = None
    out: list[BraceCandidate] = []
    seen: dict[int, list[Array]] = {}
    last = f"braces[{len(first)}]"  # the candidate's label in the constraint's warnings
    for (name, link, j, f, _), kin in zip(planned, kinematics[len(base) :], strict=True):
        b = kin[0][:3, 3]  # the candidate point in world coordinates
        if any(np.linalg.norm(p - b) < 1e-9 for p in seen.get(j, ())):
            continue
        seen.setdefault(j, []).append(b)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                braced = BracedRobot(frames, [*first, Brace(name, Surface(b, n_c), kind)])
                st = braced.state_from_kinematics(qa, [*base, kin])
                ci = compliance_index(end_effector_compliance(st, "constrained"), beta)
            except (ContactError, NumericalError):
                continue
        if ci_before is None:  # the same for every candidate
            ci_before = _ci_before(st, frames, first, base, beta)
        about = [w for w in caught if last in str(w.message) or "braces[" not in str(w.message)]
        out.append(
            BraceCandidate(
                link=link,
                joint=j,
                fraction=f,
                point=b,
                Ci_before=ci_before,
                Ci_constrained=ci,
                Ci_projection=_projection(st, beta),
                k_braced=_k(st),
                redundant=any(issubclass(w.category, RedundantContactWarning) for w in about),
                unloaded=any(issubclass(w.category, UnloadedContactWarning) for w in about),
            )
        )
    return sorted(out, key=lambda c: c.Ci_constrained)


def _fixed(robot: Robot, fixed: object, kind: ContactType) -> list[Brace]:
    """The fixed braces (frame, plane normal) as Braces on a plane through the origin; InputError if malformed."""
    if not isinstance(fixed, (list, tuple)):
        raise InputError(f"fixed must be a list of (frame name, normal) pairs, got {type(fixed).__name__}")
    out = []
    for i, item in enumerate(fixed):
        if not (isinstance(item, (list, tuple)) and len(item) == 2 and isinstance(item[0], str)):
            raise InputError(f"fixed[{i}] must be a (frame name, normal) pair, got {item!r}")
        out.append(Brace(item[0], Surface(np.zeros(3), _plane_normal(item[1], f"the normal of fixed[{i}]")), kind))
    if out:
        BracedRobot(robot, out)  # frames the model can brace
    return out


def _ci_before(
    state: BracedState, frames: Robot, first: list[Brace], base: list[tuple[Array, Array]], beta: Array
) -> float:
    """C_i without the candidate (``state``: with it).

    The fixed braces' stacked constrained C_i, or the free robot's without fixed braces.
    """
    if not first:
        return compliance_index(free_space_compliance(state), beta)
    alone = BracedRobot(frames, first).state_from_kinematics(state.q, base)
    return compliance_index(end_effector_compliance(alone, "constrained"), beta)


def _projection(state: BracedState, beta: Array) -> float | None:
    """C_i of the paper's projection model for a set of one brace; None for several (it needs the chain split)."""
    try:
        return compliance_index(end_effector_compliance(state, "projection"), beta)
    except ContactError:
        return None


def _k(state: BracedState) -> float | None:
    """The condition number k of the braced task Jacobian (J̃ for one brace, J_e N for several); None if singular."""
    try:
        return frobenius_condition(state.motions.task_jacobian)
    except SingularityError:
        return None
