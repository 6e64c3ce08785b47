"""Candidates of a sweep: the grid or seeded random expansion of a spec's axes, in a fixed order with stable ids.

A candidate's ``id`` is a hash of its inputs (the same inputs give the same id in any spec); ``index`` is its
place in the expansion order, the order of every table.
"""

from __future__ import annotations

import hashlib
import itertools
import json
from dataclasses import dataclass
from typing import Any

import numpy as np
import pinocchio as pin
from numpy.typing import NDArray

from bracekit.geometry.pad import pad_on_surface
from bracekit.model.robot import Robot

Array = NDArray[np.float64]

#: A link segment shorter than this (m) carries no candidates: its joint and the next one coincide.
MIN_SEGMENT = 1e-9


@dataclass(frozen=True)
class Candidate:
    """One candidate of a sweep: ``inputs`` maps each axis of the spec to its value (SI units)."""

    index: int
    id: str
    inputs: dict[str, Any]

    @property
    def context_key(self) -> str:
        """The inputs that change the task context (everything but where the brace is), as a key."""
        from bracekit.studies.sweep.spec import BRACE_AXES

        return _canonical({k: v for k, v in self.inputs.items() if k not in BRACE_AXES})


def _canonical(inputs: dict[str, Any]) -> str:
    return json.dumps(inputs, sort_keys=True, separators=(",", ":"))


def candidate_id(inputs: dict[str, Any]) -> str:
    """The stable id of a candidate: 12 hex digits of the SHA-256 of its inputs (sorted keys, exact floats)."""
    return hashlib.sha256(_canonical(inputs).encode()).hexdigest()[:12]


def _link_joints(robot: Robot) -> dict[str, int]:
    """Link name → the joint that carries it (its BODY frame's parent joint), links on the chain only."""
    out: dict[str, int] = {}
    for f in robot.model.frames:
        if f.type == pin.FrameType.BODY and int(f.parentJoint) >= 1 and f.name not in robot.off_chain:
            out.setdefault(f.name, int(f.parentJoint))
    return out


def brace_links(robot: Robot) -> tuple[str, ...]:
    """The links a sweep can brace: joints 1..n−1 (a joint beyond them), with a segment to the next joint.

    One link per joint (the joint's first BODY frame), base to tip.
    """
    out: dict[int, str] = {}
    for name, j in _link_joints(robot).items():
        if j < robot.n and j not in out and segment(robot, name)[1] > MIN_SEGMENT:
            out[j] = name
    return tuple(out[j] for j in sorted(out))


def segment(robot: Robot, link: str) -> tuple[Array, float]:
    """The segment of `link` from its joint to the next joint: (the next joint's origin in link axes, length m)."""
    model = robot.model
    frame = model.frames[robot.frame_id(link)]
    j = int(frame.parentJoint)
    nxt = np.asarray(model.jointPlacements[j + 1].translation, dtype=float) if j + 1 < model.njoints else np.zeros(3)
    place = frame.placement
    start = np.asarray(place.rotation).T @ (np.zeros(3) - np.asarray(place.translation))
    end = np.asarray(place.rotation).T @ (nxt - np.asarray(place.translation))
    return np.concatenate([start, end]), float(np.linalg.norm(nxt))


def link_offset(robot: Robot, link: str, fraction: float) -> Array:
    """The point at `fraction` of the segment from the link's joint (0) to the next joint (1), in link axes (m)."""
    ends, _ = segment(robot, link)
    return (1.0 - fraction) * ends[:3] + fraction * ends[3:]


def surface_offset(robot: Robot, link: str, fraction: float, angle: float) -> Array:
    """The pad on `link`'s collision surface at `fraction` of its axis and `angle` (degrees) about it (link axes, m).

    As ``[brace] surface = {fraction, angle}`` places it (:func:`bracekit.geometry.pad.pad_on_surface`): on the
    URDF's meshes or primitives, or on the default capsule of a link without them; never inside the link.
    """
    return np.asarray(pad_on_surface(robot, link, fraction, angle).point, dtype=float)


def expand(spec: Any, limit: int | None = None) -> list[Candidate]:
    """The candidates of a spec, in order: the grid's combinations or the seeded random draws.

    Grid: every combination of the axes' grids, the first axis slowest. Random: ``samples`` draws, each axis in
    spec order (a listed value at random, or uniform in its range).

    Duplicates (same inputs) keep their first place. `limit` keeps the first candidates only.
    """
    names = spec.axis_names
    if spec.mode == "grid":
        combos = (dict(zip(names, values, strict=True)) for values in itertools.product(*(a.grid() for a in spec.axes)))
    else:
        rng = np.random.default_rng(spec.seed)

        def draw() -> dict[str, Any]:
            out: dict[str, Any] = {}
            for a in spec.axes:
                if a.values is not None:
                    out[a.name] = a.values[int(rng.integers(len(a.values)))]
                elif a.kind == "vector":
                    out[a.name] = [float(x) for x in rng.uniform(a.low, a.high)]
                else:
                    out[a.name] = float(rng.uniform(a.low, a.high))
            return out

        combos = (draw() for _ in range(spec.samples))
    out: list[Candidate] = []
    seen: set[str] = set()
    for inputs in combos:
        cid = candidate_id(inputs)
        if cid in seen:
            continue
        seen.add(cid)
        out.append(Candidate(len(out), cid, inputs))
        if limit is not None and len(out) >= limit:
            break
    return out
