"""A run's verdict beside ``completed``: ``valid`` — nothing along its samples that the physics forbids.

A run is valid when, at every sample: no link is inside an obstacle (the least link clearance from the
surface's solid is above −CLEARANCE_TOL), every brace of a braced run is inside its bracing region
(r_i ≤ r_max,i), the braces hold where the statics are on (``holds``), and every joint is inside its URDF
limits (by JOINT_LIMIT_TOL). ``invalid_reasons`` names each that fails, with its worst value and the time.
A run that did not complete is judged on the samples it took.

The link named is :func:`deepest_link`'s: two adjacent links whose capsules meet at their shared joint have the
same least clearance there up to rounding, so among the links within TIE_TOL of the least the lowest joint is
named (and the earliest sample within TIE_TOL of the path's least), a name that rounding does not flip.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from bracekit.kinematics import BracedRobot
from bracekit.kinematics.clearance import Clearance
from bracekit.simulation.guards import JOINT_LIMIT_TOL, point_label
from bracekit.simulation.trajectory import Trajectory

__all__ = ["CLEARANCE_TOL", "TIE_TOL", "Verdict", "deepest_link", "verdict"]

#: Depth (m) of a link inside an obstacle below which the run is still valid (contact within rounding).
CLEARANCE_TOL = 1e-6
#: Clearances (m) within this of the least are one tie: the lowest joint (or the earliest sample) is named.
TIE_TOL = 1e-9


def deepest_link(braced: BracedRobot, q: ArrayLike) -> tuple[float, int]:
    """(The least link clearance at q, m; the lowest joint in chain order whose link is within TIE_TOL of it).

    Negative is penetration; (inf, −1) when the robot has no capsule besides the brace's link. The value is the
    clearance model's least (:class:`~bracekit.kinematics.clearance.Clearance`); only the name breaks the tie.
    """
    links = Clearance(braced).links(q, gradient=False)
    if not links:
        return math.inf, -1
    least = min(d.clearance for d in links)
    return least, min(d.joint for d in links if d.clearance <= least + TIE_TOL)


class Verdict(NamedTuple):
    """``valid`` and, when not, the reasons (one line each)."""

    valid: bool
    invalid_reasons: list[str]


def verdict(braced: BracedRobot, tr: Trajectory, summary: dict[str, Any]) -> Verdict:
    """The verdict of run `tr` of `braced` from its measures and its summary (``holds`` if the statics are on)."""
    reasons: list[str] = []
    m = tr.measures
    t = tr.t
    clearance = m.get("link_clearance")
    if clearance is not None and clearance.size and float(np.min(clearance)) < -CLEARANCE_TOL:
        i = int(np.argmax(clearance <= float(np.min(clearance)) + TIE_TOL))  # the earliest sample of the tie
        joint = deepest_link(braced, tr.q[i])[1]
        name = braced.robot.joint_names[joint] if 0 <= joint < braced.n else "?"
        reasons.append(
            f"a link passes through the surface's solid: the link of joint {joint + 1} ({name}) is "
            f"{-float(clearance[i]):.4f} m inside at t = {t[i]:.3f} s"
        )
    if tr.braced and tr.samples is not None:
        for k, (brace, series) in enumerate(zip(braced.braces, tr.samples.contacts, strict=True)):
            if brace.region_radius is None or not series.region_radius.size:
                continue
            i = int(np.argmax(series.region_radius))
            if series.region_radius[i] > brace.region_radius * (1.0 + 1e-9):
                reasons.append(
                    f"{point_label(braced, k)} leaves its region: r = {series.region_radius[i]:.4f} m > r_max = "
                    f"{brace.region_radius:g} m at t = {t[i]:.3f} s"
                )
    if summary.get("holds") is False:
        reasons.append("the brace does not hold along the run (statics: a margin below 1 or a torque over its limit)")
    violation = m.get("joint_limit_violation")
    if violation is not None and violation.size and float(np.max(violation)) > JOINT_LIMIT_TOL:
        i = int(np.argmax(violation))
        reasons.append(f"a joint leaves its limits by {float(violation[i]):.3g} rad at t = {t[i]:.3f} s")
    return Verdict(not reasons, reasons)
