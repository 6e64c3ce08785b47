"""A run's scene seen through an orthographic camera: link volumes, surfaces, task, traces (world m → screen m).

:class:`RunScene` holds what every drawing of a run shares: the camera, the robot's link capsules in parts
(each part one colour pair, alternating link by link), each brace's surface (the obstacle's top disk and the
column below it, or the whole plane) and bracing region, the task path, and every run's tip and brace-point
traces. :class:`SceneView` draws it into one 2-D matplotlib axes and redraws only the robot, its traces and
the brace points when the sample changes (the artists are made once and updated).

Occlusion is drawn by layers: each capsule is split where it crosses a brace plane; the pieces on the far
side of a plane (seen from the camera) are drawn before that surface (translucent), the others after it, and
within a layer the pieces are drawn far to near.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import pinocchio as pin
from matplotlib.artist import Artist
from matplotlib.axes import Axes
from matplotlib.patches import Polygon
from numpy.typing import NDArray

from bracekit.geometry.obstacles import obstacle_mesh
from bracekit.model.chain import DATA_JOINT_LIMIT
from bracekit.report.camera import choose_camera
from bracekit.report.projection import OrthoCamera, capsule_outlines, circle_points, convex_hull
from bracekit.report.silhouettes import block_pieces, mesh_blocks

if TYPE_CHECKING:
    from bracekit.model.robot import Robot
    from bracekit.simulation.run import RunResult
    from bracekit.simulation.simulate import Trajectory

Array = NDArray[np.float64]
IntArray = NDArray[np.intp]

#: Colours of the robot's parts (light, dark per part, alternating link by link).
PART_COLORS = (("#b9c4d0", "#93a3b5"), ("#5a5f66", "#383c42"), ("#c8b48a", "#a8946a"))
SURFACE_COLOR = "#d8c8a0"
EDGE_COLOR = "0.2"
REGION_COLOR = "tab:purple"
BRACE_COLOR = "tab:orange"
TASK_COLOR = "k"
BASE_COLOR = "0.15"
#: Colour of each strategy's tip trace.
STRATEGY_COLORS = {
    "free_space_min_norm": "tab:red",
    "braced_min_norm": "tab:blue",
    "braced_gradient_projection": "tab:green",
    "braced_qp": "tab:purple",
}
#: Names of the shipped robots' parts: URDF robot name → ((label, joints), ...), base to tip.
NAMED_PARTS = {"paper_robot": (("PUMA 560", 6), ("HEBI X8-16 modules", 5))}
_BASE_RADIUS = 0.09  # m, the base plate drawn at the world origin
_CAP_POINTS = 7  # points per half circle of a capsule outline
#: Samples of each run whose link volumes set the drawing's limits and judge the camera.
SURVEY_SAMPLES = 41


@dataclass(frozen=True)
class Part:
    """Links of the robot drawn in one colour pair.

    Attributes:
        label: legend text, e.g. "PUMA 560 (joints 1–6)".
        joints: Pinocchio joint indices of the part (1..n).
        colors: light and dark colour, alternating link by link.
    """

    label: str
    joints: tuple[int, ...]
    colors: tuple[str, str]


def robot_parts(robot: Robot, brace_frames: tuple[str, ...]) -> tuple[Part, ...]:
    """The robot's parts: the named parts of a shipped robot, else the links up to the first brace and past it."""
    n = robot.n
    named = NAMED_PARTS.get(str(robot.model.name))
    if named is not None and sum(count for _, count in named) == n:
        spans, start = [], 1
        for label, count in named:
            spans.append((label, start, start + count - 1))
            start += count
    else:
        k = max(robot.frame_joint(brace_frames[0]) + 1, 1) if brace_frames else n
        spans = [("links up to the brace", 1, k)] + ([("links past the brace", k + 1, n)] if k < n else [])
    parts = []
    for i, (label, lo, hi) in enumerate(spans):
        joints = f"joint {lo}" if lo == hi else f"joints {lo}–{hi}"
        parts.append(Part(f"{label} ({joints})", tuple(range(lo, hi + 1)), PART_COLORS[i % len(PART_COLORS)]))
    return tuple(parts)


@dataclass(frozen=True)
class _Plane:
    """A brace surface as drawn: its top (disk or plane patch), the column below a disk, its region circle."""

    point: Array
    normal: Array
    top: Array  # (k, 3) outline of the top, world
    column: Array | None  # (h, 2) screen outline of the column below the disk, or None (a plane)
    region: Array | None  # (k, 3) bracing-region circle, world


class RunScene:
    """The geometry of a run for drawing: camera, capsules, surfaces, task path and every run's traces.

    Args:
        result: the run.
        runs: the trajectories to draw (strategy name → run), e.g. the run model's.
        camera: the view; None: chosen from the scene (:func:`choose_camera`).
    """

    def __init__(self, result: RunResult, runs: dict[str, Trajectory], camera: OrthoCamera | None = None) -> None:
        sc = result.scenario
        robot = sc.robot
        self.robot = robot
        self.runs = runs
        self.braces = sc.braced.braces
        self._fk = robot.chain
        self._brace_ids = [robot.frame_id(b.frame) for b in self.braces]
        caps = robot.link_capsules()
        self.parts = robot_parts(robot, tuple(b.frame for b in self.braces))
        self.cap_joint = np.array([c.joint for c in caps], dtype=np.intp)
        self.cap_a = np.array([c.a for c in caps], dtype=float).reshape(-1, 3)
        self.cap_b = np.array([c.b for c in caps], dtype=float).reshape(-1, 3)
        self.cap_r = np.array([c.radius for c in caps], dtype=float)
        self.cap_face = self._colors(self.cap_joint)
        #: a mesh robot's blocks (:mod:`bracekit.report.silhouettes`), drawn instead of its capsules
        self.blocks = mesh_blocks(robot)
        self.piece_face = self.cap_face if self.blocks is None else self._colors(self.blocks.joint)
        ts = np.linspace(0.0, sc.task.duration, 241)
        self.task_path = np.array([sc.task.position(t) for t in ts])
        self._model = robot.model
        self._data = robot.model.createData() if robot.n <= DATA_JOINT_LIMIT else None
        #: tip (N, 3) and brace points (N, braces, 3) of each run, world m
        self.tips: dict[str, Array] = {}
        self.brace_points: dict[str, Array] = {}
        self._cache: dict[tuple[str, int], tuple[Array, Array]] = {}
        #: capsule ends (S, m, 3) twice at up to SURVEY_SAMPLES samples of each run (limits, camera)
        self._ends: dict[str, tuple[Array, Array]] = {}
        for name, tr in runs.items():
            self.tips[name], self.brace_points[name] = self._points(tr.q)
            ks = np.unique(np.linspace(0, tr.q.shape[0] - 1, min(SURVEY_SAMPLES, tr.q.shape[0])).astype(int))
            pairs = [self.capsule_ends(name, int(k)) for k in ks]
            self._ends[name] = (np.array([p[0] for p in pairs]), np.array([p[1] for p in pairs]))
        ends = np.vstack([np.concatenate([a, b], axis=1).reshape(-1, 3) for a, b in self._ends.values()])
        main = self._ends.get("braced_gradient_projection") or next(iter(self._ends.values()))
        self.camera = camera if camera is not None else choose_camera(main, self.cap_r, self.task_path)
        first = np.array(robot.model.jointPlacements[1].translation) if robot.model.njoints > 1 else np.zeros(3)
        #: the base: a plate at the world origin and, when joint 1 sits away from it, a column up to joint 1
        self.base_column = (np.zeros(3), first, float(max(self.cap_r[:1].max(initial=0.0), 0.04)))
        if self.blocks is not None and np.any(self.blocks.joint == 0):  # the base link's own mesh is drawn
            self.base_column = (np.zeros(3), np.zeros(3), 0.0)
        self.planes = self._planes(ends)
        #: the environment's further solids: each one's vertices (k, 3), m, base frame (convex: its silhouette is
        #: the hull of their projection)
        self.obstacles = [obstacle_mesh(o)[0] for o in sc.braced.obstacles]
        self.limits = self._limits()

    # --- geometry ---------------------------------------------------------------------------------------
    def _colors(self, joints: IntArray) -> list[str]:
        """Each piece's fill: its part's light and dark colour, alternating link by link (the base's: grey)."""
        face = []
        for j in joints:
            if int(j) == 0:
                face.append("0.45")
                continue
            part = next((p for p in self.parts if int(j) in p.joints), None)
            face.append(PART_COLORS[0][0] if part is None else part.colors[part.joints.index(int(j)) % 2])
        return face

    def _points(self, q: Array) -> tuple[Array, Array]:
        """Tips (N, 3) and brace points (N, B, 3), world m, of configurations q (N, n)."""
        count = q.shape[0]
        tips = np.empty((count, 3))
        bps = np.empty((count, len(self._brace_ids), 3))
        tip_id, model, data = self.robot.tip_id, self._model, self._data
        for i in range(count):
            if data is not None:
                pin.forwardKinematics(model, data, q[i])
                tips[i] = pin.updateFramePlacement(model, data, tip_id).translation
                for k, f in enumerate(self._brace_ids):
                    bps[i, k] = pin.updateFramePlacement(model, data, f).translation
                continue
            pose = self._fk.pose(q[i])
            tips[i] = self._fk.frame_placement(pose, tip_id)[:3, 3]
            for k, f in enumerate(self._brace_ids):
                bps[i, k] = self._fk.frame_placement(pose, f)[:3, 3]
        return tips, bps

    def capsule_ends(self, name: str, k: int) -> tuple[Array, Array]:
        """Capsule end points a, b (m, 3), world m, of run `name` at sample k."""
        key = (name, k)
        if key not in self._cache:
            q = self.runs[name].q[k]
            if self._data is not None:
                pin.forwardKinematics(self._model, self._data, q)
                oMi = self._data.oMi
                rot = np.array([oMi[int(j)].rotation for j in self.cap_joint])
                org = np.array([oMi[int(j)].translation for j in self.cap_joint])
            else:
                pose = self._fk.pose(q)
                rot, org = pose.rotations[self.cap_joint], pose.origins[self.cap_joint]
            a = np.einsum("mij,mj->mi", rot, self.cap_a) + org
            b = np.einsum("mij,mj->mi", rot, self.cap_b) + org
            self._cache[key] = (a, b)
        return self._cache[key]

    def _planes(self, points: Array) -> list[_Plane]:
        cam = self.camera
        span = float(np.max(np.ptp(np.vstack([points, self.task_path]), axis=0)))
        planes = []
        for brace in self.braces:
            s = brace.surface
            radius = brace.obstacle_radius
            region = None if brace.region_radius is None else circle_points(s.point, s.normal, brace.region_radius)
            if radius is None:  # the whole plane: a square patch around the scene's foot point on it
                centre = points.mean(axis=0)
                foot = centre - s.normal * float(s.normal @ (centre - s.point))
                u, w = s.frame[:, 0], s.frame[:, 1]
                h = 0.6 * span
                top = foot + h * np.array([u + w, -u + w, -u - w, u - w])
                planes.append(_Plane(s.point, s.normal, top, None, region))
                continue
            top = circle_points(s.point, s.normal, radius)
            base = top - s.normal * span
            column = convex_hull(cam.project(np.vstack([top, base])))
            planes.append(_Plane(s.point, s.normal, top, column, region))
        order = np.argsort([float(cam.depth(p.point)) for p in planes])  # far first
        return [planes[i] for i in order]

    def _limits(self) -> tuple[float, float, float, float]:
        """(x0, x1, y0, y1), screen m: everything but the columns and whole planes, with a margin."""
        cam = self.camera
        a0, b0, r0 = self.base_column
        pts = [
            cam.project(self.task_path),
            cam.project(_base_disk()),
            cam.project(np.array([a0, b0])) + r0,
            cam.project(np.array([a0, b0])) - r0,
        ]
        for plane in self.planes:
            if plane.column is not None:
                pts.append(cam.project(plane.top))
            if plane.region is not None:
                pts.append(cam.project(plane.region))
        for a, b in self._ends.values():
            grow = self.cap_r[None, :, None]
            for ends in (cam.project(a), cam.project(b)):
                pts.append((ends - grow).reshape(-1, 2))
                pts.append((ends + grow).reshape(-1, 2))
        for tips in self.tips.values():
            pts.append(cam.project(tips))
        pts += [cam.project(vertices) for vertices in self.obstacles]
        allp = np.vstack(pts)
        lo, hi = allp.min(axis=0), allp.max(axis=0)
        pad = 0.03 * float(np.max(hi - lo))
        return float(lo[0] - pad), float(hi[0] + pad), float(lo[1] - pad), float(hi[1] + pad)

    def free_corners(self, size: tuple[float, float] = (0.3, 0.25)) -> list[str]:
        """The panel's corners ("lower left", "lower right", "upper left", "upper right"), emptiest first.

        Args:
            size: a corner's width and height as fractions of the panel's.
        """
        x0, x1, y0, y1 = self.limits
        cam = self.camera
        pts = [cam.project(self.task_path)]
        for a, b in self._ends.values():
            step = max(1, a.shape[0] // 40)
            pts += [cam.project(a[::step]).reshape(-1, 2), cam.project(b[::step]).reshape(-1, 2)]
        pts += [cam.project(p.top) for p in self.planes if p.column is not None]
        a0, b0, _r0 = self.base_column
        pts.append(cam.project(a0 + np.linspace(0.0, 1.0, 9)[:, None] * (b0 - a0)))
        pts.append(cam.project(_base_disk()))
        allp = np.vstack(pts)
        u = (allp[:, 0] - x0) / (x1 - x0)
        v = (allp[:, 1] - y0) / (y1 - y0)
        w, h = size
        boxes = {
            "lower left": (u < w) & (v < h),
            "lower right": (u > 1 - w) & (v < h),
            "upper left": (u < w) & (v > 1 - h),
            "upper right": (u > 1 - w) & (v > 1 - h),
        }
        return sorted(boxes, key=lambda k: int(np.count_nonzero(boxes[k])))

    @property
    def aspect(self) -> float:
        """Width over height of the drawn region."""
        x0, x1, y0, y1 = self.limits
        return (x1 - x0) / (y1 - y0)

    def pieces(self, name: str, k: int) -> tuple[Array, IntArray, IntArray, Array, IntArray]:
        """The capsules of run `name` at sample k split at the brace planes (a mesh robot's blocks), in drawing order.

        Returns:
            Screen outlines (p, m, 2), the capsule (block) of each piece (p,), index of its fill in `piece_face`,
            and each piece's layer (p,) (2j + 1: in front of the j farthest planes), depth (p,) and drawing order
            (indices into the first three, far to near within a layer).
        """
        if self.blocks is not None:
            q = self.runs[name].q[k]
            if self._data is not None:
                pin.forwardKinematics(self._model, self._data, q)
                rot = np.array([m.rotation for m in self._data.oMi])
                org = np.array([m.translation for m in self._data.oMi])
            else:
                pose = self._fk.pose(q)
                rot, org = pose.rotations, pose.origins
            return block_pieces(self.blocks, self.planes, self.camera, rot, org)
        a, b = self.capsule_ends(name, k)
        cam = self.camera
        ts = [np.zeros(a.shape[0]), np.ones(a.shape[0])]
        for plane in self.planes:
            facing = 1.0 if float(plane.normal @ cam.toward) >= 0.0 else -1.0
            ha = facing * ((a - plane.point) @ plane.normal)
            hb = facing * ((b - plane.point) @ plane.normal)
            with np.errstate(divide="ignore", invalid="ignore"):
                ts.append(np.where((ha * hb < 0.0), ha / (ha - hb), np.nan))
        cuts = np.sort(np.column_stack(ts), axis=1)  # per capsule: 0, its crossings, 1, then nan
        t0, t1 = cuts[:, :-1], cuts[:, 1:]
        uncut = (np.count_nonzero(np.isfinite(cuts), axis=1) == 2)[:, None]  # keep a capsule of zero length
        with np.errstate(invalid="ignore"):
            keep = np.isfinite(t1) & ((t1 - t0 > 1e-12) | uncut)
        cap, col = np.nonzero(keep)  # capsule by capsule, along each
        d = b[cap] - a[cap]
        pa = a[cap] + t0[cap, col][:, None] * d
        pb = a[cap] + t1[cap, col][:, None] * d
        mid = 0.5 * (pa + pb)
        layer = np.ones(cap.size, dtype=np.intp)
        for j, plane in enumerate(self.planes):
            facing = 1.0 if float(plane.normal @ cam.toward) >= 0.0 else -1.0
            front = facing * ((mid - plane.point) @ plane.normal) >= 0.0
            layer = np.where(front, 2 * (j + 1) + 1, layer)
        depth = cam.depth(mid)
        outlines = capsule_outlines(cam.project(pa), cam.project(pb), self.cap_r[cap], _CAP_POINTS)
        order = np.lexsort((depth, layer))
        return outlines, cap, layer, depth, order


def _base_disk() -> Array:
    return circle_points(np.zeros(3), np.array([0.0, 0.0, 1.0]), _BASE_RADIUS, 36)


class SceneView:
    """One run of a :class:`RunScene` drawn in a 2-D axes; :meth:`show` moves the robot to a sample.

    Args:
        ax: the axes (limits, aspect and frame are set here).
        scene: the scene.
        name: the run (strategy) drawn.
        animated: mark the changing artists animated (drawn by the caller, e.g. when blitting frames).
        trace_width: line width of the tip trace, pt.
        samples: the only samples :meth:`show` is given (default: any); then only as many artists for the link
            pieces are made as these samples draw.
    """

    def __init__(
        self,
        ax: Axes,
        scene: RunScene,
        name: str,
        animated: bool = False,
        trace_width: float = 1.6,
        samples: Sequence[int] | None = None,
    ) -> None:
        self.ax, self.scene, self.name = ax, scene, name
        cam = scene.camera
        x0, x1, y0, y1 = scene.limits
        ax.set_xlim(x0, x1)
        ax.set_ylim(y0, y1)
        ax.set_aspect("equal", adjustable="box")
        ax.set_axis_off()
        self.surfaces: list[list[Artist]] = []
        for j, plane in enumerate(scene.planes):
            z = 2.0 * (j + 1)
            arts: list[Artist] = []
            if plane.column is not None:
                arts.append(
                    ax.add_artist(Polygon(plane.column, closed=True, fc=SURFACE_COLOR, ec="none", alpha=0.35, zorder=z))
                )
            arts.append(
                ax.add_artist(
                    Polygon(
                        cam.project(plane.top),
                        closed=True,
                        fc=SURFACE_COLOR,
                        ec="#8a7a50",
                        lw=0.8,
                        alpha=0.7,
                        zorder=z + 0.01,
                    )
                )
            )
            if plane.region is not None:
                ring = cam.project(np.vstack([plane.region, plane.region[:1]]))
                arts += ax.plot(*ring.T, color=REGION_COLOR, lw=1.0, ls="--", zorder=z + 0.02)
            for a in arts:
                a.set_animated(animated)
            self.surfaces.append(arts)
        ax.add_artist(Polygon(cam.project(_base_disk()), closed=True, fc=BASE_COLOR, ec="none", zorder=0.5))
        for vertices in scene.obstacles:  # behind the robot, as the surfaces' bodies
            outline = convex_hull(cam.project(vertices))
            ax.add_artist(Polygon(outline, closed=True, fc=SURFACE_COLOR, ec="#8a7a50", lw=0.6, alpha=0.5, zorder=0.6))
        a0, b0, r0 = scene.base_column
        if float(np.linalg.norm(b0 - a0)) > 1e-9:
            column = capsule_outlines(cam.project(a0), cam.project(b0), [r0], _CAP_POINTS)[0]
            ax.add_artist(Polygon(column, closed=True, fc="0.45", ec=BASE_COLOR, lw=0.6, zorder=0.55))
        task = cam.project(np.vstack([scene.task_path, scene.task_path[:1]]))
        top = 2.0 * len(scene.planes) + 3.0
        (self.task,) = ax.plot(*task.T, color=TASK_COLOR, lw=0.9, ls=(0, (4, 2)), zorder=top - 0.1, animated=animated)
        if samples is not None:  # the pieces these samples draw (each at most the slots below)
            slots = max((len(scene.pieces(name, k)[4]) for k in samples), default=0)
        elif scene.blocks is None:
            slots = scene.cap_r.size * (len(scene.planes) + 1)
        else:
            slots = scene.blocks.joint.size
        self.patches: list[Polygon] = [
            Polygon(np.zeros((3, 2)), closed=True, lw=0.6, animated=animated, visible=False) for _ in range(slots)
        ]
        for patch in self.patches:
            ax.add_artist(patch)
        color = STRATEGY_COLORS.get(name, "C0")
        (self.trace,) = ax.plot([], [], color=color, lw=trace_width, zorder=top, animated=animated)
        self.brace_traces = [
            ax.plot([], [], color=BRACE_COLOR, lw=1.0, zorder=top, animated=animated)[0] for _ in scene.braces
        ]
        braced = scene.runs[name].braced
        (self.brace_dots,) = ax.plot(
            [],
            [],
            "o",
            ms=5.5,
            mfc=BRACE_COLOR if braced else "white",
            mec="k",
            mew=0.8,
            zorder=top + 0.5,
            animated=animated,
        )
        (self.tip_dot,) = ax.plot(
            [], [], "o", ms=3.5, color=color, mec="k", mew=0.5, zorder=top + 0.5, animated=animated
        )

    def show(self, k: int) -> list[Artist]:
        """Put the robot at sample k of its run; return the changing artists in drawing order."""
        scene, cam = self.scene, self.scene.camera
        outlines, cap, layer, _depth, order = scene.pieces(self.name, k)
        drawn: list[Artist] = []
        surfaces_done = 0
        for slot, i in enumerate(order):
            while surfaces_done < len(self.surfaces) and layer[i] > 2 * (surfaces_done + 1):
                drawn += self.surfaces[surfaces_done]
                surfaces_done += 1
            patch = self.patches[slot]
            c = int(cap[i])
            patch.set_xy(outlines[i])
            patch.set_facecolor(scene.piece_face[c])
            patch.set_edgecolor(EDGE_COLOR)
            patch.set_zorder(float(layer[i]) + 0.5 * slot / max(len(order), 1))
            patch.set_visible(True)
            drawn.append(patch)
        drawn += [a for arts in self.surfaces[surfaces_done:] for a in arts]
        for patch in self.patches[len(order) :]:
            patch.set_visible(False)
        tips = cam.project(scene.tips[self.name][: k + 1])
        self.trace.set_data(tips[:, 0], tips[:, 1])
        self.tip_dot.set_data(tips[-1:, 0], tips[-1:, 1])
        bps = scene.brace_points[self.name]
        for j, line in enumerate(self.brace_traces):
            pts = cam.project(bps[: k + 1, j])
            line.set_data(pts[:, 0], pts[:, 1])
        now = cam.project(bps[k])
        self.brace_dots.set_data(now[:, 0], now[:, 1])
        return [*drawn, self.task, self.trace, *self.brace_traces, self.tip_dot, self.brace_dots]
