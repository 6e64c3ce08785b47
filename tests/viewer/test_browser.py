"""The served page in a real headless Chromium: the robot and the surface are drawn where the camera sees them.

Each layer is checked by hiding it: the pixels that change are the layer's, and they must lie where the layer's
points project with the viewer's camera (computed here with a pinhole model). Requests to any other host than
the viewer's are refused, so the page is shown to draw offline. Set BRACEKIT_VIEWER_PNG to a path to keep the
screenshot (docs/images/viewer.png is made so), BRACEKIT_VIEWER_MESH_PNG for the mesh robot's
(docs/images/viewer-xarm7.png).
"""

from __future__ import annotations

import io
import os
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np
import pytest

CHROMIUM = Path("/usr/bin/chromium")
pytestmark = pytest.mark.skipif(not CHROMIUM.exists(), reason="/usr/bin/chromium is not installed (CI installs it)")

WIDTH, HEIGHT = 1280, 760
FLAGS = [
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--use-gl=angle",
    "--use-angle=swiftshader",
    "--enable-unsafe-swiftshader",
]


def _pixels(png: bytes) -> np.ndarray:
    from PIL import Image

    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=np.int16)


def _settled(page, previous: np.ndarray | None = None, timeout: float = 60.0) -> np.ndarray:
    """A screenshot once the canvas stops changing (and differs from `previous`, when given)."""
    end = time.monotonic() + timeout
    last = _pixels(page.screenshot())
    while time.monotonic() < end:
        time.sleep(0.5)
        now = _pixels(page.screenshot())
        changed = previous is None or np.any(np.abs(now - previous).sum(axis=2) > 30)
        if changed and np.array_equal(now, last):
            return now
        last = now
    raise AssertionError("the page did not settle within the timeout")


def _project(points: np.ndarray, position: np.ndarray, look_at: np.ndarray, fov: float) -> np.ndarray:
    """Pixel (column, row) of world points for a pinhole camera at `position` looking at `look_at`, z up."""
    forward = (look_at - position) / np.linalg.norm(look_at - position)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    d = points - position
    depth = d @ forward
    f = 1.0 / np.tan(0.5 * fov)
    x = f * (d @ right) / depth / (WIDTH / HEIGHT)
    y = f * (d @ up) / depth
    return np.column_stack([(x + 1.0) * 0.5 * WIDTH, (1.0 - y) * 0.5 * HEIGHT])


def _changed(full: np.ndarray, hidden: np.ndarray) -> np.ndarray:
    """Pixels that changed together with their 8 neighbours: areas, not the one-pixel seams at edges that move
    when the renderer changes its resolution (it adapts it to the frame rate)."""
    changed = np.abs(full - hidden).sum(axis=2) > 30
    core = changed.copy()
    core[0, :] = core[-1, :] = core[:, 0] = core[:, -1] = False
    for dr in (-1, 0, 1):
        for dc in (-1, 0, 1):
            core[1:-1, 1:-1] &= changed[1 + dr : changed.shape[0] - 1 + dr, 1 + dc : changed.shape[1] - 1 + dc]
    return core


def _check_layer(
    mask: np.ndarray, pixels: np.ndarray, what: str, margin: float = 40.0, drawn: np.ndarray | None = None
) -> None:
    """The changed pixels are many, lie in the box of the projected points (± margin), and most of the points
    `drawn` (default: all) have changed pixels within 6 px."""
    rows, cols = np.nonzero(mask)
    assert rows.size > 400, f"hiding the {what} changed only {rows.size} pixels"
    lo, hi = pixels.min(axis=0) - margin, pixels.max(axis=0) + margin
    inside = (cols >= lo[0]) & (cols <= hi[0]) & (rows >= lo[1]) & (rows <= hi[1])
    assert inside.mean() > 0.97, f"{what}: {1 - inside.mean():.1%} of the changed pixels lie off its projection"
    near = 0
    drawn = pixels if drawn is None else drawn
    for c, r in drawn:
        r0, c0 = round(r), round(c)
        window = mask[max(r0 - 6, 0) : r0 + 7, max(c0 - 6, 0) : c0 + 7]
        near += bool(window.any())
    assert near >= 0.6 * len(drawn), f"{what}: only {near} of {len(drawn)} projected points are drawn"


def _screens(viewer, layers: tuple[str, ...], keep: str | None) -> dict[str, np.ndarray]:
    """Screenshots of the page in Chromium: 'full', then for each layer the page with it hidden ('no_<layer>',
    shown again after). Requests to any other host than the viewer's are refused and fail the test."""
    from playwright.sync_api import sync_playwright

    external: list[str] = []
    shots: dict[str, np.ndarray] = {}
    profile = tempfile.mkdtemp(prefix="bracekit-chromium-")
    try:
        with sync_playwright() as p:
            browser = p.chromium.launch_persistent_context(
                profile,
                executable_path=str(CHROMIUM),
                headless=True,
                args=FLAGS,
                viewport={"width": WIDTH, "height": HEIGHT},
            )
            try:
                page = browser.new_page()

                def route(request_route) -> None:
                    if request_route.request.url.startswith(viewer.url):
                        request_route.continue_()
                    else:
                        external.append(request_route.request.url)
                        request_route.abort()

                page.route("**/*", route)
                page.goto(viewer.url)
                page.add_style_tag(content=".mantine-Notifications-root { display: none !important; }")
                page.wait_for_selector("canvas", timeout=60_000)  # (the style hides the "software WebGL" notice)
                shots["full"] = last = _settled(page)
                if keep:
                    page.screenshot(path=keep)
                for layer in layers:
                    viewer.set_visible(layer, False)
                    shots[f"no_{layer}"] = _settled(page, last)
                    viewer.set_visible(layer, True)
                    shots[f"with_{layer}"] = last = _settled(page, shots[f"no_{layer}"])
            finally:
                browser.close()
    finally:
        shutil.rmtree(profile, ignore_errors=True)
    assert external == [], f"the page asked for other hosts: {external}"
    return shots


def test_the_page_draws_the_robot_and_the_surface_offline(paper_run) -> None:
    from bracekit.viewer.frames import run_frames
    from bracekit.viewer.server import FOV, serve

    result, out = paper_run
    assert result.completed
    viewer = serve(out, port=0)
    try:
        scene = viewer.scene
        frames = run_frames(scene, scene.runs[scene.models[0]]["braced_gradient_projection"])
        shots = _screens(viewer, ("robot", "surface"), os.environ.get("BRACEKIT_VIEWER_PNG"))
        position, look_at = viewer.camera
    finally:
        viewer.stop()
    assert not scene.meshes  # the paper's URDF has no collision geometry: capsules
    # the robot: both ends of every link capsule at the first sample (and the mount under the base)
    ends = [np.zeros(3)]
    for c in scene.capsules:
        m = frames.joints[0, c.joint - 1]
        ends += [m[:3, :3] @ c.a + m[:3, 3], m[:3, :3] @ c.b + m[:3, 3]]
    _check_layer(_changed(shots["full"], shots["no_robot"]), _project(np.array(ends), position, look_at, FOV), "robot")
    # the surface: its disk's rim bounds the changed pixels; points inside the rim are drawn
    from bracekit.viewer.bodies import surface_body
    from bracekit.viewer.meshes import circle_points
    from bracekit.viewer.server import drawn_radius

    brace = scene.braces[0]
    rim = _project(circle_points(brace.point, brace.normal, drawn_radius(brace), 48), position, look_at, FOV)
    inner = _project(circle_points(brace.point, brace.normal, 0.8 * drawn_radius(brace), 24), position, look_at, FOV)
    body = surface_body(brace.point, brace.normal, brace.surface_radius, drawn_radius(brace))
    bottom = circle_points(body.bottom, brace.normal, body.radius, 48)
    box = np.vstack([rim, _project(bottom, position, look_at, FOV)])  # the surface's body below the disk
    _check_layer(_changed(shots["with_robot"], shots["no_surface"]), box, "surface", drawn=inner)


def test_the_page_draws_a_mesh_robot_where_its_vertices_project(xarm_run) -> None:
    """The xArm7's STL meshes: hiding the robot changes pixels inside the box of its posed mesh vertices, and
    near most of the vertices (the link meshes are drawn, not capsules)."""
    from bracekit.viewer.frames import run_frames
    from bracekit.viewer.server import FOV, serve

    _, out = xarm_run
    viewer = serve(out, port=0)
    try:
        scene = viewer.scene
        frames = run_frames(scene, scene.runs[scene.models[0]]["braced_gradient_projection"])
        shots = _screens(viewer, ("robot",), os.environ.get("BRACEKIT_VIEWER_MESH_PNG"))
        position, look_at = viewer.camera
    finally:
        viewer.stop()
    assert {m.link for m in scene.meshes} >= {"link_base", "link4", "link7"}
    posed = []
    for m in scene.meshes:
        pose = np.eye(4) if m.joint == 0 else frames.joints[0, m.joint - 1]
        posed.append(m.vertices.astype(float) @ pose[:3, :3].T + pose[:3, 3])
    points = np.vstack(posed)
    pixels = _project(points, position, look_at, FOV)
    drawn = pixels[:: max(1, len(pixels) // 400)]
    _check_layer(_changed(shots["full"], shots["no_robot"]), pixels, "xArm7 meshes", margin=8.0, drawn=drawn)
