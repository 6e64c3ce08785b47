"""`bracekit view` and `bracekit run --view`: one-line errors with exit 2, and a served page."""

from __future__ import annotations

import re
import shutil
import socket
import sys
import urllib.request
from pathlib import Path

import numpy as np
import pytest

from bracekit.cli import main
from bracekit.viewer.scene import SCENE_FILE


def _one_error_line(capsys: pytest.CaptureFixture[str]) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("bracekit: error: "), err
    return err[0]


def test_a_missing_folder(capsys, tmp_path: Path) -> None:
    assert main(["view", str(tmp_path / "nowhere")]) == 2
    assert "is not a folder" in _one_error_line(capsys)


def test_a_folder_that_is_not_a_run_output(capsys, tmp_path: Path) -> None:
    assert main(["view", str(tmp_path)]) == 2
    assert "not the output of `bracekit run`" in _one_error_line(capsys)


def test_an_old_output_without_scene_json(capsys, short_run, tmp_path: Path) -> None:
    _, out = short_run
    old = tmp_path / "old"
    shutil.copytree(out, old)
    (old / SCENE_FILE).unlink()
    assert main(["view", str(old)]) == 2
    assert "re-run `bracekit run`" in _one_error_line(capsys)


def test_viser_missing(capsys, monkeypatch, short_run) -> None:
    _, out = short_run
    monkeypatch.setitem(sys.modules, "viser", None)  # import viser fails, find_spec finds nothing
    assert main(["view", str(out)]) == 2
    assert "pip install 'bracekit[view]'" in _one_error_line(capsys)


@pytest.fixture
def busy_port():
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        s.listen(1)
        yield s.getsockname()[1]


def test_a_busy_port(capsys, short_run, busy_port: int) -> None:
    _, out = short_run
    assert main(["view", str(out), "--port", str(busy_port)]) == 2
    assert f"port {busy_port} on 127.0.0.1 is in use" in _one_error_line(capsys)


def test_run_view_checks_the_port_before_running(capsys, short_scenario_file: Path, tmp_path: Path, busy_port) -> None:
    out = tmp_path / "out"
    code = main(
        [
            "run",
            str(short_scenario_file),
            "--out",
            str(out),
            "--no-figures",
            "--quiet",
            "--view",
            "--view-port",
            str(busy_port),
        ]
    )
    assert code == 2 and "--view-port" in _one_error_line(capsys)
    assert not out.exists()  # refused before any computation or output


@pytest.mark.parametrize("port", ["-1", "65536", "http"])
def test_bad_ports_are_argument_errors(capsys, port: str) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["view", "somewhere", "--port", port])
    assert exc.value.code == 2
    assert "a port is a number from 0 to 65535" in capsys.readouterr().err


def test_serve_answers_with_the_viewer_page(short_run) -> None:
    from bracekit.viewer.server import serve

    _, out = short_run
    viewer = serve(out, port=0)
    try:
        assert viewer.port > 0
        with urllib.request.urlopen(viewer.url, timeout=10) as response:
            page = response.read().decode("utf-8", errors="replace")
        assert response.status == 200 and '<div id="root">' in page
        assert set(viewer.scene.runs) == {"constrained", "projection"}
        for layer in ("robot", "surface"):
            viewer.set_visible(layer, False)
            assert viewer.nodes[layer].visible is False
    finally:
        viewer.stop()


def test_the_controls_move_the_scene_to_the_chosen_sample_and_run(preloaded_run) -> None:
    from bracekit.viewer.frames import run_frames
    from bracekit.viewer.server import FORCE_LENGTH, serve

    _, out = preloaded_run
    viewer = serve(out, port=0)
    try:
        scene, n = viewer.scene, viewer.nodes
        assert n["model"].value == "preloaded" and n["strategy"].value == "braced_gradient_projection"
        run = scene.runs["preloaded"]["braced_gradient_projection"]
        frames = run_frames(scene, run)
        k = len(run.t) - 1
        n["time"].value = float(run.t[k])
        np.testing.assert_allclose(n["ellipsoid"].position, frames.tip[k], atol=1e-12)
        scale = float(n["scale"].value)
        np.testing.assert_allclose(sorted(n["ellipsoid"].scale), sorted(scale * frames.semi_axes[k]), rtol=1e-6)
        # the contact force: from the brace point along the normal, the run's largest force FORCE_LENGTH long
        force = run.measures["contact_force_N"]
        arrow = np.asarray(n["forces"].points, dtype=float)[0]
        np.testing.assert_allclose(arrow[0], frames.brace_points[k, 0], atol=1e-6)
        np.testing.assert_allclose(
            arrow[1] - arrow[0], FORCE_LENGTH * force[k] / force.max() * scene.braces[0].normal, atol=1e-6
        )
        n["strategy"].value = "free_space_min_norm"  # unbraced: no contact force, the free-space ellipsoid
        free = run_frames(scene, scene.runs["preloaded"]["free_space_min_norm"])
        assert "forces" not in n
        np.testing.assert_allclose(n["ellipsoid"].position, free.tip[k], atol=1e-12)
        n["model"].value = "constrained"
        np.testing.assert_allclose(n["ellipsoid"].position, free.tip[k], atol=1e-12)
    finally:
        viewer.stop()


def test_the_documented_address_is_the_one_the_command_prints(short_run) -> None:
    from bracekit.cli.view import DEFAULT_HOST, DEFAULT_PORT
    from bracekit.viewer.scene import load_scene
    from bracekit.viewer.server import Viewer

    _, out = short_run
    printed = Viewer(load_scene(out), None, DEFAULT_HOST, DEFAULT_PORT, (np.zeros(3), np.zeros(3))).url
    root = Path(__file__).resolve().parents[2]
    for doc in ("README.md", "docs/tutorial.md", "docs/viewer.md"):
        text = (root / doc).read_text(encoding="utf-8")
        found = re.findall(rf"http://[\w.:\[\]]+:{DEFAULT_PORT}\b", text)
        assert found and set(found) == {printed}, (doc, found, printed)
