"""scene.json and the Scene rebuilt from a run's output folder, against the run that wrote it."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from bracekit.compliance import compliance_ellipsoids, end_effector_compliance, free_space_compliance
from bracekit.compliance.preloaded import loaded_free_space_compliance, preloaded_compliance
from bracekit.errors import InputError
from bracekit.report.output import run_files
from bracekit.viewer.frames import run_frames
from bracekit.viewer.meshes import capsule_mesh, disk_mesh, sphere_mesh
from bracekit.viewer.scene import SCENE_FILE, load_scene


def test_scene_json_is_listed_among_the_files_written_without_figures(short_run) -> None:
    _, out = short_run
    assert SCENE_FILE in run_files(figures=False)
    manifest = json.loads((out / ".bracekit-output.json").read_text())
    assert sorted(manifest["files"]) == sorted(run_files(figures=False))


def test_round_trip_rebuilds_the_runs_robot_braces_and_path(short_run) -> None:
    result, out = short_run
    scene = load_scene(out)
    sc = result.scenario
    assert scene.name == sc.name and scene.compliance_model == result.compliance_model
    assert set(scene.runs) == set(result.trajectories)
    original, rebuilt = sc.braced, scene.braced
    np.testing.assert_array_equal(rebuilt.robot.stiffness, original.robot.stiffness)
    assert rebuilt.robot.joint_names == original.robot.joint_names and rebuilt.robot.tip == original.robot.tip
    for model, runs in result.trajectories.items():
        for name, tr in runs.items():
            run = scene.runs[model][name]
            np.testing.assert_array_equal(run.q, tr.q)
            np.testing.assert_array_equal(run.t, tr.t)
            assert run.braced == tr.braced
            for q in tr.q[:: max(1, len(tr.q) // 4)]:  # the rebuilt model against the scenario's own
                a, b = original.state(q), rebuilt.state(q)
                np.testing.assert_allclose(b.e, a.e, atol=1e-12)
                np.testing.assert_allclose(b.contacts[0].b, a.contacts[0].b, atol=1e-12)
                np.testing.assert_allclose(b.J_e, a.J_e, atol=1e-12)
    brace = original.brace
    view = scene.braces[0]
    np.testing.assert_allclose(view.point, brace.surface.point)
    np.testing.assert_allclose(view.normal, brace.surface.normal)
    assert view.region_radius == brace.region_radius and view.frame == brace.frame
    ts = np.linspace(0.0, sc.task.duration, len(scene.path))
    np.testing.assert_allclose(scene.path, [sc.task.position(t) for t in ts], atol=1e-12)
    capsules = sc.robot.link_capsules()
    assert len(scene.capsules) == len(capsules)
    for c, d in zip(scene.capsules, capsules, strict=True):
        assert c.joint == d.joint and c.radius == d.radius
        np.testing.assert_allclose(c.a, d.a)
        np.testing.assert_allclose(c.b, d.b)


def test_frames_ellipsoids_equal_the_compliance_of_the_original_model(short_run) -> None:
    result, out = short_run
    scene = load_scene(out)
    braced = result.scenario.braced
    for model, runs in result.trajectories.items():
        for name, tr in runs.items():
            frames = run_frames(scene, scene.runs[model][name])
            for k in (0, len(tr.q) // 2, len(tr.q) - 1):
                state = braced.state(tr.q[k])
                c = end_effector_compliance(state, model) if tr.braced else free_space_compliance(state)
                ell = compliance_ellipsoids(c).translational
                np.testing.assert_allclose(frames.semi_axes[k], ell.semi_axes, rtol=1e-9, atol=1e-15)
                # the same axes up to sign: |axesᵀ axes'| is the identity (distinct semi-axes)
                np.testing.assert_allclose(np.abs(frames.axes[k].T @ ell.axes), np.eye(3), atol=1e-6)
                np.testing.assert_allclose(frames.tip[k], state.e, atol=1e-12)
                np.testing.assert_allclose(frames.brace_points[k, 0], state.contacts[0].b, atol=1e-12)
                for c_ in scene.capsules:  # joint placements carry the capsules: compare the segment's ends
                    m = frames.joints[k, c_.joint - 1]
                    data = braced.robot.model.createData()
                    pin.forwardKinematics(braced.robot.model, data, tr.q[k])
                    np.testing.assert_allclose(m, data.oMi[c_.joint].homogeneous, atol=1e-12)


def test_preloaded_model_ellipsoids_equal_the_preloaded_compliance(preloaded_run) -> None:
    result, out = preloaded_run
    scene = load_scene(out)
    assert scene.compliance_model == "preloaded" and "preloaded" in scene.runs and scene.gravity
    h = result.scenario.holding
    braced = result.scenario.braced
    for name, tr in result.trajectories["preloaded"].items():
        frames = run_frames(scene, scene.runs["preloaded"][name])
        q = tr.q[-1]
        if tr.braced:
            c = preloaded_compliance(braced, q, h.preload, gravity=h.gravity)
        else:
            c = loaded_free_space_compliance(braced, q, gravity=h.gravity)
        np.testing.assert_allclose(frames.semi_axes[-1], compliance_ellipsoids(c).translational.semi_axes, rtol=1e-9)
    assert "contact_force_N" in scene.runs["preloaded"]["braced_min_norm"].measures


def _closed_and_convex_around(vertices: np.ndarray, faces: np.ndarray, inside: list[np.ndarray]) -> None:
    edges: dict[tuple[int, int], int] = {}
    for f in faces:
        for i in range(3):
            a, b = int(f[i]), int(f[(i + 1) % 3])
            edges[(min(a, b), max(a, b))] = edges.get((min(a, b), max(a, b)), 0) + 1
    assert set(edges.values()) == {2}  # closed: every edge between two triangles
    centre = vertices.mean(axis=0)
    for f in faces:
        p0, p1, p2 = vertices[f]
        n = np.cross(p1 - p0, p2 - p0)
        if np.linalg.norm(n) < 1e-14:  # the poles' degenerate triangles
            continue
        assert n @ (centre - p0) < 0  # wound outward
        for x in inside:
            assert n @ (x - p0) < 0  # the point is inside every face's plane


@pytest.mark.parametrize(
    ("a", "b", "radius"),
    [
        ((0, 0, 0), (0, 0, 0.3), 0.04),
        ((0.1, -0.2, 0.05), (0.4, 0.1, -0.2), 0.02),
        ((0.1, 0, 0), (0.1, 0, 0), 0.05),
        ((0, 0, 0), (0, 0, -0.2), 0.03),
    ],
)
def test_capsule_meshes_enclose_the_capsule_endpoints(a, b, radius) -> None:
    a, b = np.array(a, dtype=float), np.array(b, dtype=float)
    vertices, faces = capsule_mesh(a, b, radius)
    _closed_and_convex_around(vertices, faces, [a, b, 0.5 * (a + b)])
    # every vertex at distance radius from the segment [a, b] (brute force over points of the segment)
    seg = a + np.linspace(0.0, 1.0, 2001)[:, None] * (b - a)
    dist = np.min(np.linalg.norm(vertices[:, None, :] - seg[None, :, :], axis=2), axis=1)
    np.testing.assert_allclose(dist, radius, atol=radius * 1e-3 + 1e-6)


def test_shipped_capsules_of_the_run_are_enclosed(short_run) -> None:
    _, out = short_run
    for c in load_scene(out).capsules:
        vertices, faces = capsule_mesh(c.a, c.b, max(c.radius, 0.005))
        _closed_and_convex_around(vertices, faces, [c.a, c.b])


def test_sphere_and_disk_meshes() -> None:
    vertices, faces = sphere_mesh()
    np.testing.assert_allclose(np.linalg.norm(vertices, axis=1), 1.0)
    _closed_and_convex_around(vertices, faces, [np.zeros(3)])
    centre, normal = np.array([0.7, -0.15, -0.3]), np.array([0.0, 0.0, 1.0])
    vertices, faces = disk_mesh(centre, normal, 0.2)
    np.testing.assert_allclose((vertices - centre) @ normal, 0.0, atol=1e-15)
    np.testing.assert_allclose(np.linalg.norm(vertices[1:] - centre, axis=1), 0.2)
    for f in faces:  # counter-clockwise seen from the normal's side
        p0, p1, p2 = vertices[f]
        assert np.cross(p1 - p0, p2 - p0) @ normal > 0


def test_an_output_without_scene_json_asks_to_rerun(short_run, tmp_path: Path) -> None:
    _, out = short_run
    old = tmp_path / "old"
    shutil.copytree(out, old)
    (old / SCENE_FILE).unlink()
    with pytest.raises(InputError, match=r"no scene\.json .*re-run `bracekit run`"):
        load_scene(old)


def test_a_scene_that_does_not_match_its_trajectories_is_refused(short_run, tmp_path: Path) -> None:
    _, out = short_run
    bad = tmp_path / "bad"
    shutil.copytree(out, bad)
    data = json.loads((bad / SCENE_FILE).read_text())
    key = next(iter(data["runs"]))
    data["runs"][key]["tip_first_last"][1][2] += 1e-3
    (bad / SCENE_FILE).write_text(json.dumps(data))
    with pytest.raises(InputError, match="do not belong together"):
        load_scene(bad)


@pytest.mark.parametrize("content", ["not json", '{"format": "other"}', '{"format": "bracekit-scene", "version": 99}'])
def test_unreadable_scene_json_is_an_input_error(short_run, tmp_path: Path, content: str) -> None:
    _, out = short_run
    bad = tmp_path / "bad"
    shutil.copytree(out, bad)
    (bad / SCENE_FILE).write_text(content)
    with pytest.raises(InputError, match="re-run"):
        load_scene(bad)
