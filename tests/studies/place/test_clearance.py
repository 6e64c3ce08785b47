"""The moving clearance on a robot with collision meshes (the xArm7): the surface put through a new point.

References: coal's clearance (:class:`MeshClearance`) of the same scenario parsed with its surface through that
point, and central differences of the values in q for the exact gradient.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from bracekit.geometry.distance import MeshClearance
from bracekit.simulation.scenario import load_scenario
from bracekit.studies.place.clearance import MovingClearance

pytestmark = pytest.mark.slow


def _scenario(tmp_path: Path, point: list[float]) -> object:
    from xarm_post import xarm_post_text

    text = xarm_post_text().replace("point = [0.3, 0.0, 0.47]", f"point = [{point[0]!r}, {point[1]!r}, {point[2]!r}]")
    path = tmp_path / f"xarm-{len(list(tmp_path.iterdir()))}.toml"
    path.write_text(text, encoding="utf-8")
    return load_scenario(path)


def test_moving_mesh_clearance_matches_a_fixed_surface_there(tmp_path: Path) -> None:
    sc = _scenario(tmp_path, [0.3, 0.0, 0.47])
    braced = sc.braced  # type: ignore[attr-defined]
    moving = MovingClearance(braced)
    assert moving.mesh is not None  # the xArm7's meshes, not capsules
    q = np.array([0.0, 0.3, 0.0, 1.27, 0.0, 1.57, 0.0])
    b0 = np.array(braced.brace.surface.point, dtype=float)
    b = b0 + np.array([0.02, -0.03, 0.05])
    got = moving.values(q, b)
    # the reference: the scenario with its surface through b, the braced link left out as the placement does
    moved = _scenario(tmp_path, [float(v) for v in b]).braced  # type: ignore[attr-defined]
    skip = int(moved.robot.model.frames[moved.brace_id].parentJoint)
    ref = MeshClearance(moved, [e for e in moved.robot.geometry if e.joint != skip])
    want = np.array([v for _, v, _ in sorted(ref.links(q, False))])
    assert got.shape == want.shape and got.size >= 5
    assert got == pytest.approx(want, abs=1e-9)
    # (∂c/∂q)_b against central differences, ∂c/∂b against the surface moved by hand
    values, dq, db = moving.rows(q, b)
    assert values == pytest.approx(got, abs=1e-12)
    h = 1e-6
    for k in range(q.size):
        e = np.zeros(q.size)
        e[k] = h
        fd = (moving.values(q + e, b) - moving.values(q - e, b)) / (2 * h)
        assert dq[:, k] == pytest.approx(fd, abs=1e-5)
    step = np.array([0.0, 0.0, 1e-3])
    assert db @ step == pytest.approx(moving.values(q, b + step) - got, abs=1e-5)
