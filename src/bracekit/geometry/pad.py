"""Placing a brace on a link's collision surface: the pad point and its axis (the surface's inward normal).

Two ways, both in the link's frame (the URDF link's axes, m):

- ``surface = {fraction, angle}``: the link's axis is parallel to the segment from its joint's origin o to the
  origin of the next joint of the chain o' (the tip frame for the last link) and passes through the centroid g
  of the link's collision surface (on links offset from the joint line, like the xArm's or the Panda's, that line
  runs beside the housing; for a capsule it is the joint line). From the axis point
  o + fraction·(o' − o) + P(g − o), P = I − ẑẑᵀ (or, where that point lies outside the link because its
  housing bends away from the line, as the xArm7's forearm does near its wrist, from the centroid of the
  surface's cross-section at that fraction), a ray goes out perpendicular to the axis, at `angle`
  (degrees, right-handed about ẑ) from the reference direction (the link frame's x axis made perpendicular to
  ẑ, its y axis if x is along it); the pad is the link surface's outermost point on that ray's line.
- ``offset`` snapped along a direction: the outermost surface point on the line through `offset` along the
  direction. An offset inside the link's geometry warns (:class:`~bracekit.errors.PadPlacementWarning`) with its
  depth (the distance along the line to the surface).

The surface is every collision element of the link (meshes as they are, primitives tessellated), or the link's
capsules when the URDF has no collision geometry. The rays are cast against its triangles (Möller–Trumbore, all
triangles at once). The pad axis is the inward unit normal of the triangle hit.
"""

from __future__ import annotations

import math
import warnings
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from bracekit._linalg import as_array
from bracekit.errors import ContactError, PadPlacementWarning
from bracekit.geometry.collision import CollisionElement
from bracekit.geometry.pieces import surface_triangles
from bracekit.model.geometry import DEFAULT_LINK_RADIUS, Capsule
from bracekit.model.robot import Robot

Array = NDArray[np.float64]


class PadPlacement(NamedTuple):
    """A pad on a link's surface, in the link's frame.

    Attributes:
        point: the pad point (3,), m.
        axis: the pad axis (3,), the surface's inward unit normal there.
        depth: how far the given offset lay inside the link's geometry (m; 0 for a surface placement or an
            offset outside).
    """

    point: Array
    axis: Array
    depth: float


def _capsule_element(capsule: Capsule) -> CollisionElement:
    """A capsule as a collision element (its axis the element's z)."""
    a, b = np.asarray(capsule.a, dtype=float), np.asarray(capsule.b, dtype=float)
    length = float(np.linalg.norm(b - a))
    place = np.eye(4)
    if length > 0.0:
        z = (b - a) / length
        x = np.cross(z, np.eye(3)[int(np.argmin(np.abs(z)))])
        x /= np.linalg.norm(x)
        place[:3, :3] = np.column_stack([x, np.cross(z, x), z])
    place[:3, 3] = 0.5 * (a + b)
    return CollisionElement(capsule.link, capsule.joint, place, "capsule", (capsule.radius, length))


def link_triangles(robot: Robot, link: str, link_radius: float = DEFAULT_LINK_RADIUS) -> tuple[Array, Array]:
    """(The link's surface triangles (t, 3, 3) in the link's frame, m; the link frame's pose in its joint's (4×4)).

    Its collision elements, or its capsules for a robot without collision geometry.
    """
    fid = robot.frame_id(link)
    frame = robot.model.frames[fid]
    joint = int(frame.parentJoint)
    elements = [e for e in robot.geometry if e.joint == joint and e.link == link]
    if not robot.geometry:
        elements = [_capsule_element(c) for c in robot.link_capsules(link_radius) if c.joint == joint]
    if not elements:
        raise ContactError(f"link {link!r} has no collision geometry to place a pad on; give an offset instead")
    tri = np.concatenate([surface_triangles(e) for e in elements])
    place = np.array(frame.placement.homogeneous, dtype=float)
    inverse = np.linalg.inv(place)
    return tri @ inverse[:3, :3].T + inverse[:3, 3], place


class RayHits(NamedTuple):
    """Where the line origin + t·direction crosses each triangle of a surface (t, 3, 3) (Möller–Trumbore).

    ``hit``: which triangles it crosses (t,); ``t``: the line parameter of each crossing (m per unit of
    direction); ``u``, ``v``: the barycentric coordinates of the crossing along each triangle's edges
    (corner 1 − corner 0, corner 2 − corner 0). Entries where ``hit`` is False are meaningless.
    """

    hit: NDArray[np.bool_]
    t: Array
    u: Array
    v: Array


def ray_hits(tri: Array, origin: Array, direction: Array) -> RayHits:
    """The crossings of the line origin + t·direction (world or link frame, m) with the triangles `tri` (t, 3, 3)."""
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    e1, e2 = b - a, c - a
    p = np.cross(direction, e2)
    det = np.einsum("ij,ij->i", e1, p)
    ok = np.abs(det) > 1e-15
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    s = origin - a
    u = np.einsum("ij,ij->i", s, p) * inv
    qv = np.cross(s, e1)
    v = (qv @ direction) * inv
    t = np.einsum("ij,ij->i", e2, qv) * inv
    return RayHits(ok & (u >= -1e-12) & (v >= -1e-12) & (u + v <= 1.0 + 1e-12), t, u, v)


def _cast(tri: Array, origin: Array, direction: Array) -> tuple[float, Array] | None:
    """(Largest t with origin + t·direction on a triangle, that triangle's unit normal) or None (no hit)."""
    hit, t, _, _ = ray_hits(tri, origin, direction)
    if not hit.any():
        return None
    k = int(np.flatnonzero(hit)[np.argmax(t[hit])])
    normal = np.cross(tri[k, 1] - tri[k, 0], tri[k, 2] - tri[k, 0])
    return float(t[k]), normal / np.linalg.norm(normal)


def _unit(value: ArrayLike, what: str) -> Array:
    v = as_array(value, what, (3,), error=ContactError)
    size = float(np.linalg.norm(v))
    if not size > 0.0:
        raise ContactError(f"{what} must be a non-zero direction")
    return v / size


def snap_to_surface(tri: Array, offset: ArrayLike, direction: ArrayLike, link: str = "the link") -> PadPlacement:
    """The outermost point of the surface `tri` (t, 3, 3) on the line through `offset` along `direction`.

    Warns (PadPlacementWarning) with the depth when `offset` lies inside the surface. ContactError if the line
    misses the link.
    """
    point = as_array(offset, "the pad offset (m)", (3,), error=ContactError)
    d = _unit(direction, "the snap direction")
    found = _cast(tri, point, d)
    if found is None:
        raise ContactError(f"the line through the offset {point.tolist()} along {d.tolist()} misses {link}'s surface")
    t, normal = found
    inward = normal if normal @ d < 0.0 else -normal
    depth = max(t, 0.0) if _inside(tri, point) else 0.0
    if depth > 0.0:
        warnings.warn(
            f"the brace offset {point.tolist()} lies {depth:.4f} m inside the collision geometry of {link}; the pad is "
            "placed on its surface",
            PadPlacementWarning,
            stacklevel=2,
        )
    return PadPlacement(point + t * d, inward, depth)


#: Three skew directions whose crossing parities vote on whether a point is inside a closed surface.
_VOTES = np.array([[0.5773, 0.5774, 0.5773], [-0.31, 0.81, 0.5], [0.2, -0.4, 0.894]])


def _inside(tri: Array, point: Array) -> bool:
    """Whether `point` is inside the closed surface `tri` (parity of crossings along three rays, majority)."""
    votes = 0
    for d in _VOTES:
        hit, t, _, _ = ray_hits(tri, point, d / np.linalg.norm(d))
        votes += int(np.count_nonzero(hit & (t > 0.0))) % 2
    return votes >= 2


def link_axis(robot: Robot, link: str) -> tuple[Array, Array]:
    """(The link's joint origin o, the next joint's origin o') in the link's frame, m."""
    model = robot.model
    frame = model.frames[robot.frame_id(link)]
    joint = int(frame.parentJoint)
    children = [k for k in range(joint + 1, model.njoints) if model.parents[k] == joint]
    if children:
        end = np.array(model.jointPlacements[children[0]].translation)
    else:
        tip = model.frames[robot.tip_id]
        end = np.array(tip.placement.translation) if tip.parentJoint == joint else np.zeros(3)
    inverse = np.linalg.inv(np.array(frame.placement.homogeneous))
    return inverse[:3, 3].copy(), inverse[:3, :3] @ end + inverse[:3, 3]


def link_frame(robot: Robot, link: str, why: str) -> tuple[Array, Array, float, Array, Array]:
    """(o, axis o' − o, its length (m), the unit axis z, a unit x ⟂ z) of `link`, in the link's frame.

    ContactError (ending with `why`) for a link without length between its joint origins.
    """
    o, o_next = link_axis(robot, link)
    axis = o_next - o
    length = float(np.linalg.norm(axis))
    if not length > 1e-9:
        raise ContactError(f"link {link!r} has no length between its joint origins; {why}")
    z = axis / length
    ref = np.eye(3)[0] if abs(z[0]) < 0.99 else np.eye(3)[1]
    x = ref - z * (z @ ref)
    return o, axis, length, z, x / np.linalg.norm(x)


#: How far (m) inside the surface a ray's origin must be, along each axis direction, to count as inside it (a
#: point on a face casts the same pad at every angle that leaves through that face).
_INSIDE_MARGIN = 1e-4


def _well_inside(tri: Array, point: Array) -> bool:
    """Whether `point` and its neighbours _INSIDE_MARGIN away along ±x, ±y, ±z are inside the surface `tri`."""
    return all(
        _inside(tri, point + d)
        for d in np.vstack([np.zeros(3), _INSIDE_MARGIN * np.eye(3), -_INSIDE_MARGIN * np.eye(3)])
    )


def _section_centre(tri: Array, o: Array, z: Array, height: float) -> Array | None:
    """The centroid of the surface's cross-section by the plane ẑᵀ(p − o) = height (m), or None if it misses.

    Each triangle the plane crosses gives a segment; the centroid is of the segments, weighted by their lengths.
    """
    side = np.einsum("tci,i->tc", tri - o, z) - height
    ends = []
    for a, b in ((0, 1), (1, 2), (2, 0)):
        sa, sb = side[:, a], side[:, b]
        crossing = (sa * sb < 0.0) | ((sa == 0.0) & (sb != 0.0))
        t = np.where(crossing, sa / np.where(crossing, sa - sb, 1.0), np.nan)
        ends.append(tri[:, a] + t[:, None] * (tri[:, b] - tri[:, a]))
    points = np.stack(ends, axis=1)  # (t, 3 edges, 3): NaN where an edge does not cross
    crossed = np.sum(~np.isnan(points[:, :, 0]), axis=1) == 2
    if not crossed.any():
        return None
    pairs = points[crossed][~np.isnan(points[crossed][:, :, 0])].reshape(-1, 2, 3)
    weight = np.linalg.norm(pairs[:, 1] - pairs[:, 0], axis=1)
    if not weight.sum() > 0.0:
        return None
    return np.asarray((weight @ pairs.mean(axis=1)) / weight.sum())


def pad_on_surface(robot: Robot, link: str, fraction: float, angle: float) -> PadPlacement:
    """The pad on `link`'s surface at `fraction` of its axis and `angle` (degrees) about it (the module's rule)."""
    if not (isinstance(fraction, int | float) and math.isfinite(fraction)):
        raise ContactError(f"surface.fraction must be a number (0: the link's joint, 1: the next), got {fraction!r}")
    if not (isinstance(angle, int | float) and math.isfinite(angle)):
        raise ContactError(f"surface.angle must be an angle in degrees, got {angle!r}")
    tri, _ = link_triangles(robot, link)
    o, axis, length, z, x = link_frame(robot, link, "give an offset instead")
    y = np.cross(z, x)
    phi = math.radians(angle)
    out = math.cos(phi) * x + math.sin(phi) * y
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    g = (area @ tri.mean(axis=1)) / max(float(area.sum()), 1e-300)
    centre = o + fraction * axis + (g - o) - z * float(z @ (g - o))
    if not _well_inside(tri, centre):  # the line runs beside the housing here: from the cross-section's centroid
        section = _section_centre(tri, o, z, fraction * length)
        if section is not None and _well_inside(tri, section):
            centre = section
    found = _cast(tri, centre, out)
    if found is None or found[0] < 0.0:
        span = (tri.reshape(-1, 3) - o) @ z / length
        raise ContactError(
            f"no surface of link {link!r} on the ray at fraction {fraction:g}, angle {angle:g}° (its collision "
            f"geometry spans the fractions {span.min():.2f} to {span.max():.2f} of its axis); choose another "
            "fraction or angle"
        )
    t, normal = found
    inward = normal if normal @ out < 0.0 else -normal
    return PadPlacement(centre + t * out, inward, 0.0)


def pad_by_offset(robot: Robot, link: str, offset: ArrayLike, direction: ArrayLike) -> PadPlacement:
    """`offset` (m, link frame) snapped to `link`'s surface along `direction` (link frame); see the module."""
    tri, _ = link_triangles(robot, link)
    return snap_to_surface(tri, offset, direction, f"link {link!r}")


def offset_depth(robot: Robot, link: str, offset: ArrayLike) -> float:
    """How far (m) a link point `offset` (link frame) lies inside the link's collision surface; 0 outside.

    The depth is the distance to the surface along the nearest of the six axis directions (a bound of the true
    depth from above).
    """
    tri, _ = link_triangles(robot, link)
    point = as_array(offset, "the brace offset (m)", (3,), error=ContactError)
    if not _inside(tri, point):
        return 0.0
    depths = []
    for d in np.vstack([np.eye(3), -np.eye(3)]):
        found = _cast(tri, point, d)
        if found is not None and found[0] > 0.0:
            depths.append(found[0])
    return min(depths, default=0.0)


def brace_point(
    robot: Robot,
    link: str,
    offset: ArrayLike | None = None,
    surface: object = None,
    snap: ArrayLike | None = None,
) -> tuple[Array, Array | None]:
    """A ``[brace]`` table's link point: (offset (3,), m; the pad axis (3,) or None), in the link's frame.

    `surface` ({fraction, angle}) places it on the link's surface (:func:`pad_on_surface`); `snap` (a direction)
    snaps `offset` to the surface along it (:func:`pad_by_offset`); both give the surface's inward normal as the
    pad axis. A bare `offset` is kept; on a link with collision meshes one inside them warns with its depth.

    Raises:
        ContactError: a malformed `surface`, `surface` with `offset` or `snap`, `snap` without `offset`, or a
            ray that misses the link.
    """
    if surface is not None:
        if offset is not None or snap is not None:
            raise ContactError("give either surface = {fraction, angle} or an offset (with snap), not both")
        if not isinstance(surface, dict) or set(surface) - {"fraction", "angle"} or "fraction" not in surface:
            raise ContactError(
                "surface must be a table {fraction = 0.5, angle = 90.0} (fraction along the link's axis, angle in "
                f"degrees about it, default 0), got {surface!r}"
            )
        pad = pad_on_surface(robot, link, surface["fraction"], surface.get("angle", 0.0))
        return pad.point, pad.axis
    point = np.zeros(3) if offset is None else as_array(offset, "the brace offset (m)", (3,), error=ContactError)
    if snap is not None:
        if offset is None:
            raise ContactError("snap needs the offset to snap (m, link axes)")
        pad = pad_by_offset(robot, link, point, snap)
        return pad.point, pad.axis
    if any(e.kind == "mesh" for e in robot.geometry) and any(e.link == link for e in robot.geometry):
        depth = offset_depth(robot, link, point)
        if depth > 0.0:
            warnings.warn(
                f"the brace offset {point.tolist()} lies {depth:.4f} m inside the collision geometry of link "
                f"{link!r}; place the pad on its surface (surface = {{fraction, angle}} or snap = [x, y, z])",
                PadPlacementWarning,
                stacklevel=2,
            )
    return point, None
