"""Link volumes: each link of the chain as a capsule (a segment and a radius) in its joint's frame.

A capsule comes from the URDF's collision geometry where a link has some: a cylinder (or a ``<capsule>``)
becomes a capsule along its axis with its radius, a sphere a capsule of zero length, a box the bounding
capsule along its longest edge (radius the half-diagonal of the other two edges), a mesh the tightest capsule
along its principal axis (:func:`mesh_capsules`; pictures only: the clearance of a robot with meshes is coal's,
:mod:`bracekit.geometry.distance`). A link without collision geometry gets the default capsule of its joint,
the segment from the joint's origin to the origin of the next joint of the chain (to the tip frame for the
last joint) with the radius ``link_radius`` (:data:`DEFAULT_LINK_RADIUS`). Links fixed to the base do not
move and are left out.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pinocchio as pin
from numpy.typing import NDArray

from bracekit.errors import InputError, ModelError
from bracekit.geometry.collision import CollisionElement

Array = NDArray[np.float64]

#: Radius of a link's default capsule (no usable URDF collision geometry), m.
DEFAULT_LINK_RADIUS = 0.04


@dataclass(frozen=True)
class Capsule:
    """A capsule fixed to a joint of the chain: the segment [a, b] (m, joint frame) grown by `radius` (m).

    Attributes:
        joint: Pinocchio index of the joint that carries it (1..n; joint i + 1 is chain joint i).
        a, b: the segment's end points (3,), m, in the joint's frame.
        radius: m, ≥ 0.
        link: the URDF link it stands for (or the joint's name for a default capsule).
    """

    joint: int
    a: Array
    b: Array
    radius: float
    link: str


def _floats(text: str | None, count: int, default: float = 0.0) -> list[float]:
    """`count` numbers of a URDF attribute (defaults where it is missing)."""
    if text is None:
        return [default] * count
    parts = [float(x) for x in text.split()]
    if len(parts) != count:
        raise InputError(f"a URDF attribute must hold {count} numbers, got {text!r}")
    return parts


def _shape(geometry: ET.Element) -> tuple[Array, Array, float] | None:
    """The capsule (a, b, radius) of one URDF <geometry> in its own frame; None for a mesh or nothing."""
    for child in geometry:
        if child.tag in ("cylinder", "capsule"):
            r, half = float(child.get("radius", "0")), float(child.get("length", "0")) / 2.0
            return np.array([0.0, 0.0, -half]), np.array([0.0, 0.0, half]), r
        if child.tag == "sphere":
            return np.zeros(3), np.zeros(3), float(child.get("radius", "0"))
        if child.tag == "box":
            size = np.abs(np.array(_floats(child.get("size"), 3)))
            axis = int(np.argmax(size))
            others = np.delete(size, axis) / 2.0
            tip = np.zeros(3)
            tip[axis] = size[axis] / 2.0
            return -tip, tip, float(np.hypot(others[0], others[1]))
    return None


def collision_capsules(text: str, model: pin.Model) -> tuple[Capsule, ...]:
    """The capsules of the URDF collision geometry (not meshes) of the links that `model`'s joints move.

    Args:
        text: the URDF text.
        model: the chain's Pinocchio model (links are found as its frames).

    Returns:
        One capsule per usable <collision> element, in its joint's frame; () for text that is not XML.

    Raises:
        ModelError: a collision element's numbers cannot be read.
    """
    try:
        root = ET.fromstring(text)
    except (ET.ParseError, ValueError):
        return ()
    out = []
    for link in root.iter("link"):
        name = link.get("name", "")
        if not model.existFrame(name):
            continue
        frame = model.frames[model.getFrameId(name)]
        if frame.parentJoint == 0:
            continue
        for collision in link.findall("collision"):
            geometry = collision.find("geometry")
            origin = collision.find("origin")
            try:
                shape = None if geometry is None else _shape(geometry)
                xyz = _floats(None if origin is None else origin.get("xyz"), 3)
                rpy = _floats(None if origin is None else origin.get("rpy"), 3)
            except (InputError, ValueError) as exc:
                raise ModelError(f"link {name!r} has a collision element that is not numbers: {exc}") from exc
            if shape is None:
                continue
            place = frame.placement * pin.SE3(pin.rpy.rpyToMatrix(*rpy), np.array(xyz))
            a, b, r = shape
            out.append(Capsule(int(frame.parentJoint), place.act(a), place.act(b), abs(r), name))
    return tuple(out)


def link_capsules(
    model: pin.Model, tip_id: int, collisions: tuple[Capsule, ...] = (), link_radius: float = DEFAULT_LINK_RADIUS
) -> tuple[Capsule, ...]:
    """Every moving joint's capsules: its URDF ones (`collisions`) or else its default capsule.

    Args:
        model: the chain's Pinocchio model.
        tip_id: frame id of the tip {e} (the end of the last joint's default capsule).
        collisions: capsules from :func:`collision_capsules`.
        link_radius: radius of a default capsule, m.
    """
    if not (isinstance(link_radius, int | float) and np.isfinite(link_radius) and link_radius >= 0):
        raise InputError(f"link_radius must be a length ≥ 0 (m), got {link_radius!r}")
    tip = model.frames[tip_id]
    out: list[Capsule] = []
    for j in range(1, model.njoints):
        own = [c for c in collisions if c.joint == j]
        if own:
            out.extend(own)
            continue
        children = [k for k in range(j + 1, model.njoints) if model.parents[k] == j]
        if children:
            end = np.array(model.jointPlacements[children[0]].translation)
        elif tip.parentJoint == j:
            end = np.array(tip.placement.translation)
        else:
            end = np.zeros(3)
        out.append(Capsule(j, np.zeros(3), end, float(link_radius), str(model.names[j])))
    return tuple(out)


#: A mesh's capsule is split in two (its vertices' two clusters, up to twice) when that saves this share of its
#: volume: an elbow housing becomes two or three capsules instead of one ball.
SPLIT_SAVING = 0.15


def _fit(points: Array) -> tuple[Array, Array, float]:
    """The tightest capsule (a, b, radius) along the points' principal axis that holds every point.

    The axis is the principal direction of the points (through their mean); the radius the largest distance of a
    point from that line; the segment the shortest one whose capsule holds every point (each point at axial t
    and distance d from the line needs an end within √(r² − d²) of t).
    """
    mean = points.mean(axis=0)
    _, _, vt = np.linalg.svd(points - mean, full_matrices=False)
    axis = vt[0]
    t = (points - mean) @ axis
    d = np.linalg.norm(points - mean - np.outer(t, axis), axis=1)
    radius = float(d.max())
    reach = np.sqrt(np.maximum(radius * radius - d * d, 0.0))
    start, stop = float(np.min(t + reach)), float(np.max(t - reach))
    if start > stop:  # short: a sphere anywhere in [stop, start] holds every point
        start = stop = 0.5 * (start + stop)
    return mean + start * axis, mean + stop * axis, radius


def _volume(a: Array, b: Array, r: float) -> float:
    return float(np.pi * r * r * np.linalg.norm(b - a) + 4.0 / 3.0 * np.pi * r**3)


def _fits(points: Array, depth: int) -> list[tuple[Array, Array, float]]:
    """One capsule, or those of its two clusters (two-means from the ends of its axis) when they save SPLIT_SAVING."""
    whole = _fit(points)
    if depth == 0 or len(points) < 8:
        return [whole]
    centred = points - points.mean(axis=0)
    t = centred @ np.linalg.svd(centred, full_matrices=False)[2][0]  # along the principal axis
    centres = points[[int(np.argmin(t)), int(np.argmax(t))]]
    for _ in range(20):  # two-means from the two ends
        near = np.linalg.norm(points - centres[0], axis=1) <= np.linalg.norm(points - centres[1], axis=1)
        if near.all() or not near.any():
            return [whole]
        centres = np.array([points[near].mean(axis=0), points[~near].mean(axis=0)])
    halves = [points[near], points[~near]]
    if min(len(h) for h in halves) < 4:
        return [whole]
    parts = [f for h in halves for f in _fits(h, depth - 1)]
    if sum(_volume(*f) for f in parts) <= (1.0 - SPLIT_SAVING) * _volume(*whole):
        return parts
    return [whole]


def mesh_capsules(elements: Sequence[CollisionElement]) -> tuple[Capsule, ...]:
    """Tight capsules of each moving mesh, in its joint's frame (for pictures).

    One capsule along the mesh's principal axis (:func:`_fit`), split into its two clusters' capsules (two-means
    from the ends of the axis; up to four in all) when that saves SPLIT_SAVING of the volume; together they hold
    every vertex.
    The clearance of a robot with meshes is coal's (:mod:`bracekit.geometry.distance`), not these capsules'.
    """
    out: list[Capsule] = []
    for e in elements:
        if e.kind != "mesh" or e.joint <= 0 or e.vertices is None:
            continue
        points = e.vertices @ e.placement[:3, :3].T + e.placement[:3, 3]
        out.extend(Capsule(e.joint, a, b, r, e.link) for a, b, r in _fits(points, 2))
    return tuple(out)
