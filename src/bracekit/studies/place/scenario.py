"""A place's scenario: the sweep's candidate scenario with the pad on the link's capsule surface.

The brace is the link point p(s, φ) (:mod:`bracekit.studies.place.surface`) with its pad axis the surface's
inward normal n(φ); the surface is the spec's plane through the pad point at the start posture (its placement —
the table's height, the post's position — follows the place), and the start guess is that posture. Everything
else (task, weights, strategies, the feasibility rules of the row) is the sweep's
(:func:`bracekit.studies.sweep.scenario.candidate_data`).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from bracekit.simulation.scenario import parse_scenario
from bracekit.simulation.scenario_model import Scenario
from bracekit.studies.place.surface import PadSurface
from bracekit.studies.sweep.candidates import Candidate, candidate_id
from bracekit.studies.sweep.scenario import candidate_data
from bracekit.studies.sweep.spec import POINT_FRAME, SweepSpec

Array = NDArray[np.float64]


class Place(NamedTuple):
    """A pad's place: the link, the fraction s along its axis and the angle φ about it (rad)."""

    link: str
    fraction: float
    angle: float

    @property
    def angle_deg(self) -> float:
        """φ in degrees (the unit of ``surface = {fraction, angle}`` in files)."""
        return math.degrees(self.angle)


def place_candidate(surface: PadSurface, place: Place) -> Candidate:
    """The place as a sweep candidate: inputs link, fraction and the pad point as the link-frame offset (m)."""
    offset = [float(x) for x in surface.point(place.fraction, place.angle)]
    inputs: dict[str, Any] = {"link": place.link, "fraction": float(place.fraction), "offset": offset}
    return Candidate(-1, candidate_id(inputs), inputs)


def pad_world(spec: SweepSpec, surface: PadSurface, place: Place, q: Array) -> Array:
    """The pad point's world position (3,), m, at posture q."""
    robot = spec.base_scenario().robot
    offset = surface.point(place.fraction, place.angle)
    point = robot.with_point_frame(POINT_FRAME, place.link, offset)
    placement, _ = point.frame_kinematics(q, [point.frame_id(POINT_FRAME)])[0]
    return np.asarray(placement[:3, 3], dtype=float)


def place_data(
    spec: SweepSpec, surface: PadSurface, place: Place, q: Array, centre: Array | None = None
) -> dict[str, Any]:
    """The TOML data of the place's scenario, braced at posture q (the start guess); see the module."""
    candidate = place_candidate(surface, place)
    if centre is None:
        centre = pad_world(spec, surface, place, q)
    data = candidate_data(spec, candidate, q, centre)
    data["brace"]["pad_axis"] = [float(x) for x in surface.normal(place.fraction, place.angle)]
    data["name"] = f"{spec.name}-place"
    data["description"] = (
        f"brace on {place.link} at fraction {place.fraction:.4f}, angle {place.angle_deg:.1f}° (bracekit place)"
    )
    robot = data.get("robot", {})
    if isinstance(robot.get("urdf"), str) and not Path(robot["urdf"]).is_absolute():
        robot["urdf"] = str((spec.base_dir / robot["urdf"]).resolve())
    return data


def place_scenario(spec: SweepSpec, surface: PadSurface, place: Place, q: Array) -> Scenario:
    """The place's scenario (parsed), braced at posture q."""
    data = place_data(spec, surface, place, q)
    return parse_scenario(data, base=spec.base_dir, name=data["name"])
