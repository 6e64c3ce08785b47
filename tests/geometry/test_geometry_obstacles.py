"""Tests of a scenario's further obstacles ([[obstacle]], bracekit.geometry.obstacle_tables) in the clearance.

References: the xArm7's STL vertices and points 3 mm apart on its faces (geometry_refs), placed by Pinocchio,
their signed distance from a box written out here (|max(|R̃ᵀ(p − c)| − h, 0)| outside, the largest face
distance inside) and from the post (geometry_refs.solid_distance): a brute-force clearance within the mesh
resolution; for the paper robot's capsules the closed form of a segment's distance from a sphere's centre
minus both radii; central differences for the gradient.
"""

from __future__ import annotations

import dataclasses
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from test_geometry_distance import MESH_TOLERANCE, POST, Q0, _braced

from bracekit.errors import ScenarioError
from bracekit.geometry.collision import solids_of
from bracekit.geometry.obstacle_tables import with_obstacles
from bracekit.geometry.obstacles import box_obstacle
from bracekit.kinematics import BracedRobot
from bracekit.kinematics.clearance import Clearance
from bracekit.objective import central_difference
from bracekit.simulation.scenario import load_scenario
from geometry_refs import box_triangles, read_stl, solid_distance, surface_points, write_ascii_stl, xarm7
from helpers import scenario_text

HALF = np.array([0.05, 0.04, 0.06])


def _box_distance(points: np.ndarray, pose: np.ndarray) -> np.ndarray:
    """Signed distance (m) of points (k, 3) from the box of half edges HALF at `pose` (4×4)."""
    local = np.abs((points - pose[:3, 3]) @ pose[:3, :3]) - HALF
    outside = np.linalg.norm(np.maximum(local, 0.0), axis=1)
    return outside + np.minimum(local.max(axis=1), 0.0)


def _box_pose(robot, q: np.ndarray) -> np.ndarray:
    """A box turned about z and x, 0.13 m beside the wrist (link6's origin) at q."""
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, q)
    pose = np.eye(4)
    pose[:3, :3] = pin.rpy.rpyToMatrix(0.3, 0.0, 0.5)
    pose[:3, 3] = np.array(data.oMf[robot.frame_id("link6")].translation) + np.array([0.0, 0.13, 0.0])
    return pose


def test_a_box_beside_the_xarm7_counts_as_its_stl_vertices_say() -> None:
    robot = xarm7()
    braced = _braced(robot, tilt=0.1)
    pose = _box_pose(braced.robot, Q0)
    boxed = with_obstacles(braced, [box_obstacle("box", 2.0 * HALF, pose)])
    clearance = Clearance(boxed)
    assert clearance.mesh is not None and len(clearance.mesh.obstacles) == 2
    faces = {e.link: surface_points(read_stl(e.source), 0.003) for e in robot.geometry if e.joint > 0}
    corners = {e.link: read_stl(e.source).reshape(-1, 3) for e in robot.geometry if e.joint > 0}
    surface = braced.brace.surface
    data = boxed.robot.model.createData()
    rng = np.random.default_rng(21)
    near_box = inside = 0
    for q in [Q0, *(Q0 + rng.uniform(-0.2, 0.2, 7) for _ in range(5))]:
        found = {d.joint: d.clearance for d in clearance.links(q, gradient=False)}
        pin.framesForwardKinematics(boxed.robot.model, data, q)
        pad = np.array(data.oMf[boxed.brace_id].translation)
        for link, pts in faces.items():
            place = data.oMf[boxed.robot.frame_id(link)]
            joint = boxed.robot.frame_joint(link)
            values = []
            for cloud in (pts, corners[link]):
                world = cloud @ np.array(place.rotation).T + np.array(place.translation)
                if link == "link4":
                    world = world[np.linalg.norm(world - pad, axis=1) >= boxed.brace.pad_radius]
                post = solid_distance(world, surface.point, surface.normal, POST)
                values.append((float(post.min()), float(_box_distance(world, pose).min())))
            (post, box), (post_corner, box_corner) = values
            brute = min(post, box)
            if brute < 0.0:  # in the box or the post: the deepest point of the link's pieces
                inside += box < 0.0
                assert found[joint] == pytest.approx(brute, abs=MESH_TOLERANCE), (link, q)
            elif brute < 0.1:
                near_box += box < post
                assert found[joint] == pytest.approx(brute, abs=MESH_TOLERANCE), (link, q)
                if min(post_corner, box_corner) > 0.0:
                    assert found[joint] <= min(post_corner, box_corner) + 1e-8  # vertices are points of the mesh
    assert near_box >= 4  # the box is the nearer solid of a link outside it
    assert inside >= 1


@pytest.mark.slow  # central differences of the mesh clearance over every joint: seconds
def test_the_clearance_gradient_with_a_box_matches_central_differences() -> None:
    braced = _braced(xarm7(), tilt=0.1)
    clearance = Clearance(with_obstacles(braced, [box_obstacle("box", 2.0 * HALF, _box_pose(braced.robot, Q0))]))
    rng = np.random.default_rng(22)
    for q in [Q0 + rng.uniform(-0.1, 0.1, 7) for _ in range(3)]:
        for d in clearance.links(q):
            if d.clearance <= 0.0:
                continue
            fd = central_difference(
                lambda x, j=d.joint: {e.joint: e.clearance for e in clearance.links(x, False)}[j], q, 1e-5
            )
            np.testing.assert_allclose(d.gradient, fd, atol=1e-4)


def _paper_with(tmp_path: Path, obstacle: str) -> Path:
    path = tmp_path / "with-obstacle.toml"
    path.write_text(scenario_text(period=2.0) + "\n" + obstacle, encoding="utf-8")
    return path


def test_capsules_count_a_sphere_by_the_closed_form(tmp_path: Path) -> None:
    plain = load_scenario(_paper_with(tmp_path, ""))
    q = plain.guess
    capsules = plain.robot.link_capsules()
    data = plain.robot.model.createData()
    pin.framesForwardKinematics(plain.robot.model, data, q)
    first = capsules[1]  # a link before the brace, far from its pad
    frame = plain.robot.model.getFrameId(plain.robot.model.names[first.joint], pin.FrameType.JOINT)
    place = data.oMf[frame]
    a, b = (np.array(place.rotation) @ p + np.array(place.translation) for p in (first.a, first.b))
    centre = 0.5 * (a + b) + 0.1 * np.cross(b - a, [0.0, 0.0, 1.0]) / np.linalg.norm(np.cross(b - a, [0, 0, 1.0]))
    sc = load_scenario(
        _paper_with(tmp_path, f"[[obstacle]]\nsphere = {{ radius = 0.03 }}\nposition = {centre.tolist()}\n")
    )
    assert len(sc.braced.obstacles) == 1
    with_sphere = {d.joint: d.clearance for d in Clearance(sc.braced).links(q, gradient=False)}
    without = {d.joint: d.clearance for d in Clearance(plain.braced).links(q, gradient=False)}
    for c in capsules:
        if c.link == first.link:
            frame = plain.robot.model.getFrameId(plain.robot.model.names[c.joint], pin.FrameType.JOINT)
            place = data.oMf[frame]
            a, b = (np.array(place.rotation) @ p + np.array(place.translation) for p in (c.a, c.b))
            t = np.clip((centre - a) @ (b - a) / ((b - a) @ (b - a)), 0.0, 1.0)
            closed = float(np.linalg.norm(a + t * (b - a) - centre)) - c.radius - 0.03
            joint = c.joint - 1
            assert with_sphere[joint] == pytest.approx(min(closed, without.get(joint, np.inf)), abs=1e-8)
    assert with_sphere[first.joint - 1] < without[first.joint - 1]  # the sphere is that link's nearest solid


def test_obstacle_tables_read_every_shape_and_a_mesh_beside_the_scenario(tmp_path: Path) -> None:
    write_ascii_stl(tmp_path / "block.stl", box_triangles((50.0, 40.0, 60.0)))  # in mm
    text = """
[[obstacle]]
name = "block"
mesh = "block.stl"
scale = 0.001
position = [1.0, 1.0, 0.5]
[[obstacle]]
box = { size = [0.1, 0.2, 0.3] }
position = [1.0, -1.0, 0.5]
rpy = [0.0, 0.0, 0.3]
[[obstacle]]
cylinder = { radius = 0.05, length = 0.4 }
position = [-1.0, 1.0, 0.5]
[[obstacle]]
sphere = { radius = 0.05 }
position = [-1.0, -1.0, 0.5]
"""
    sc = load_scenario(_paper_with(tmp_path, text))
    names = [o.name for o in sc.braced.obstacles]
    assert names == ["block", "obstacle[2]", "obstacle[3]", "obstacle[4]"]
    block = sc.braced.obstacles[0]
    assert block.radius == pytest.approx(float(np.linalg.norm(HALF)), abs=1e-9)  # the mm mesh scaled to m
    assert Clearance(sc.braced).minimum(sc.guess)[0] < np.inf
    # a run's clearance note names what it measures against: the surface's solid and each obstacle by kind
    assert solids_of(sc.braced) == (
        "the body under the bracing disk (radius 0.15 m) or an obstacle (mesh 'block', box 'obstacle[2]', "
        "cylinder 'obstacle[3]', sphere 'obstacle[4]')"
    )
    plane = dataclasses.replace(sc.braced.brace, region_radius=None, surface_radius=None)
    assert solids_of(BracedRobot(sc.braced.robot, plane)) == "the half-space below the bracing plane"
    two = load_scenario("two-braces").braced
    assert solids_of(two) == "the bodies under the bracing disks (radii 0.15, 0.2 m)"


@pytest.mark.parametrize(
    ("obstacle", "message"),
    [
        ("box = { size = [0.1, 0.1, 0.1] }\nsphere = { radius = 0.1 }", "exactly one shape"),
        ("box = { size = [0.1, -0.1, 0.1] }", "positive edge lengths"),
        ('mesh = "missing.stl"', "missing.stl does not exist"),
        ("sphere = { radius = 0.1 }\nscale = 2.0", "goes with a mesh"),
        ("sphere = { radius = 0.1, height = 2.0 }", "unknown key 'obstacle[1].sphere.height'"),
    ],
)
def test_a_bad_obstacle_is_one_clear_line(tmp_path: Path, obstacle: str, message: str) -> None:
    path = _paper_with(tmp_path, f"[[obstacle]]\n{obstacle}\n")
    with pytest.raises(ScenarioError, match=re.escape(message)):
        load_scenario(path)
    done = subprocess.run(
        [sys.executable, "-m", "bracekit", "run", str(path), "--out", str(tmp_path / "out")],
        capture_output=True,
        text=True,
    )
    assert done.returncode == 2 and len(done.stderr.strip().splitlines()) == 1, done.stderr
    assert message.split("'")[0] in done.stderr
    assert not (tmp_path / "out").exists()


@pytest.mark.slow
def test_the_run_folder_and_figures_draw_each_obstacle(tmp_path: Path) -> None:
    """scene.json carries the box's corners (the viewer draws them); Fig. 2's panels draw its projected hull."""
    pytest.importorskip("matplotlib")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Polygon

    from bracekit import run_scenario
    from bracekit.report.figure_common import _scene
    from bracekit.report.scene import SceneView
    from bracekit.viewer import load_scene

    text = "[[obstacle]]\nbox = { size = [0.2, 0.1, 0.3] }\nposition = [0.3, 0.5, 0.15]\nrpy = [0.0, 0.0, 0.4]\n"
    path = _paper_with(tmp_path, text)
    out = tmp_path / "out"
    done = subprocess.run(
        [sys.executable, "-m", "bracekit", "run", str(path), "--out", str(out)], capture_output=True, text=True
    )
    assert done.returncode in (0, 1), done.stderr[-2000:]
    scene = load_scene(out)
    ((name, vertices, faces),) = scene.obstacles
    rotation = pin.rpy.rpyToMatrix(0.0, 0.0, 0.4)
    corners = np.array([[x, y, z] for x in (-0.1, 0.1) for y in (-0.05, 0.05) for z in (-0.15, 0.15)])
    expected = corners @ rotation.T + [0.3, 0.5, 0.15]
    assert name == "obstacle[1]" and len(faces) == 12
    assert np.allclose(np.sort(vertices, axis=0), np.sort(expected, axis=0), atol=1e-9)

    result = run_scenario(load_scenario(path))
    figure_scene = _scene(result)
    ax = plt.figure().add_subplot()
    SceneView(ax, figure_scene, "braced_gradient_projection")
    hull = figure_scene.camera.project(expected)
    drawn = [p.get_xy() for p in ax.patches if isinstance(p, Polygon) and p.get_zorder() == 0.6]
    assert len(drawn) == 1
    outline = drawn[0][:-1] if np.allclose(drawn[0][0], drawn[0][-1]) else drawn[0]
    # every projected corner on or inside the outline, every outline point a projected corner
    assert all(np.min(np.linalg.norm(hull - p, axis=1)) < 1e-9 for p in outline)
    assert len(outline) >= 4
    plt.close("all")
