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
from bracekit.errors import ContactError, InputError, SingularityError, UnloadedContactWarning
from bracekit.kinematics import BracedRobot
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
    if not isinstance(robot, Robot):
        raise InputError(f"the study needs a bracekit Robot, got {type(robot).__name__}")
    count = as_count(points_per_link, "points_per_link", low=1, high=MAX_POINTS_PER_LINK)
    qa = robot.check_q(q)
    kind = contact_type(contact)
    n_hat = as_array(normal, "the surface normal", error=ContactError)
    Surface(np.zeros(3), n_hat)  # a normal that makes a plane (3 finite numbers, not all zero)
    n_hat = n_hat.reshape(-1)
    if beta_x is None:
        with np.errstate(over="ignore", under="ignore"):
            size = np.linalg.norm(n_hat)
        unit_normal = n_hat / size if np.isfinite(size) and size > 1e-150 else unit(n_hat)
        beta = np.concatenate([unit_normal, np.zeros(3)])
    else:
        beta = as_array(beta_x, "beta_x", finite=False).reshape(-1)
        unit6(beta, "beta_x")  # 6 finite numbers, not all zero
    model = robot.model
    links = _links(model)
    fractions = np.linspace(0.0, 1.0, count, endpoint=count == 1) + (0.5 if count == 1 else 0.0)
    planned = []
    for j in range(1, robot.n):  # joints 1..n-1 carry links with joints beyond them
        nxt = np.asarray(model.jointPlacements[j + 1].translation, dtype=float)
        link = links.get(j, model.names[j])
        planned += [(f"_candidate_{j}_{f:.3f}", link, j, float(f), f * nxt) for f in fractions]
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
        st = braced.state_from_kinematics(qa, tip, j_e, placement, j_b)
        if ci_free is None:  # the free robot is the same for every candidate
            ci_free = compliance_index(free_space_compliance(st), beta)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", UnloadedContactWarning)
            c_con = end_effector_compliance(st, "constrained")
        try:
            k_b: float | None = frobenius_condition(st.J_braced)
        except SingularityError:
            k_b = None
        out.append(
            BraceCandidate(
                link=link,
                n1=braced.n1,
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
