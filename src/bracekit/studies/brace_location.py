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

from bracekit.compliance.first_order import compliance_index, end_effector_compliance, free_space_compliance
from bracekit.compliance.measures import frobenius_condition
from bracekit.contact import Brace, Surface, contact_type
from bracekit.errors import InputError, SingularityError, UnloadedContactWarning
from bracekit.kinematics import BracedRobot
from bracekit.model.robot import Robot

Array = NDArray[np.float64]

#: Upper bound on the candidates per link (each costs a model copy and one evaluation).
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


def brace_location_study(
    robot: Robot,
    q: ArrayLike,
    *,
    normal: ArrayLike = (0.0, 0.0, 1.0),
    beta_x: ArrayLike | None = None,
    points_per_link: int = 3,
    contact: str = "frictionless_point",
) -> list[BraceCandidate]:
    """Candidates on every link that has at least one joint between it and the tip, best (lowest C_i) first.

    Candidates that coincide with one already listed (same point, same chain split) are dropped.
    """
    if not 1 <= points_per_link <= MAX_POINTS_PER_LINK:
        raise InputError(f"points_per_link must be between 1 and {MAX_POINTS_PER_LINK}, got {points_per_link}")
    qa = robot.check_q(q)
    model = robot.model
    data = model.createData()
    pin.forwardKinematics(model, data, qa)
    pin.updateFramePlacements(model, data)
    n_hat = np.asarray(normal, dtype=float)
    beta = np.concatenate([n_hat / np.linalg.norm(n_hat), np.zeros(3)]) if beta_x is None else np.asarray(beta_x)
    out: list[BraceCandidate] = []
    for j in range(1, robot.n):  # joints 1..n-1 carry links with joints beyond them
        nxt = np.asarray(model.jointPlacements[j + 1].translation, dtype=float)
        bodies = [f.name for f in model.frames if f.parentJoint == j and f.type == pin.FrameType.BODY]
        link = bodies[0] if bodies else model.names[j]
        for f in np.linspace(0.0, 1.0, points_per_link, endpoint=points_per_link == 1) + (
            0.5 if points_per_link == 1 else 0.0
        ):
            name = f"_candidate_{j}_{f:.3f}"
            b = data.oMi[j].act(f * nxt)  # the candidate point in world coordinates
            if any(c.n1 == j and np.linalg.norm(c.point - b) < 1e-9 for c in out):
                continue
            r = robot.with_point_frame(name, link, f * nxt)
            braced = BracedRobot(r, Brace(name, Surface(b, n_hat), contact_type(contact)))
            st = braced.state(qa)
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
                    fraction=float(f),
                    point=b,
                    Ci_free=compliance_index(free_space_compliance(st), beta),
                    Ci_constrained=compliance_index(c_con, beta),
                    Ci_projection=compliance_index(end_effector_compliance(st, "projection"), beta),
                    k_braced=k_b,
                    unloaded=any(issubclass(w.category, UnloadedContactWarning) for w in caught),
                )
            )
    return sorted(out, key=lambda c: c.Ci_constrained)
