"""Tests of a sweep's pads on the link's surface: the axes (fraction, angle) on the xArm7's forearm.

References: the STL triangles of link4 read without coal (geometry_refs.read_stl): a candidate's point lies on
one of them (barycentric coordinates, the test of test_geometry_pad); the STL vertices placed by Pinocchio at a
candidate's start, their signed distance from the post written out in geometry_refs (a brute-force clearance of
the braced link, the pad's ball left out).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from test_geometry_pad import _on_triangles

from bracekit.studies.sweep.candidates import expand, link_offset
from bracekit.studies.sweep.context import task_context
from bracekit.studies.sweep.evaluate import candidate_scenario, evaluate_candidate
from bracekit.studies.sweep.scenario import point_offset
from bracekit.studies.sweep.spec import SpecError, load_spec
from geometry_refs import read_stl, solid_distance, xarm7
from xarm_post import xarm_post_text

SPEC = """
name = "xarm-pads"
base = "post.toml"
[axes]
link = ["link4"]
{axes}
"""


def _spec(folder: Path, angle: str = "angle = [180.0, 225.0]", place: str = "fraction = [0.3]"):
    (folder / "post.toml").write_text(xarm_post_text(), encoding="utf-8")
    (folder / "spec.toml").write_text(SPEC.format(axes=f"{place}\n{angle}"), encoding="utf-8")
    return load_spec(folder / "spec.toml")


def test_the_angle_axis_puts_each_pad_on_the_link_surface(tmp_path: Path) -> None:
    spec = _spec(tmp_path)
    robot = xarm7()
    mesh = read_stl(next(e.source for e in robot.geometry if e.link == "link4"))  # link frame = joint frame here
    candidates = expand(spec)
    assert [c.inputs["angle"] for c in candidates] == [180.0, 225.0]
    for c in candidates:
        point = point_offset(spec, robot, c.inputs)
        assert len(_on_triangles(point, mesh)) >= 1  # on the STL surface
    # without an angle the point is on the link's axis, inside the forearm (far from every face)
    inside = link_offset(robot, "link4", 0.3)
    assert len(_on_triangles(inside, mesh, tol=1e-3)) == 0


def test_an_angle_goes_with_the_fraction_not_an_offset(tmp_path: Path) -> None:
    with pytest.raises(SpecError, match="angle"):
        _spec(tmp_path, "angle = [0.0]", "offset = [[0.0, 0.0, 0.1]]")


@pytest.mark.slow
def test_no_feasible_candidate_has_its_own_link_inside_the_post(tmp_path: Path) -> None:
    """Each candidate's braced link at the reference start (where its contact closes) against the STL vertices."""
    spec = _spec(tmp_path, "angle = [180.0, 225.0]")
    candidates = expand(spec)
    context = task_context(spec, candidates[0].inputs, candidates[0].context_key)
    assert context.failure is None
    mesh = read_stl(next(e.source for e in xarm7().geometry if e.link == "link4")).reshape(-1, 3)
    inside = 0
    for candidate in candidates:
        sc = candidate_scenario(spec, candidate, context)
        row = evaluate_candidate(spec, candidate, context)
        braced = sc.braced
        data = braced.robot.model.createData()
        q = np.asarray(context.q_ref)
        pin.framesForwardKinematics(braced.robot.model, data, q)
        place = data.oMf[braced.robot.frame_id("link4")]
        points = mesh @ np.array(place.rotation).T + np.array(place.translation)
        pad = np.array(data.oMf[braced.brace_id].translation)
        points = points[np.linalg.norm(points - pad, axis=1) >= braced.brace.pad_radius]
        surface = braced.brace.surface
        brute = float(solid_distance(points, surface.point, surface.normal, braced.brace.obstacle_radius).min())
        if row["feasible"]:
            assert row["valid"] and row["min_link_clearance_m"] >= 0.0
            assert brute >= -5e-3  # the mesh's resolution
        if brute < -5e-3:  # the forearm inside the post at its start: never feasible, and said so
            inside += 1
            assert not row["feasible"] and row["valid"] is False
    assert inside >= 1  # the post's horizontal top cuts the forearm where its pad does not face it
