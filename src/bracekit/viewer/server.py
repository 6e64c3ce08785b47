"""The viser scene of a run: robot, surfaces, task path, traces, tip compliance ellipsoid and contact forces.

:func:`serve` starts a local viser server (a thread) and returns a :class:`Viewer`; the page is viser's own client,
bundled in its wheel, so nothing is fetched from the network to draw it.
"""

from __future__ import annotations

import contextlib
import errno
import io
import math
import os
import socket
import threading
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pinocchio as pin
from numpy.typing import NDArray

from bracekit.errors import InputError, MissingDependencyError
from bracekit.viewer.bodies import mount, surface_body
from bracekit.viewer.frames import RunFrames, run_frames
from bracekit.viewer.meshes import capsule_mesh, circle_points, cylinder_mesh, disk_mesh, segments_of, sphere_mesh
from bracekit.viewer.scene import BraceView, Scene, load_scene

Array = NDArray[np.float64]

ROBOT_COLOR = (150, 150, 160)
SURFACE_COLOR = (205, 185, 150)
BODY_COLOR = (170, 150, 120)
MOUNT_COLOR = (90, 90, 100)
REGION_COLOR = (60, 120, 220)
PATH_COLOR = (20, 20, 20)
BRACE_COLOR = (240, 140, 20)
TIP_COLOR = (40, 160, 60)
ELLIPSOID_COLOR = (220, 40, 120)
FORCE_COLOR = (200, 30, 30)
#: Largest drawn length of a contact-force arrow, m (the largest force of the run).
FORCE_LENGTH = 0.15
#: No shadows: a shadow map fitted to the visible scene would shade every object anew when a layer is hidden.
NO_SHADOW: dict[str, Any] = {"cast_shadow": False, "receive_shadow": False}
#: Vertical field of view of the initial camera, rad.
FOV = np.radians(50.0)
#: The scene layers that can be hidden (GUI checkboxes and :meth:`Viewer.set_visible`).
LAYERS = ("robot", "surface", "path", "traces", "ellipsoid", "forces")


def drawn_radius(brace: BraceView) -> float:
    """Radius of a brace's surface disk as drawn, m: its surface radius, else 1.6 × the region's (0.15 m)."""
    return brace.surface_radius or 1.6 * (brace.region_radius or 0.15)


def _wxyz(rotation: Array) -> tuple[float, float, float, float]:
    """The unit quaternion (w, x, y, z) of a rotation matrix (a reflection is made a rotation first)."""
    r = np.array(rotation, dtype=float)
    if np.linalg.det(r) < 0:
        r[:, 2] *= -1.0
    q = pin.Quaternion(r)
    return (float(q.w), float(q.x), float(q.y), float(q.z))


def port_free(host: str, port: int) -> bool:
    """Whether a TCP server can listen on (host, port) now; InputError when `host` is not an address of this machine."""
    try:
        infos = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM, flags=socket.AI_PASSIVE)
    except (socket.gaierror, UnicodeError) as exc:
        raise InputError(f"cannot listen on host {host!r}: {exc}; give an address of this machine") from None
    family, _, _, _, address = infos[0]
    with socket.socket(family, socket.SOCK_STREAM) as s:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            s.bind(address)
        except OSError as exc:
            if exc.errno in (errno.EADDRINUSE, errno.EACCES):
                return False
            why = exc.strerror or exc
            raise InputError(f"cannot listen on {host}:{port}: {why}; give an address of this machine") from None
    return True


def default_scale(scene: Scene, frames: RunFrames) -> float:
    """Ellipsoid scale (m per m/N), two significant digits: the run's largest semi-axis drawn at 15 % of the scene."""
    cloud = np.vstack([scene.path, frames.joints[0, :, :3, 3], frames.tip])
    size = 0.5 * float(np.linalg.norm(np.ptp(cloud, axis=0)))
    largest = float(np.max(frames.semi_axes)) if frames.semi_axes.size else 0.0
    if not (largest > 0.0 and size > 0.0):
        return 1.0
    raw = 0.15 * size / largest
    digits = math.floor(math.log10(raw)) - 1
    return float(round(raw / 10**digits) * 10**digits)


def camera_pose(scene: Scene, frames: RunFrames) -> tuple[Array, Array]:
    """(position, look-at) of the initial camera: 20° above, azimuth −60° (the figures' view), all in view.

    In view: the task path, the joints and tip at the first sample, the base frame's origin and the brace points.

    The look-at is moved right of the scene's centre so that the scene sits left of the control panel.
    """
    pts = [scene.path, frames.joints[0, :, :3, 3], frames.tip, np.zeros((1, 3))]  # (the base frame's origin)
    pts += [b.point[None, :] for b in scene.braces]
    cloud = np.vstack(pts)
    lo, hi = cloud.min(axis=0), cloud.max(axis=0)
    centre = 0.5 * (lo + hi)
    radius = max(0.5 * float(np.linalg.norm(hi - lo)), 0.2)
    elev, azim = np.radians(20.0), np.radians(-60.0)
    direction = np.array([np.cos(elev) * np.cos(azim), np.cos(elev) * np.sin(azim), np.sin(elev)])
    right = np.cross(-direction, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    distance = 1.15 * radius / np.tan(0.5 * FOV)
    look_at = centre + 0.35 * radius * right
    return look_at + distance * direction, look_at


@dataclass
class Viewer:
    """A served scene. ``url`` is the page; :meth:`stop` ends the server and the playback thread.

    Attributes:
        scene: the scene drawn.
        server: the viser server (``viser.ViserServer``).
        host, port: where it listens.
        camera: (position, look-at) of the initial camera, m, world.
    """

    scene: Scene
    server: Any
    host: str
    port: int
    camera: tuple[Array, Array]
    nodes: dict[str, Any] = field(default_factory=dict)
    _stop: threading.Event = field(default_factory=threading.Event)
    _thread: threading.Thread | None = None

    @property
    def url(self) -> str:
        """The page's address."""
        host = "localhost" if self.host in ("127.0.0.1", "0.0.0.0", "::", "::1") else self.host
        return f"http://{host}:{self.port}"

    def set_visible(self, layer: str, visible: bool) -> None:
        """Show or hide one of :data:`LAYERS`."""
        if layer not in LAYERS:
            raise InputError(f"unknown layer {layer!r}; choose one of {', '.join(LAYERS)}")
        self.nodes[f"show_{layer}"].value = bool(visible)
        self.nodes[layer].visible = bool(visible)

    def stop(self) -> None:
        """Stop the playback thread and the server."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5.0)
        with contextlib.redirect_stdout(io.StringIO()):
            self.server.stop()


class _Drawing:
    """The scene nodes and GUI of one viewer, updated when the time, run or scale changes."""

    def __init__(self, viewer: Viewer) -> None:
        self.v = viewer
        self.scene = viewer.scene
        self.cache: dict[tuple[str, str], RunFrames] = {}
        self.lock = threading.RLock()

    def frames(self, model: str, strategy: str) -> RunFrames:
        key = (model, strategy)
        if key not in self.cache:
            self.cache[key] = run_frames(self.scene, self.scene.runs[model][strategy])
        return self.cache[key]

    # --- static layers -------------------------------------------------------------------------
    def build(self, frames: RunFrames, scale: float) -> None:
        api = self.v.server.scene
        n = self.v.nodes
        api.set_up_direction("+z")
        for layer in LAYERS:
            n[layer] = api.add_frame(f"/{layer}", show_axes=False)
        self.build_robot()
        for i, b in enumerate(self.scene.braces):
            vertices, faces = disk_mesh(b.point, b.normal, drawn_radius(b))
            api.add_mesh_simple(f"/surface/disk_{i}", vertices, faces, color=SURFACE_COLOR, side="double", **NO_SHADOW)
            body = surface_body(b.point, b.normal, b.surface_radius, drawn_radius(b))
            vertices, faces = cylinder_mesh(body.top - 1e-3 * b.normal, body.bottom, body.radius)
            api.add_mesh_simple(f"/surface/body_{i}", vertices, faces, color=BODY_COLOR, **NO_SHADOW)
            if b.region_radius is not None:
                lift = b.point + 1e-3 * b.normal
                vertices, faces = disk_mesh(lift, b.normal, b.region_radius)
                api.add_mesh_simple(
                    f"/surface/region_{i}",
                    vertices,
                    faces,
                    color=REGION_COLOR,
                    opacity=0.35,
                    side="double",
                    **NO_SHADOW,
                )
                ring = circle_points(lift, b.normal, b.region_radius)
                api.add_line_segments(f"/surface/region_rim_{i}", segments_of(ring), REGION_COLOR, thickness=0.004)
        for i, (_, points, triangles) in enumerate(self.scene.obstacles):  # the further obstacles, as the post
            api.add_mesh_simple(f"/surface/obstacle_{i}", points, triangles, color=BODY_COLOR, **NO_SHADOW)
        api.add_line_segments("/path/task", segments_of(self.scene.path), PATH_COLOR, thickness=0.004)
        vertices, faces = sphere_mesh()
        n["ellipsoid"] = api.add_mesh_simple(
            "/ellipsoid/tip", vertices, faces, color=ELLIPSOID_COLOR, opacity=0.6, scale=(0.01, 0.01, 0.01), **NO_SHADOW
        )
        self.set_run(frames, scale)

    def build_robot(self) -> None:
        """The robot's layer: its link meshes (joint 0's fixed), else its capsules and a mount under the base."""
        api = self.v.server.scene
        n = self.v.nodes
        for i, m in enumerate(self.scene.meshes):
            node = api.add_mesh_simple(
                f"/robot/mesh_{i}_{m.link}", m.vertices, m.triangles, color=ROBOT_COLOR, **NO_SHADOW
            )
            if m.joint > 0:
                n[f"mesh_{i}"] = node
        if self.scene.meshes:
            return
        for i, c in enumerate(self.scene.capsules):
            vertices, faces = capsule_mesh(c.a, c.b, max(c.radius, 0.005))
            n[f"capsule_{i}"] = api.add_mesh_simple(
                f"/robot/{i}_{c.link}", vertices, faces, color=ROBOT_COLOR, **NO_SHADOW
            )
        base = mount()
        vertices, faces = cylinder_mesh(base.top, base.bottom, base.radius)
        api.add_mesh_simple("/robot/mount", vertices, faces, color=MOUNT_COLOR, **NO_SHADOW)

    def set_run(self, frames: RunFrames, scale: float) -> None:
        """Redraw the traces of a newly chosen run."""
        api = self.v.server.scene
        n = self.v.nodes
        for key in ("tip_trace", "tip_dot", "forces"):
            if key in n:
                n.pop(key).remove()
        for key in [k for k in n if k.startswith("brace_")]:
            n.pop(key).remove()
        if frames.tip.shape[0] > 1:
            n["tip_trace"] = api.add_line_segments("/traces/tip", segments_of(frames.tip), TIP_COLOR, thickness=0.003)
        n["tip_dot"] = api.add_icosphere("/traces/tip_dot", 0.012, TIP_COLOR, **NO_SHADOW)
        for i in range(frames.brace_points.shape[1]):
            trace = frames.brace_points[:, i]
            if trace.shape[0] > 1:
                n[f"brace_trace_{i}"] = api.add_line_segments(
                    f"/traces/brace_{i}", segments_of(trace), BRACE_COLOR, thickness=0.003
                )
            n[f"brace_dot_{i}"] = api.add_icosphere(f"/traces/brace_dot_{i}", 0.015, BRACE_COLOR, **NO_SHADOW)
        self.scale = scale

    # --- per-sample update ---------------------------------------------------------------------
    def show(self, frames: RunFrames, forces: list[Array] | None, k: int) -> None:
        n = self.v.nodes
        k = int(np.clip(k, 0, frames.tip.shape[0] - 1))
        with self.v.server.atomic():
            placed = [(f"mesh_{i}", m.joint) for i, m in enumerate(self.scene.meshes) if m.joint > 0]
            if not self.scene.meshes:
                placed = [(f"capsule_{i}", c.joint) for i, c in enumerate(self.scene.capsules)]
            for key, joint in placed:
                m = frames.joints[k, joint - 1]
                n[key].position = m[:3, 3]
                n[key].wxyz = _wxyz(m[:3, :3])
            n["tip_dot"].position = frames.tip[k]
            for i in range(frames.brace_points.shape[1]):
                n[f"brace_dot_{i}"].position = frames.brace_points[k, i]
            ell = n["ellipsoid"]
            ell.position = frames.tip[k]
            ell.wxyz = _wxyz(frames.axes[k])
            semi = np.maximum(self.scale * frames.semi_axes[k], 1e-4)
            ell.scale = (float(semi[0]), float(semi[1]), float(semi[2]))
            if "forces" in n:
                n.pop("forces").remove()
            if forces:
                starts = [frames.brace_points[k, i] for i in range(len(forces))]
                arrows = np.array([[s, s + forces[i][k] * self.scene.braces[i].normal] for i, s in enumerate(starts)])
                if np.any(np.linalg.norm(arrows[:, 1] - arrows[:, 0], axis=1) > 1e-6):
                    n["forces"] = self.v.server.scene.add_arrows(
                        "/forces/contact", arrows, FORCE_COLOR, shaft_radius=0.006, head_radius=0.014, head_length=0.03
                    )


def _forces(scene: Scene, model: str, strategy: str) -> tuple[list[Array] | None, float]:
    """Each brace's arrow length per sample (m) and the largest force (N), from the run's contact_force_N."""
    run = scene.runs[model][strategy]
    if not run.braced:
        return None, 0.0
    k = len(scene.braces)
    keys = [f"contact_force_N_{i}" for i in range(k)] if k > 1 else ["contact_force_N"]
    if not all(key in run.measures for key in keys):
        keys = ["contact_force_N"] * k if "contact_force_N" in run.measures else []
    if not keys:
        return None, 0.0
    values = [np.nan_to_num(np.asarray(run.measures[key], dtype=float), posinf=0.0) for key in keys]
    largest = max(float(np.max(v)) if v.size else 0.0 for v in values)
    if not largest > 0.0:
        return None, 0.0
    return [FORCE_LENGTH * v / largest for v in values], largest


def _legend(scene: Scene, model: str, strategy: str, scale: float, force: float) -> str:
    run = scene.runs[model][strategy]
    kind = "free space" if not run.braced else f"{model} model"
    lines = [
        f"**{scene.name}** — {strategy.replace('_', ' ')} ({kind})",
        "",
        f"Compliance ellipsoid at the tip (magenta): semi-axes = eigenvalues of C_e's force block, drawn at "
        f"**{scale:g} m per m/N** (1 mm/N → {1e-3 * scale * 100:.3g} cm).",
        "",
        ("Grey: links (the URDF's meshes). " if scene.meshes else "Grey: links (capsules). ")
        + "Tan: surface and its body. Blue: bracing region. Black: task path. Green: tip trace. Orange: brace point "
        "trace.",
    ]
    if force > 0.0:
        lines += ["", f"Red arrow: contact force (largest |f_c| along the normal), {FORCE_LENGTH:g} m = {force:.3g} N."]
    s = run.summary
    if s:
        done = "completed" if s.get("completed", True) else f"stopped: {s.get('failure')}"
        ci = s.get("Ci_mean")
        lines += ["", f"Run {done}" + (f"; mean C_i {1e3 * ci:.4g} mm/N." if isinstance(ci, float) else ".")]
    return "\n".join(lines)


def serve(out_dir: str | os.PathLike[str], port: int = 8080, host: str = "127.0.0.1") -> Viewer:
    """Serve the scene of a `bracekit run` output folder with viser; returns once the page can be opened.

    Args:
        out_dir: the run's output folder (with scene.json).
        port: TCP port (0: any free port).
        host: address to listen on (127.0.0.1: this machine only; use ssh -L to reach it from another).

    Raises:
        MissingDependencyError: viser is not installed.
        InputError: the host is not an address of this machine, the port is taken, or the folder is not a run
            output with a readable scene.json.
    """
    try:
        import viser
    except ImportError as exc:
        raise MissingDependencyError(
            f"bracekit view needs viser, which cannot be imported ({exc}): pip install 'bracekit[view]'"
        ) from exc
    if not isinstance(port, int) or isinstance(port, bool) or not 0 <= port <= 65535:
        raise InputError(f"the port must be a number from 0 to 65535, got {port!r}")
    scene = load_scene(out_dir)
    if not port_free(host, port):  # also for port 0: the host must be an address of this machine
        raise InputError(f"port {port} on {host} is in use; choose another with --port")
    model, strategy = scene.models[0], _first_strategy(scene)
    viewer = Viewer(scene, None, host, port, (np.zeros(3), np.zeros(3)))
    drawing = _Drawing(viewer)
    frames = drawing.frames(model, strategy)
    scale = default_scale(scene, frames)
    viewer.camera = camera_pose(scene, frames)
    with contextlib.redirect_stdout(io.StringIO()):  # viser prints its own banner; the caller prints the URL
        server = viser.ViserServer(host=host, port=port, label=f"bracekit: {scene.name}", verbose=False)
    viewer.server = server
    if port != 0 and server.get_port() != port:  # viser moves to the next port when the port is taken
        viewer.stop()
        raise InputError(f"port {port} on {host} is in use; choose another with --port")
    server.gui.configure_theme(show_share_button=False)  # sharing opens a tunnel through viser's servers
    viewer.port = server.get_port()
    server.initial_camera.position = tuple(viewer.camera[0])
    server.initial_camera.look_at = tuple(viewer.camera[1])
    server.initial_camera.up = (0.0, 0.0, 1.0)
    server.initial_camera.fov = float(FOV)
    _gui(viewer, drawing, frames, scale, model, strategy)
    return viewer


def _first_strategy(scene: Scene) -> str:
    names = scene.strategies
    return "braced_gradient_projection" if "braced_gradient_projection" in names else names[0]


def _gui(viewer: Viewer, drawing: _Drawing, frames: RunFrames, scale: float, model: str, strategy: str) -> None:
    scene, server, n = viewer.scene, viewer.server, viewer.nodes
    gui = server.gui
    state: dict[str, Any] = {"model": model, "strategy": strategy, "frames": frames}
    forces, force_max = _forces(scene, model, strategy)
    state["forces"] = forces
    legend = gui.add_markdown(_legend(scene, model, strategy, scale, force_max))
    run = scene.runs[model][strategy]
    t_end = float(run.t[-1]) if run.t.size else 0.0
    step = float(np.min(np.diff(run.t))) if run.t.size > 1 else 1.0
    time_slider = gui.add_slider("time [s]", 0.0, max(t_end, step), step, 0.0, marks=(0.0, max(t_end, step)))
    play = gui.add_checkbox("play", False)
    speed = gui.add_number("speed [×]", 1.0, min=0.1, max=20.0, step=0.1)
    strategy_box = gui.add_dropdown("strategy", list(scene.strategies), initial_value=strategy)
    model_box = gui.add_dropdown("compliance model", list(scene.models), initial_value=model)
    scale_box = gui.add_number("ellipsoid scale [m per m/N]", scale, min=0.0, step=scale / 10.0)
    with gui.add_folder("layers"):
        for layer in LAYERS:
            box = gui.add_checkbox(layer, True)
            n[f"show_{layer}"] = box

            def toggle(_: Any, layer: str = layer, box: Any = box) -> None:
                n[layer].visible = bool(box.value)

            box.on_update(toggle)
    n.update(time=time_slider, play=play, speed=speed, strategy=strategy_box, model=model_box, scale=scale_box)

    def index(t: float) -> int:
        times = scene.runs[state["model"]][state["strategy"]].t
        return int(np.clip(np.searchsorted(times, t - 1e-9), 0, max(times.size - 1, 0)))

    def redraw(_: Any = None) -> None:
        with drawing.lock:
            drawing.scale = float(scale_box.value)
            drawing.show(state["frames"], state["forces"], index(float(time_slider.value)))

    def choose(_: Any = None) -> None:
        with drawing.lock:
            m, s = str(model_box.value), str(strategy_box.value)
            if s not in scene.runs.get(m, {}):
                return
            state.update(model=m, strategy=s, frames=drawing.frames(m, s))
            state["forces"], peak = _forces(scene, m, s)
            drawing.set_run(state["frames"], float(scale_box.value))
            legend.content = _legend(scene, m, s, float(scale_box.value), peak)
            times = scene.runs[m][s].t
            end = float(times[-1]) if times.size else 0.0
            time_slider.max = max(end, time_slider.step)
            if float(time_slider.value) > end:
                time_slider.value = end
            redraw()

    def rescale(_: Any = None) -> None:
        m, s = state["model"], state["strategy"]
        _, peak = _forces(scene, m, s)
        legend.content = _legend(scene, m, s, float(scale_box.value), peak)
        redraw()

    time_slider.on_update(redraw)
    strategy_box.on_update(choose)
    model_box.on_update(choose)
    scale_box.on_update(rescale)
    drawing.build(frames, scale)
    redraw()

    def playback() -> None:
        last = time.monotonic()
        while not viewer._stop.wait(0.05):
            now = time.monotonic()
            if play.value:
                end = float(time_slider.max)
                t = float(time_slider.value) + (now - last) * float(speed.value)
                time_slider.value = 0.0 if t > end + 1e-9 else min(t, end)
            last = now

    viewer._thread = threading.Thread(target=playback, name="bracekit-view-playback", daemon=True)
    viewer._thread.start()
