"""Triangle meshes of the scene's shapes (NumPy only): capsules, cylinders, boxes, spheres, disks and circles."""

from __future__ import annotations

from typing import cast

import numpy as np
from numpy.typing import NDArray

from bracekit.spatial import rotation_with_z

Array = NDArray[np.float64]
Faces = NDArray[np.uint32]


def _frame_z(direction: Array) -> Array:
    """A rotation whose z is `direction` (unit), the identity for a zero direction."""
    norm = float(np.linalg.norm(direction))
    if norm < 1e-12:
        return np.eye(3)
    return rotation_with_z(direction / norm, "the capsule axis")


def capsule_mesh(a: Array, b: Array, radius: float, segments: int = 16, rings: int = 6) -> tuple[Array, Faces]:
    """A capsule: the segment [a, b] grown by `radius` (points in the segment's frame, m).

    Args:
        a: one end point (3,), m.
        b: the other end point (3,), m.
        radius: m (> 0).
        segments: vertices around the axis.
        rings: latitude rings of each end cap.

    Returns:
        vertices (V×3) and triangles (F×3, counter-clockwise seen from outside). Every vertex lies at distance
        `radius` from the segment.
    """
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    axis = b - a
    length = float(np.linalg.norm(axis))
    rot = _frame_z(axis)
    # latitude rings without the poles: the lower cap about a, then the upper cap about b
    phis = np.concatenate([np.linspace(-np.pi / 2, 0.0, rings + 1)[1:], np.linspace(0.0, np.pi / 2, rings + 1)[:-1]])
    heights = np.concatenate([np.zeros(rings), np.full(rings, length)])
    angles = np.linspace(0.0, 2 * np.pi, segments, endpoint=False)
    ring_r = radius * np.cos(phis)
    z = heights + radius * np.sin(phis)
    ring_points = np.stack(
        [
            np.outer(ring_r, np.cos(angles)),
            np.outer(ring_r, np.sin(angles)),
            np.repeat(z[:, None], segments, axis=1),
        ],
        axis=-1,
    ).reshape(-1, 3)
    poles = np.array([[0.0, 0.0, -radius], [0.0, 0.0, length + radius]])
    local = np.vstack([ring_points, poles])
    vertices = a + local @ rot.T
    bottom, top = len(ring_points), len(ring_points) + 1
    last = (len(phis) - 1) * segments
    faces = []
    for j in range(segments):
        faces.append((bottom, (j + 1) % segments, j))
        faces.append((last + j, last + (j + 1) % segments, top))
    for i in range(len(phis) - 1):
        for j in range(segments):
            p, q = i * segments + j, i * segments + (j + 1) % segments
            r, s = p + segments, q + segments
            faces += [(p, q, s), (p, s, r)]
    return vertices, np.asarray(faces, dtype=np.uint32)


def sphere_mesh(subdivisions: int = 12) -> tuple[Array, Faces]:
    """The unit sphere (a capsule of zero length and radius 1), for ellipsoids scaled along their axes."""
    return capsule_mesh(np.zeros(3), np.zeros(3), 1.0, segments=2 * subdivisions, rings=subdivisions // 2)


def circle_points(centre: Array, normal: Array, radius: float, count: int = 96) -> Array:
    """`count` + 1 points of a closed circle (m) about `centre` in the plane of unit `normal`."""
    rot = _frame_z(np.asarray(normal, dtype=float))
    a = np.linspace(0.0, 2 * np.pi, count + 1)
    ring = np.asarray(centre, dtype=float) + radius * (np.outer(np.cos(a), rot[:, 0]) + np.outer(np.sin(a), rot[:, 1]))
    return cast(Array, ring)


def disk_mesh(centre: Array, normal: Array, radius: float, count: int = 96) -> tuple[Array, Faces]:
    """A flat disk about `centre`, its triangles counter-clockwise seen from the side `normal` points to."""
    rim = circle_points(centre, normal, radius, count)[:-1]
    vertices = np.vstack([np.asarray(centre, dtype=float), rim])
    return vertices, np.asarray([(0, 1 + j, 1 + (j + 1) % count) for j in range(count)], dtype=np.uint32)


def segments_of(points: Array) -> Array:
    """A polyline (k×3) as line segments (k−1)×2×3."""
    p = np.asarray(points, dtype=float)
    return np.stack([p[:-1], p[1:]], axis=1)


def cylinder_mesh(a: Array, b: Array, radius: float, segments: int = 48) -> tuple[Array, Faces]:
    """A closed cylinder of axis [a, b] (m), its triangles counter-clockwise seen from outside."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    rot = _frame_z(b - a)
    angles = np.linspace(0.0, 2 * np.pi, segments, endpoint=False)
    rim = radius * (np.outer(np.cos(angles), rot[:, 0]) + np.outer(np.sin(angles), rot[:, 1]))
    vertices = np.vstack([a + rim, b + rim, a, b])
    low, high = 2 * segments, 2 * segments + 1
    faces = []
    for j in range(segments):
        k = (j + 1) % segments
        faces += [
            (j, k, segments + k),
            (j, segments + k, segments + j),
            (low, k, j),
            (high, segments + j, segments + k),
        ]
    return vertices, np.asarray(faces, dtype=np.uint32)


def box_mesh(size: Array) -> tuple[Array, Faces]:
    """A box of edge lengths `size` (3,), m, centred at the origin, its triangles counter-clockwise from outside."""
    h = 0.5 * np.asarray(size, dtype=float)
    vertices = np.array([[x, y, z] for x in (-h[0], h[0]) for y in (-h[1], h[1]) for z in (-h[2], h[2])])
    faces = [
        (0, 1, 3), (0, 3, 2), (4, 6, 7), (4, 7, 5), (0, 4, 5), (0, 5, 1),
        (2, 3, 7), (2, 7, 6), (0, 2, 6), (0, 6, 4), (1, 5, 7), (1, 7, 3),
    ]  # fmt: skip
    return vertices, np.asarray(faces, dtype=np.uint32)
