"""Where to brace: the compliance at the tip for bracing points along the robot (the paper's future work).

At a fixed configuration q, candidate bracing points are placed along each link (on the segment from the
link's joint to the next joint), a plane with the given normal is put through each point, and the tip's
compliance index C_i along β_x is evaluated for the free robot and both braced models. Units: m, m/N.
"""

from __future__ import annotations

import warnings
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
    """One candidate bracing point and what bracing there does to the tip.

    ``link`` is the link that carries the point, ``fraction`` its place on the segment to the next
    joint (0 = at the joint), ``point`` its world position (m). ``Ci_*`` in m/N; ``k_braced`` is k of J̃
    (None if J̃ is singular there); ``unloaded`` tells that the contact carries no load from chain 1.
    """

    link: str
    n1: int
    fraction: float
    point: Array
    Ci_free: float
    Ci_constrained: float
    Ci_projection: float
    k_braced: float | None
    unloaded: bool

    @property
    def reduction(self) -> float | None:
        """1 − C_i(constrained) / C_i(free); None when the free compliance along β_x is zero."""
        return None if self.Ci_free <= 1e-15 else 1.0 - self.Ci_constrained / self.Ci_free


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
    beta_x: ArrayLike | None = None,
    points_per_link: int = 3,
    contact: str | ContactType = "frictionless_point",
) -> list[BraceCandidate]:
    """Candidates on every link that has at least one joint between it and the tip, best (lowest C_i) first.

    Candidates that coincide with one already listed (same point, same chain split) are dropped. The robot's
    kinematics are evaluated once for all candidates (their frames are added to one copy of the model).

    Args:
        robot: the robot, at configuration q (n,).
        q: joint values, chain order.
        normal: normal of the bracing plane put through each candidate (world; its length does not matter).
        beta_x: twist of the compliance index (6,); [n̂; 0] by default.
        points_per_link: candidates per link, 1 to MAX_POINTS_PER_LINK (1: the middle of the link).
        contact: contact type (name or instance).
    """
    count, qa, kind = _study_inputs(robot, q, points_per_link, contact)
    n_hat = _plane_normal(normal, "the surface normal")
    beta = _beta(beta_x, n_hat)
    planned = _planned(robot, count)
    frames = robot.with_point_frames([(name, link, offset, None) for name, link, _, _, offset in planned])
    ids = [frames.tip_id] + [frames.frame_id(p[0]) for p in planned]
    kinematics = frames.frame_kinematics(qa, ids)
    tip, j_e = kinematics[0]
    out: list[BraceCandidate] = []
    seen: dict[int, list[Array]] = {}
    ci_free: float | None = None
    for (name, link, j, f, _), (placement, j_b) in zip(planned, kinematics[1:], strict=True):
        b = placement[:3, 3]  # the candidate point in world coordinates
        if any(np.linalg.norm(p - b) < 1e-9 for p in seen.get(j, ())):
            continue
        seen.setdefault(j, []).append(b)
        braced = BracedRobot(frames, Brace(name, Surface(b, n_hat), kind))
        st = braced.state_from_kinematics(qa, [(tip, j_e), (placement, j_b)])
        if ci_free is None:  # the free robot is the same for every candidate
            ci_free = compliance_index(free_space_compliance(st), beta)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", UnloadedContactWarning)
            c_con = end_effector_compliance(st, "constrained")
        try:
            k_b: float | None = frobenius_condition(st.split.J_braced)
        except SingularityError:
            k_b = None
        out.append(
            BraceCandidate(
                link=link,
                n1=braced.split.n1,
                fraction=f,
                point=b,
                Ci_free=ci_free,
                Ci_constrained=compliance_index(c_con, beta),
                Ci_projection=compliance_index(end_effector_compliance(st, "projection"), beta),
                k_braced=k_b,
                unloaded=any(issubclass(w.category, UnloadedContactWarning) for w in caught),
            )
        )
    return sorted(out, key=lambda c: c.Ci_constrained)


@dataclass(frozen=True)
class BracePairCandidate:
    """One candidate second bracing point, braced together with a fixed first brace.

    ``link`` carries the point, ``joint`` is the number of joints that move it (base to that link),
    ``fraction`` its place on the segment to the next joint (0 = at the joint), ``point`` its world position
    (m). ``Ci_first`` is C_i of the first brace alone and ``Ci_pair`` the stacked constrained C_i with both
    braces (m/N, or the units of β_x's rows); ``k_pair`` is k of J_e N (None where J_e N is singular).
    ``redundant``: the candidate's constraint rows depend on the first brace's (it adds no constraint; its
    rows are dropped, so C_i,pair = C_i,first). ``unloaded``: no joint can push the point along the normal.
    """

    link: str
    joint: int
    fraction: float
    point: Array
    Ci_first: float
    Ci_pair: float
    k_pair: float | None
    redundant: bool
    unloaded: bool

    @property
    def gain(self) -> float | None:
        """1 − C_i,pair / C_i,first: what the second brace adds; None when C_i,first is zero."""
        return None if self.Ci_first <= 1e-15 else 1.0 - self.Ci_pair / self.Ci_first


def _stacked(braced: BracedRobot, q: Array, kinematics: list[tuple[Array, Array]]) -> BracedState:
    """The stacked state of `braced` at q from (⁰M, J) of the tip and of each brace, in brace order."""
    return braced.state_from_kinematics(q, kinematics)


def _k(state: BracedState) -> float | None:
    """The condition number k of J_e N; None where it is singular (fewer than 6 braced motions, or σ_min ≈ 0)."""
    try:
        return frobenius_condition(state.braced_jacobian)
    except SingularityError:
        return None


def brace_pair_study(
    robot: Robot,
    q: ArrayLike,
    first_frame: str,
    *,
    first_normal: ArrayLike = (0.0, 0.0, 1.0),
    second_normal: ArrayLike = (0.0, 0.0, 1.0),
    beta_x: ArrayLike | None = None,
    points_per_link: int = 3,
    contact: str | ContactType = "frictionless_point",
) -> list[BracePairCandidate]:
    """Where to put a second brace, given a first one: candidates along the robot, best (lowest C_i,pair) first.

    The first brace is frame `first_frame` of the model on the plane through it with normal `first_normal`.
    Candidate second points are placed as in :func:`brace_location_study` (the same points, coincident ones
    dropped), each on its own plane through the point with normal `second_normal`. For each candidate,
    C_i,pair = ‖β_xᵀ C_e‖ with C_e the stacked constrained compliance of both braces
    (:func:`~bracekit.compliance.first_order.constrained_compliance`, first brace's rows first). A candidate whose
    rows depend on the first brace's is kept and marked ``redundant`` (its RedundantContactWarning is not
    repeated); candidates the model refuses (a frame it cannot brace, a non-finite G) are left out. The
    kinematics are evaluated once for all candidates.

    Args:
        robot: the robot (n joints).
        q: joint values (n,), chain order.
        first_frame: frame of the first brace {b_1} (a frame of a link with a joint between it and the tip).
        first_normal: normal of the first brace's plane (world; its length does not matter).
        second_normal: normal of every candidate's plane (world).
        beta_x: twist of the compliance index (6,); [n̂_1; 0] (the first normal) by default.
        points_per_link: candidates per link, 1 to MAX_POINTS_PER_LINK (1: the middle of the link).
        contact: contact type of both braces (name or instance).
    """
    count, qa, kind = _study_inputs(robot, q, points_per_link, contact)
    n_1 = _plane_normal(first_normal, "the first brace's normal")
    n_2 = _plane_normal(second_normal, "the second brace's normal")
    beta = _beta(beta_x, n_1)
    if not isinstance(first_frame, str):
        raise InputError(f"first_frame must be a frame name (a string), got {type(first_frame).__name__}")
    BracedRobot(robot, Brace(first_frame, Surface(np.zeros(3), n_1), kind))  # a frame the model can brace
    planned = _planned(robot, count)
    frames = robot.with_point_frames([(name, link, offset, None) for name, link, _, _, offset in planned])
    ids = [frames.tip_id, frames.frame_id(first_frame)] + [frames.frame_id(p[0]) for p in planned]
    kinematics = frames.frame_kinematics(qa, ids)
    first = Brace(first_frame, Surface(kinematics[1][0][:3, 3], n_1), kind)
    alone = _stacked(BracedRobot(frames, [first]), qa, kinematics[:2])
    ci_first = compliance_index(end_effector_compliance(alone, "constrained"), beta)
    out: list[BracePairCandidate] = []
    seen: dict[int, list[Array]] = {}
    for (name, link, j, f, _), kin in zip(planned, kinematics[2:], strict=True):
        b = kin[0][:3, 3]  # the candidate point in world coordinates
        if any(np.linalg.norm(p - b) < 1e-9 for p in seen.get(j, ())):
            continue
        seen.setdefault(j, []).append(b)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                braced = BracedRobot(frames, [first, Brace(name, Surface(b, n_2), kind)])
                st = _stacked(braced, qa, [*kinematics[:2], kin])
                ci_pair = compliance_index(end_effector_compliance(st, "constrained"), beta)
            except (ContactError, NumericalError):
                continue
        # labels in the warnings are "braces[i] (frame ...)": braces[1] is the candidate
        about = [w for w in caught if "braces[1]" in str(w.message)]
        out.append(
            BracePairCandidate(
                link=link,
                joint=j,
                fraction=f,
                point=b,
                Ci_first=ci_first,
                Ci_pair=ci_pair,
                k_pair=_k(st),
                redundant=any(issubclass(w.category, RedundantContactWarning) for w in about),
                unloaded=any(issubclass(w.category, UnloadedContactWarning) for w in about),
            )
        )
    return sorted(out, key=lambda c: c.Ci_pair)
