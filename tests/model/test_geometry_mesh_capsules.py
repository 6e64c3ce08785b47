"""Tests of the capsule fits of collision meshes (bracekit.model.geometry.mesh_capsules), used for pictures.

References: the xArm7's STL vertices read without coal (tests/geometry_refs.py); a capsule holds a
point when the point's distance from its segment is at most its radius.
"""

from __future__ import annotations

import numpy as np

from geometry_refs import read_stl, xarm7


def _segment_distance(points: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    ab = b - a
    t = np.clip((points - a) @ ab / max(float(ab @ ab), 1e-300), 0.0, 1.0) if ab @ ab > 0 else np.zeros(len(points))
    return np.linalg.norm(points - (a + np.outer(t, ab)), axis=1)


def test_each_mesh_gets_the_tightest_capsule_holding_its_vertices() -> None:
    robot = xarm7()
    caps = {c.link: c for c in robot.link_capsules()}
    assert set(caps) == {f"link{i}" for i in range(1, 8)}  # every moving link's mesh, no default capsule
    for element in robot.geometry:
        if element.joint == 0:
            continue
        cap = caps[element.link]
        place = element.placement
        points = read_stl(element.source).reshape(-1, 3) @ place[:3, :3].T + place[:3, 3]
        d = _segment_distance(points, cap.a, cap.b)
        assert d.max() <= cap.radius + 1e-9  # holds every vertex
        assert d.max() >= cap.radius - 1e-9  # the radius is reached
        length = float(np.linalg.norm(cap.b - cap.a))
        if length > 2e-3:  # tight: 1 mm shorter at either end lets a vertex out
            axis = (cap.b - cap.a) / length
            assert _segment_distance(points, cap.a + 1e-3 * axis, cap.b).max() > cap.radius
            assert _segment_distance(points, cap.a, cap.b - 1e-3 * axis).max() > cap.radius
