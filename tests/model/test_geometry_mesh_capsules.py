"""Tests of the capsule fits of collision meshes (bracekit.model.geometry.mesh_capsules), used for pictures.

References: the xArm7's STL vertices read without coal (tests/geometry_refs.py); a capsule holds a
point when the point's distance from its segment is at most its radius.
"""

from __future__ import annotations

import numpy as np

from bracekit.model.geometry import _fit
from geometry_refs import read_stl, xarm7


def _segment_distance(points: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    ab = b - a
    t = np.clip((points - a) @ ab / max(float(ab @ ab), 1e-300), 0.0, 1.0) if ab @ ab > 0 else np.zeros(len(points))
    return np.linalg.norm(points - (a + np.outer(t, ab)), axis=1)


def test_each_mesh_gets_tight_capsules_holding_its_vertices() -> None:
    robot = xarm7()
    caps: dict[str, list] = {}
    for c in robot.link_capsules():
        caps.setdefault(c.link, []).append(c)
    assert set(caps) == {f"link{i}" for i in range(1, 8)}  # every moving link's mesh, no default capsule
    for element in robot.geometry:
        if element.joint == 0:
            continue
        place = element.placement
        points = read_stl(element.source).reshape(-1, 3) @ place[:3, :3].T + place[:3, 3]
        inside = np.zeros(len(points), dtype=bool)
        for cap in caps[element.link]:
            d = _segment_distance(points, cap.a, cap.b)
            inside |= d <= cap.radius + 1e-9
            assert d.max() >= cap.radius - 1e-9 or len(caps[element.link]) > 1
        assert inside.all()  # together they hold every vertex
        assert 1 <= len(caps[element.link]) <= 4


def test_one_capsule_is_the_tightest_along_the_principal_axis() -> None:
    robot = xarm7()
    element = next(e for e in robot.geometry if e.link == "link3")
    points = read_stl(element.source).reshape(-1, 3)
    a, b, r = _fit(points)
    d = _segment_distance(points, a, b)
    assert d.max() <= r + 1e-9 and d.max() >= r - 1e-9  # holds every vertex, reaches its radius
    length = float(np.linalg.norm(b - a))
    if length > 2e-3:  # tight: 1 mm shorter at either end lets a vertex out
        axis = (b - a) / length
        assert _segment_distance(points, a + 1e-3 * axis, b).max() > r
        assert _segment_distance(points, a, b - 1e-3 * axis).max() > r
