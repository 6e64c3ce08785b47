"""The link meshes a run folder carries (meshes.npz), against the STL files themselves and hostile copies.

Reference: the xArm7's STL files read without coal or assimp (tests/geometry_refs.py), placed in their joint's
frame by Pinocchio's frame placement of the link.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from bracekit.cli import main
from bracekit.errors import InputError
from bracekit.report.output import run_files
from bracekit.viewer.link_meshes import MESH_FILE, load_link_meshes
from bracekit.viewer.scene import SCENE_FILE, load_scene
from geometry_refs import read_stl, xarm_share

VISUAL = "example-robot-data/robots/xarm_description/meshes/xarm7/visual"


def test_the_folder_carries_every_link_mesh_as_the_stl_files_give_it(xarm_run) -> None:
    result, out = xarm_run
    manifest = json.loads((out / ".bracekit-output.json").read_text())
    assert sorted(manifest["files"]) == sorted(run_files(figures=False, meshes=True))
    scene = load_scene(out)
    model = result.scenario.robot.model
    links = {m.link: m for m in scene.meshes}
    assert set(links) == {"link_base", *(f"link{i}" for i in range(1, 8))}
    for link, mesh in links.items():
        corners = read_stl(xarm_share() / VISUAL / f"{link}.stl")  # (t, 3, 3) in the link's frame
        place = model.frames[model.getFrameId(link)].placement  # the link's frame in its joint's
        want = corners.reshape(-1, 3) @ place.rotation.T + place.translation
        got = mesh.vertices.astype(float)[mesh.triangles].reshape(-1, 3)
        assert mesh.triangles.shape[0] == corners.shape[0], link
        assert mesh.joint == model.frames[model.getFrameId(link)].parentJoint
        np.testing.assert_allclose(got.min(axis=0), want.min(axis=0), atol=1e-6)
        np.testing.assert_allclose(got.max(axis=0), want.max(axis=0), atol=1e-6)
        np.testing.assert_allclose(got.mean(axis=0), want.mean(axis=0), atol=1e-6)


def test_a_moved_folder_still_opens_with_its_meshes(xarm_run, tmp_path: Path) -> None:
    _, out = xarm_run
    moved = tmp_path / "elsewhere"
    shutil.copytree(out, moved)
    text = (moved / SCENE_FILE).read_text()
    assert ".stl" not in text.lower() and "package://" not in text  # nothing points back at the URDF's files
    assert len(load_scene(moved).meshes) == len(load_scene(out).meshes) == 8


def test_a_robot_without_meshes_writes_none(short_run) -> None:
    _, out = short_run
    assert not (out / MESH_FILE).exists()
    assert "meshes" not in json.loads((out / SCENE_FILE).read_text())["robot"]
    assert load_scene(out).meshes == ()


def _damaged(xarm_run, tmp_path: Path, **change: np.ndarray) -> Path:
    _, out = xarm_run
    folder = tmp_path / "out"
    shutil.copytree(out, folder)
    with np.load(folder / MESH_FILE) as npz:
        arrays = {k: npz[k] for k in npz.files}
    arrays.update(change)
    np.savez(folder / MESH_FILE, **arrays)
    return folder


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"triangles": np.full((10, 3), 10**6, dtype=np.uint32)}, "do not add up"),
        ({"joints": np.full(8, 99)}, "outside 0…7"),
        ({"vertices": np.full((5, 3), np.nan, dtype=np.float32)}, "do not add up"),
        ({"links": np.arange(8)}, "links is not text"),
    ],
)
def test_a_damaged_mesh_file_is_one_line(xarm_run, tmp_path: Path, capsys, change, message) -> None:
    folder = _damaged(xarm_run, tmp_path, **change)
    with pytest.raises(InputError, match=message):
        load_scene(folder)
    assert main(["view", str(folder), "--port", "0"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0] and "re-run `bracekit run`" in err[0]


def test_a_triangle_naming_another_meshs_vertex_and_a_far_vertex_are_refused(xarm_run, tmp_path: Path) -> None:
    _, out = xarm_run
    with np.load(out / MESH_FILE) as npz:
        triangles, vertices = npz["triangles"].copy(), npz["vertices"].copy()
        counts = npz["vertex_counts"]
    triangles[0, 0] = counts[0]  # one past the first mesh's own vertices
    with pytest.raises(InputError, match="names a vertex it does not have"):
        load_scene(_damaged(xarm_run, tmp_path / "a", triangles=triangles))
    vertices[0] = 1e9
    with pytest.raises(InputError, match="not finite or farther than"):
        load_scene(_damaged(xarm_run, tmp_path / "b", vertices=vertices))
    (Path(tmp_path / "a" / "out") / MESH_FILE).unlink()
    with pytest.raises(InputError, match=r"has no meshes\.npz"):
        load_scene(tmp_path / "a" / "out")


def test_a_mesh_file_declaring_too_many_triangles_is_refused_before_loading(tmp_path: Path) -> None:
    import io
    import zipfile

    path = tmp_path / MESH_FILE
    with zipfile.ZipFile(path, "w") as archive:
        for key, shape in [("triangles", (10**9, 3)), ("vertices", (3, 3))]:
            buffer = io.BytesIO()
            np.lib.format.write_array_header_1_0(buffer, {"descr": "<f4", "fortran_order": False, "shape": shape})
            archive.writestr(f"{key}.npy", buffer.getvalue())
    with pytest.raises(InputError, match="more than"):
        load_link_meshes(path, 7)
