"""A run's scene: what ``scene.json`` holds and the :class:`Scene` rebuilt from a run's output folder.

``scene.json`` (written by ``write_run``) makes an output folder enough to draw the run without the scenario
file: the robot (its Pinocchio model as Pinocchio's text serialization, with the brace frames the scenario
added; tip; joint stiffnesses; link capsules), each brace (frame, surface, contact, region and surface radii,
environment stiffness), the statics that the preloaded compliance needs (gravity, preloads), the task path
sampled in time and, for each run, the tip position at its first and last samples. :func:`load_scene` reads
scene.json, trajectories.npz and summary.json, rebuilds the braced robot and checks that it puts the tip where
the run had it.
"""

from __future__ import annotations

import math
import os
import zipfile
import zlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pinocchio as pin
from numpy.typing import NDArray

from bracekit._io import npz_shapes, read_json
from bracekit.contact import Brace, Surface, contact_type
from bracekit.errors import BracekitError, InputError
from bracekit.kinematics import BracedRobot
from bracekit.model.geometry import Capsule
from bracekit.model.robot import Robot
from bracekit.model.urdf_numbers import MAX_LENGTH
from bracekit.viewer.link_meshes import MESH_FILE, LinkMesh, load_link_meshes
from bracekit.viewer.scene_write import SCENE_FORMAT, SCENE_VERSION, SceneInput, SceneRun, scene_content
from bracekit.viewer.scene_write import tip_position as _tip

if TYPE_CHECKING:
    from bracekit.simulation.run import RunResult

Array = NDArray[np.float64]

#: The file name of a run's scene in its output folder.
SCENE_FILE = "scene.json"
#: Samples of the task path stored in scene.json.
PATH_SAMPLES = 200
#: Largest distance (m) between a run's stored tip position and the rebuilt robot's before the scene is refused.
TIP_TOLERANCE = 1e-9
RERUN = "re-run `bracekit run` to write it"
#: Caps on what a scene.json may hold (a damaged or hostile file is refused before any work).
MAX_CAPSULES = 1000
MAX_LINKS = 200
MAX_BRACES = 16
MAX_PATH_SAMPLES = 100_000
MAX_MODEL_TEXT = 2 * 1024 * 1024
#: Largest scene.json or summary read, bytes (the paper's scene.json is ~60 kB).
MAX_SCENE_BYTES = 8 * 1024 * 1024


@dataclass(frozen=True)
class BraceView:
    """What is drawn of a brace: its frame, surface and bracing region.

    Attributes:
        frame: the bracing frame {b}.
        point: a point of the surface (3,), m, world (the region's centre).
        normal: the unit surface normal (3,), toward the robot.
        region_radius: r_max of the bracing region, m (None: no region).
        surface_radius: radius of the surface as a solid disk, m (None: the plane).
    """

    frame: str
    point: Array
    normal: Array
    region_radius: float | None
    surface_radius: float | None


@dataclass(frozen=True)
class Run:
    """One run of the output: its samples and per-sample measures.

    Attributes:
        model: compliance model ('constrained', 'projection', 'preloaded').
        strategy: strategy name.
        t: sample times (N,), s.
        q: joint values (N×n), chain order.
        measures: per-sample measures of trajectories.npz (N,) by name.
        braced: whether the run is braced (the free-space run is not).
        summary: the strategy's entry of summary_all_models.json ({} when absent).
    """

    model: str
    strategy: str
    t: Array
    q: Array
    measures: dict[str, Array]
    braced: bool
    summary: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True, eq=False)
class Scene:
    """A run's output rebuilt for drawing.

    Attributes:
        name: scenario name. description: its description.
        braced: the braced robot (the run's robot with its brace frames, braces and stiffnesses).
        capsules: link volumes, each in its joint's frame (:mod:`bracekit.model.geometry`).
        braces: what is drawn of each brace.
        path: the task path (k×3), m, world.
        compliance_model: the model of summary.json.
        runs: the runs by compliance model, then by strategy (`runs[model][strategy]`).
        gravity, preloads: the statics of the preloaded compliance (gravity on/off, P_i per brace in N).
        meshes: the robot's link meshes the folder carries (meshes.npz; () when the robot is drawn by its capsules).
        obstacles: the environment's further solids (name, vertices (k, 3) m base frame, faces (t, 3)).
    """

    name: str
    description: str
    braced: BracedRobot
    capsules: tuple[Capsule, ...]
    braces: tuple[BraceView, ...]
    path: Array
    compliance_model: str
    runs: dict[str, dict[str, Run]]
    gravity: bool = False
    preloads: tuple[float, ...] = ()
    meshes: tuple[LinkMesh, ...] = ()
    obstacles: tuple[tuple[str, Array, NDArray[np.int64]], ...] = ()

    @property
    def models(self) -> tuple[str, ...]:
        """The compliance models of the output, the summary's first."""
        rest = [m for m in self.runs if m != self.compliance_model]
        return (self.compliance_model, *rest) if self.compliance_model in self.runs else tuple(rest)

    @property
    def strategies(self) -> tuple[str, ...]:
        """The strategies of the output (those of the summary's model)."""
        return tuple(self.runs[self.models[0]])


# --- writing -------------------------------------------------------------------------------------
def scene_data(result: RunResult, meshes: bool = False) -> dict[str, Any]:
    """The JSON-ready content of scene.json for a run (see the module docstring).

    `meshes`: the run folder carries the robot's link meshes (meshes.npz, named by ``robot.meshes``).
    """
    sc = result.scenario
    ts = np.linspace(0.0, sc.task.duration, PATH_SAMPLES)
    runs = {
        model: {name: SceneRun(tr.q, bool(tr.braced)) for name, tr in by_name.items()}
        for model, by_name in result.trajectories.items()
    }
    return scene_content(
        SceneInput(
            name=sc.name,
            description=sc.description,
            compliance_model=result.compliance_model,
            braced=sc.braced,
            duration=sc.task.duration,
            path=np.array([sc.task.position(float(t)) for t in ts]),
            runs=runs,
            gravity=sc.holding.gravity,
            preloads=tuple(sc.holding.brace_preloads(len(sc.braced.braces))),
            meshes=meshes,
        )
    )


# --- reading -------------------------------------------------------------------------------------
def _read_json(path: Path, what: str) -> Any:
    return read_json(path, what, MAX_SCENE_BYTES)  # size and nesting capped (one line, never a RecursionError)


def _scene_json(folder: Path) -> dict[str, Any]:
    try:
        os.stat(folder)
    except FileNotFoundError:
        pass
    except (OSError, ValueError) as exc:  # a name too long, a NUL byte, no permission
        why = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
        raise InputError(
            f"cannot read the output folder {str(folder)[:80]}…: {why}; give the output folder of `bracekit run`"
        ) from None
    if not folder.is_dir():
        raise InputError(f"{folder} is not a folder; give the output folder of `bracekit run`")
    if not (folder / "trajectories.npz").is_file():
        raise InputError(f"{folder} is not the output of `bracekit run` (no trajectories.npz)")
    path = folder / SCENE_FILE
    if not path.is_file():
        raise InputError(f"{folder} has no {SCENE_FILE} (an output of an older bracekit); {RERUN}")
    try:
        data = _read_json(path, "the scene")
    except InputError as exc:
        raise InputError(f"{exc}; {RERUN}") from exc
    if not isinstance(data, dict) or data.get("format") != SCENE_FORMAT:
        raise InputError(f"{path} is not a bracekit scene; {RERUN}")
    if data.get("version") != SCENE_VERSION:
        found = data.get("version")
        raise InputError(f"{path} has scene version {found!r}, this bracekit reads {SCENE_VERSION}; {RERUN}")
    return data


def _object(value: Any, where: str) -> dict[str, Any]:
    """`value` when it is a JSON object, else InputError naming `where`."""
    if not isinstance(value, dict):
        raise InputError(f"{where} is not a JSON object (got {type(value).__name__}); {RERUN}")
    return value


def _text(value: Any, where: str) -> str:
    if not isinstance(value, str):
        raise InputError(f"{where} is not a string (got {type(value).__name__}); {RERUN}")
    return value


def _numbers(value: Any, where: str, shape: tuple[int | None, ...], finite: bool = True) -> Array:
    """`value` as a float array of `shape` (None: any length), finite unless told; InputError otherwise."""
    try:
        array = np.array(value, dtype=float)
    except (TypeError, ValueError, OverflowError):
        raise InputError(f"{where} is not an array of numbers; {RERUN}") from None
    fits = array.ndim == len(shape) and all(s is None or s == d for s, d in zip(shape, array.shape, strict=False))
    if not fits:
        want = "×".join("N" if s is None else str(s) for s in shape) or "a single number"
        raise InputError(f"{where} has shape {array.shape}, expected {want}; {RERUN}")
    if finite and not np.all(np.isfinite(array)):
        raise InputError(f"{where} holds numbers that are not finite; {RERUN}")
    return array


def _robot(data: dict[str, Any]) -> tuple[Robot, tuple[Capsule, ...]]:
    model = pin.Model()
    text = data.get("pinocchio_model")
    if not isinstance(text, str):
        raise InputError(f"the robot of scene.json has no Pinocchio model text; {RERUN}")
    found = data.get("capsules")
    if not isinstance(found, list) or len(found) > MAX_CAPSULES:
        size = len(found) if isinstance(found, list) else type(found).__name__
        raise InputError(
            f"scene.json: robot.capsules must be a list of at most {MAX_CAPSULES} capsules, got {size}; {RERUN}"
        )
    if len(text) > MAX_MODEL_TEXT:
        raise InputError(f"scene.json: the robot's model text is longer than {MAX_MODEL_TEXT} characters; {RERUN}")
    try:
        model.loadFromString(text)
        capsules = tuple(
            Capsule(
                int(c["joint"]),
                _numbers(c["a"], "a capsule end", (3,)),
                _numbers(c["b"], "a capsule end", (3,)),
                float(c["radius"]),
                str(c["link"]),
            )
            for c in data["capsules"]
        )
        if model.njoints - 1 > MAX_LINKS:
            raise InputError(f"{model.njoints - 1} joints (more than {MAX_LINKS})")
        robot = Robot(model=model, tip=data["tip"], stiffness=np.array(data["stiffness"], dtype=float))
    except (RuntimeError, KeyError, TypeError, ValueError, OverflowError, BracekitError) as exc:
        reason = " ".join(str(exc).split())[:200]
        raise InputError(f"the robot of scene.json cannot be rebuilt ({reason}); {RERUN}") from exc
    for c in capsules:  # a capsule's joint is 1 … n (0 is the universe), its radius finite and ≥ 0
        if not 1 <= c.joint <= robot.n or not (math.isfinite(c.radius) and 0.0 <= c.radius <= MAX_LENGTH):
            raise InputError(
                f"scene.json has a link capsule ({c.link[:40]!r}) with joint {float(c.joint):.6g} or radius "
                f"{c.radius:.6g} out of range "
                f"(joint 1…{robot.n}, radius 0…{MAX_LENGTH:g} m); {RERUN}"
            )
    return robot, capsules


def _braced(robot: Robot, braces: list[Any]) -> BracedRobot:
    try:
        built = [
            Brace(
                frame=b["frame"],
                surface=Surface(
                    _numbers(b["point"], "a brace point", (3,)),
                    _numbers(b["normal"], "a brace normal", (3,)),
                    _numbers(b["tangent"], "a brace tangent", (3,)),
                ),
                contact=contact_type(b["contact"]),
                region_radius=b["region_radius"],
                environment_stiffness=b["environment_stiffness"],
                pad_axis=bool(b["pad_axis"]),
                surface_radius=b["surface_radius"],
            )
            for b in braces
        ]
        return BracedRobot(robot, built[0] if len(built) == 1 else built)
    except (KeyError, TypeError, IndexError, ValueError, BracekitError) as exc:
        raise InputError(f"the braces of scene.json cannot be rebuilt ({exc}); {RERUN}") from exc


def _arrays(path: Path) -> dict[str, NDArray[Any]]:
    """Every array of trajectories.npz but joint_names; InputError when the file is damaged or too large.

    The arrays' shapes and types are read from their headers first (nothing decompressed): at most
    MAX_NPZ_ELEMENTS numbers in all, no object arrays.
    """
    try:
        npz_shapes(path)
    except InputError as exc:
        raise InputError(f"{exc}; {RERUN}") from None
    try:
        with np.load(path, allow_pickle=False) as npz:
            return {k: np.asarray(npz[k]) for k in npz.files if k != "joint_names"}
    except (OSError, ValueError, EOFError, zipfile.BadZipFile, zlib.error, AttributeError) as exc:
        why = str(exc) or type(exc).__name__
        raise InputError(f"cannot read {path} ({why}); {RERUN}") from None


def _summary(summaries: dict[str, Any], model: str, strategy: str, where: str) -> dict[str, Any]:
    """The strategy's entry of summary_all_models.json ({} when absent)."""
    if model not in summaries:
        return {}
    by_model = _object(summaries[model], f"{where}[{model!r}]")
    strategies = _object(by_model.get("strategies", {}), f"{where}[{model!r}]['strategies']")
    if strategy not in strategies:
        return {}
    return _object(strategies[strategy], f"{where}[{model!r}]['strategies'][{strategy!r}]")


def _runs(folder: Path, checks: dict[str, Any], summaries: dict[str, Any], n: int) -> dict[str, dict[str, Run]]:
    """The runs of trajectories.npz: t (N,) finite and increasing (N ≥ 1), q (N×n) finite, each measure (N,)."""
    path = folder / "trajectories.npz"
    grouped: dict[tuple[str, str], dict[str, NDArray[Any]]] = {}
    for key, values in _arrays(path).items():
        parts = key.split("/")
        if len(parts) != 3:
            continue
        grouped.setdefault((parts[0], parts[1]), {})[parts[2]] = values
    where = str(folder / "summary_all_models.json")
    runs: dict[str, dict[str, Run]] = {}
    for (model, strategy), items in grouped.items():
        name = f"{path}: {model}/{strategy}"
        if "t" not in items or "q" not in items:
            raise InputError(f"{path} has no t or q for {model}/{strategy}; {RERUN}")
        t = _numbers(items.pop("t"), f"{name}/t", (None,))
        q = _numbers(items.pop("q"), f"{name}/q", (t.size, n))
        if t.size == 0:
            raise InputError(f"{name} has no samples (a run has at least its start); {RERUN}")
        if not np.all(np.diff(t) > 0.0):
            raise InputError(f"{name}/t is not increasing; {RERUN}")
        measures = {k: _numbers(v, f"{name}/{k}", (t.size,), finite=False) for k, v in items.items()}
        check = _object(checks.get(f"{model}/{strategy}", {}), f"{folder / SCENE_FILE}: runs[{model}/{strategy}]")
        braced = check.get("braced", strategy != "free_space_min_norm")
        if not isinstance(braced, bool):
            raise InputError(f"{folder / SCENE_FILE}: runs[{model}/{strategy}].braced is not true or false; {RERUN}")
        summary = _summary(summaries, model, strategy, where)
        runs.setdefault(model, {})[strategy] = Run(model, strategy, t, q, measures, braced, summary)
    if not runs:
        raise InputError(f"{path} holds no runs; {RERUN}")
    return runs


def _check_tips(robot: Robot, runs: dict[str, dict[str, Run]], checks: dict[str, Any], folder: Path) -> None:
    """InputError unless the rebuilt robot puts the tip where the run had it (first and last samples)."""
    for model, by_name in runs.items():
        for name, run in by_name.items():
            stored = checks.get(f"{model}/{name}", {}).get("tip_first_last")
            if run.q.shape[0] == 0:
                continue
            if stored is None:
                raise InputError(f"{folder}: scene.json and trajectories.npz do not belong together; {RERUN}")
            ends = _numbers(stored, f"{folder / SCENE_FILE}: runs[{model}/{name}].tip_first_last", (2, 3))
            for q, want in zip((run.q[0], run.q[-1]), ends, strict=True):
                gap = float(np.linalg.norm(_tip(robot, q) - want))
                if not gap <= TIP_TOLERANCE:
                    raise InputError(
                        f"{folder}: the rebuilt robot puts the tip {gap:.3g} m from where run {model}/{name} had it; "
                        f"scene.json and trajectories.npz do not belong together; {RERUN}"
                    )


def _holding(data: dict[str, Any], count: int, where: str) -> tuple[bool, tuple[float, ...]]:
    """(gravity, preloads P_i in N) of scene.json's `holding` (off and 0 N when it is absent)."""
    holding = _object(data.get("holding", {}), f"{where}: holding")
    gravity = holding.get("gravity", False)
    if not isinstance(gravity, bool):
        raise InputError(f"{where}: holding.gravity is not true or false; {RERUN}")
    preloads = _numbers(holding.get("preloads", [0.0] * count), f"{where}: holding.preloads", (count,))
    return gravity, tuple(float(p) for p in preloads)


def load_scene(out_dir: str | os.PathLike[str]) -> Scene:
    """The scene of a `bracekit run` output folder (scene.json, trajectories.npz, summary.json).

    Raises:
        InputError: the folder is not a run output, has no scene.json (written by older bracekit versions), or
            its files cannot be read, are malformed or do not agree (one line, ending with what to do).
    """
    folder = Path(os.fspath(out_dir))
    data = _scene_json(folder)
    where = str(folder / SCENE_FILE)
    robot_data = _object(data.get("robot", {}), f"{where}: robot")
    robot, capsules = _robot(robot_data)
    meshes: tuple[LinkMesh, ...] = ()
    if "meshes" in robot_data:
        if robot_data["meshes"] != MESH_FILE:
            raise InputError(f"{where}: robot.meshes must be {MESH_FILE!r}; {RERUN}")
        if not (folder / MESH_FILE).is_file():
            raise InputError(f"{folder} has no {MESH_FILE} (the robot's meshes scene.json names); {RERUN}")
        meshes = load_link_meshes(folder / MESH_FILE, robot.n)
    braces = data.get("braces")
    if not isinstance(braces, list) or not braces:
        raise InputError(f"{where} names no brace; {RERUN}")
    if len(braces) > MAX_BRACES:
        raise InputError(f"{where} names {len(braces)} braces (at most {MAX_BRACES}); {RERUN}")
    braced = _braced(robot, braces)
    task = _object(data.get("task"), f"{where}: task")
    if "path" not in task:
        raise InputError(f"{where}: task has no path; {RERUN}")
    if not isinstance(task["path"], list) or len(task["path"]) > MAX_PATH_SAMPLES:
        raise InputError(f"{where}: task.path must be a list of at most {MAX_PATH_SAMPLES} points; {RERUN}")
    path = _numbers(task["path"], f"{where}: task.path", (None, 3))
    if path.shape[0] == 0:
        raise InputError(f"{where}: task.path is empty; {RERUN}")
    gravity, preloads = _holding(data, len(braces), where)
    summaries: dict[str, Any] = {}
    if (folder / "summary_all_models.json").is_file():
        found = _read_json(folder / "summary_all_models.json", "the summaries")
        summaries = _object(found, str(folder / "summary_all_models.json"))
    checks = _object(data.get("runs", {}), f"{where}: runs")
    runs = _runs(folder, checks, summaries, braced.robot.n)
    _check_tips(braced.robot, runs, checks, folder)
    model = _text(data.get("compliance_model", ""), f"{where}: compliance_model")
    if (folder / "summary.json").is_file():
        summary = _object(_read_json(folder / "summary.json", "the summary"), str(folder / "summary.json"))
        model = _text(summary.get("compliance_model", model), f"{folder / 'summary.json'}: compliance_model")
    views = tuple(
        BraceView(b.frame, np.array(b.surface.point), np.array(b.surface.normal), b.region_radius, b.surface_radius)
        for b in braced.braces
    )
    return Scene(
        name=_text(data.get("scenario", folder.name), f"{where}: scenario"),
        description=_text(data.get("description", ""), f"{where}: description"),
        braced=braced,
        capsules=capsules,
        braces=views,
        path=path,
        compliance_model=model,
        runs=runs,
        gravity=gravity,
        preloads=preloads,
        meshes=meshes,
        obstacles=_obstacle_views(data.get("obstacles", []), where),
    )


def _obstacle_views(raw: Any, where: str) -> tuple[tuple[str, Array, NDArray[np.int64]], ...]:
    """The further obstacles of scene.json: (name, vertices (k, 3), faces (t, 3)) each."""
    if not isinstance(raw, list):
        raise InputError(f"{where}: obstacles must be a list; {RERUN}")
    out = []
    for i, o in enumerate(raw):
        item = _object(o, f"{where}: obstacles[{i}]")
        vertices = _numbers(item.get("vertices"), f"{where}: obstacles[{i}].vertices", (None, 3))
        faces = _numbers(item.get("faces"), f"{where}: obstacles[{i}].faces", (None, 3)).astype(np.int64)
        if faces.size and (faces.min() < 0 or faces.max() >= len(vertices)):
            raise InputError(f"{where}: obstacles[{i}].faces name vertices it does not have; {RERUN}")
        out.append((_text(item.get("name", f"obstacle[{i + 1}]"), f"{where}: obstacles[{i}].name"), vertices, faces))
    return tuple(out)
