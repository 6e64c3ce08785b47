"""A candidate's scenario: the base scenario's TOML data with the candidate's inputs and bracing point.

The bracing point is a new frame on the candidate's link (no pad axis, so θ_z is not weighted). Its surface is
a plane with the spec's normal through the region centre, and the region centre is the candidate point's
position at the task context's reference start (:mod:`bracekit.studies.sweep.context`), moved by the
``region_offset`` input if swept. The start solve begins from the reference start: with no region offset the
contact is already closed there, so the braced runs start (about) where the free-space run does.
"""

from __future__ import annotations

import copy
from collections.abc import Sequence
from typing import Any

import numpy as np

from bracekit.studies.sweep.candidates import Candidate, link_offset, surface_offset
from bracekit.studies.sweep.spec import BRACED_STRATEGIES, POINT_FRAME, SweepSpec

#: Fraction along the link used when a spec sweeps neither 'fraction' nor 'offset': the segment's middle.
DEFAULT_FRACTION = 0.5
#: θ_z's weight of a pad on the link's surface (an 'angle' axis) when the base scenario's weights give none: a
#: scenario's default for a brace with a pad axis.
PAD_THETA_WEIGHT = 0.6


def context_data(spec: SweepSpec, inputs: dict[str, Any]) -> dict[str, Any]:
    """The base scenario's TOML data with the task-context inputs (task, stiffness, preload, friction, dt)."""
    data = copy.deepcopy(spec.base_data)
    task = data.setdefault("task", {})
    if "task_centre" in inputs:
        task["centre"] = list(inputs["task_centre"])
    if "task_radius" in inputs:
        task["radius"] = float(inputs["task_radius"])
    if "stiffness" in inputs:
        data.setdefault("robot", {})["stiffness"] = float(inputs["stiffness"])
    brace = data.setdefault("brace", {})
    if "preload" in inputs:
        brace["preload"] = float(inputs["preload"])
    if "friction" in inputs:
        brace["friction"] = float(inputs["friction"])
    if spec.dt is not None:
        data.setdefault("simulation", {})["dt"] = spec.dt
    return data


def point_offset(spec: SweepSpec, robot: Any, inputs: dict[str, Any]) -> np.ndarray:
    """The candidate point in its link's axes (m).

    The swept 'offset'; with an 'angle' the pad on the link's surface at ('fraction', 'angle'), as
    ``[brace] surface`` places it; else the point at 'fraction' of the segment between the joints.
    """
    if "offset" in inputs:
        return np.asarray(inputs["offset"], dtype=float)
    fraction = float(inputs.get("fraction", DEFAULT_FRACTION))
    if "angle" in inputs:
        return surface_offset(robot, inputs["link"], fraction, float(inputs["angle"]))
    return link_offset(robot, inputs["link"], fraction)


def candidate_data(
    spec: SweepSpec, candidate: Candidate, guess: Sequence[float] | np.ndarray, centre: Sequence[float] | np.ndarray
) -> dict[str, Any]:
    """The TOML data of a candidate's scenario.

    Args:
        spec: the sweep spec.
        candidate: the candidate.
        guess: the start guess (n,), the reference start of the candidate's task context.
        centre: the region centre (3,), m, world: the candidate point at the reference start (plus region_offset).
    """
    from bracekit.studies.sweep.context import held_base

    inputs = candidate.inputs
    data = context_data(spec, inputs)
    base_brace = data.get("brace", {})
    robot = held_base(spec).robot
    brace: dict[str, Any] = {"link": inputs["link"], "frame": POINT_FRAME}
    if "angle" in inputs:  # a pad on the link's surface, its axis the surface's inward normal
        brace["surface"] = {
            "fraction": float(inputs.get("fraction", DEFAULT_FRACTION)),
            "angle": float(inputs["angle"]),
        }
    else:
        brace["offset"] = [float(x) for x in point_offset(spec, robot, inputs)]
    brace |= {
        "contact": spec.contact or base_brace.get("contact", "frictionless_point"),
        "point": [float(x) for x in centre],
        "normal": list(spec.normal) if spec.normal is not None else base_brace["normal"],
    }
    region = spec.region_radius if spec.region_radius is not None else base_brace.get("region_radius")
    if region is not None:
        brace["region_radius"] = region
    surface = spec.surface_radius if spec.surface_radius is not None else None
    if surface is not None:
        brace["surface_radius"] = surface
    for key in ("environment_stiffness", "preload", "friction"):
        if key in base_brace:
            brace[key] = base_brace[key]
    data["brace"] = brace
    start = {"guess": [float(x) for x in guess]}
    data["start"] = start
    gp = data.setdefault("gradient_projection", {})
    weights = dict(gp.get("weights", {"k": 0.5, "Ci": 100.0, "d": 0.01}))
    if "angle" in inputs:  # the start solve and gradient projection turn the pad to face the surface
        weights.setdefault("theta_z", PAD_THETA_WEIGHT)
    else:
        weights["theta_z"] = 0.0  # a link point has no pad axis
    if region is None:
        weights["d"] = 0.0
    gp["weights"] = weights
    sim = data.setdefault("simulation", {})
    sim["strategies"] = list(BRACED_STRATEGIES)
    data["name"] = f"{spec.name}-{candidate.id}"
    data["description"] = f"candidate {candidate.id} of sweep {spec.name}"
    return data
