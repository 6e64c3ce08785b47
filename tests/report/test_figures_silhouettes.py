"""The figures draw a mesh robot's silhouette: the xArm7's blocks against its STL triangles projected.

Reference: the xArm7's STL files read without coal (tests/geometry_refs.py), each triangle placed by Pinocchio's
frame placements and projected by the figure's camera, filled into an image; the blocks' outlines filled into
another. The outlines must cover the triangles and add little around them.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from PIL import Image, ImageDraw

from geometry_refs import read_stl, xarm7, xarm_share
from xarm_post import xarm_post_text

VISUAL = "example-robot-data/robots/xarm_description/meshes/xarm7/visual"


@pytest.fixture(scope="module")
def xarm_result(tmp_path_factory):
    from bracekit import load_scenario, run_scenario

    path = Path(tmp_path_factory.mktemp("xarm")) / "xarm7.toml"
    path.write_text(xarm_post_text(), encoding="utf-8")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return run_scenario(load_scenario(path))


def _fill(polygons, lo: np.ndarray, scale: float, size: int) -> np.ndarray:
    image = Image.new("1", (size, size), 0)
    draw = ImageDraw.Draw(image)
    for poly in polygons:
        draw.polygon([tuple(p) for p in ((poly - lo) * scale)], fill=1)
    return np.asarray(image, dtype=bool)


def test_the_blocks_cover_the_projected_mesh_and_add_little(xarm_result) -> None:
    from bracekit.report.figure_common import _scene

    scene = _scene(xarm_result)
    assert scene.blocks is not None
    name = "braced_gradient_projection"
    k = len(scene.runs[name].q) // 2
    outlines, _, _, _, order = scene.pieces(name, k)
    assert sorted(order.tolist()) == list(range(len(outlines)))
    robot = xarm7()
    model, data = robot.model, robot.model.createData()
    pin.framesForwardKinematics(model, data, scene.runs[name].q[k])
    triangles = []
    for link in ["link_base", *(f"link{i}" for i in range(1, 8))]:
        corners = read_stl(xarm_share() / VISUAL / f"{link}.stl").reshape(-1, 3)
        pose = data.oMf[model.getFrameId(link)]
        world = corners @ pose.rotation.T + pose.translation
        triangles.append(scene.camera.project(world).reshape(-1, 3, 2))
    tris = np.vstack(triangles)
    lo = tris.reshape(-1, 2).min(axis=0) - 0.02
    hi = tris.reshape(-1, 2).max(axis=0) + 0.02
    size = 600
    scale = size / float(np.max(hi - lo))
    mesh = _fill(tris, lo, scale, size)
    drawn = _fill(outlines, lo, scale, size)
    missed = np.count_nonzero(mesh & ~drawn) / np.count_nonzero(mesh)
    extra = np.count_nonzero(drawn & ~mesh) / np.count_nonzero(mesh)
    assert missed < 0.015, f"{missed:.1%} of the mesh's silhouette is not drawn"
    assert extra < 0.05, f"the outlines add {extra:.1%} of the silhouette's area around it"


def test_a_robot_without_meshes_keeps_its_capsules(paper_result) -> None:
    from bracekit.report.figure_common import _scene

    scene = _scene(paper_result)
    assert scene.blocks is None and scene.piece_face == scene.cap_face


@pytest.fixture(scope="module")
def paper_result(tmp_path_factory):
    from bracekit import load_scenario, run_scenario
    from helpers import scenario_text

    path = Path(tmp_path_factory.mktemp("paper")) / "paper.toml"
    path.write_text(scenario_text(turns=0.05, dt=0.1), encoding="utf-8")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return run_scenario(load_scenario(path))
