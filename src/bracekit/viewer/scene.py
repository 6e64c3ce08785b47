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

import json
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pinocchio as pin
from numpy.typing import NDArray

from bracekit.contact import Brace, Surface, contact_type
from bracekit.errors import BracekitError, InputError
from bracekit.kinematics import BracedRobot
from bracekit.model.geometry import Capsule
from bracekit.model.robot import Robot

if TYPE_CHECKING:
    from bracekit.simulation.run import RunResult

Array = NDArray[np.float64]

#: The file name of a run's scene in its output folder.
SCENE_FILE = "scene.json"
#: The format tag and version of scene.json.
SCENE_FORMAT = "bracekit-scene"
SCENE_VERSION = 1
#: Samples of the task path stored in scene.json.
PATH_SAMPLES = 200
#: Largest distance (m) between a run's stored tip position and the rebuilt robot's before the scene is refused.
TIP_TOLERANCE = 1e-9
RERUN = "re-run `bracekit run` to write it"


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
def _vec(a: Any) -> list[float]:
    return [float(x) for x in np.asarray(a, dtype=float).reshape(-1)]


def scene_data(result: RunResult) -> dict[str, Any]:
    """The JSON-ready content of scene.json for a run (see the module docstring)."""
    sc = result.scenario
    robot = sc.robot
    ts = np.linspace(0.0, sc.task.duration, PATH_SAMPLES)
    braces = []
    for b in sc.braced.braces:
        braces.append(
            {
                "frame": b.frame,
                "point": _vec(b.surface.point),
                "normal": _vec(b.surface.normal),
                "tangent": _vec(b.surface.tangent),
                "contact": b.contact.name if not isinstance(b.contact, str) else b.contact,
                "region_radius": b.region_radius,
                "surface_radius": b.surface_radius,
                "environment_stiffness": b.environment_stiffness,
                "pad_axis": b.pad_axis,
            }
        )
    checks: dict[str, Any] = {}
    for model, runs in result.trajectories.items():
        for name, tr in runs.items():
            if tr.q.shape[0] == 0:
                continue
            ends = [tr.q[0], tr.q[-1]]
            checks[f"{model}/{name}"] = {
                "braced": bool(tr.braced),
                "tip_first_last": [_vec(_tip(robot, q)) for q in ends],
            }
    return {
        "format": SCENE_FORMAT,
        "version": SCENE_VERSION,
        "scenario": sc.name,
        "description": sc.description,
        "compliance_model": result.compliance_model,
        "robot": {
            "name": str(robot.model.name),
            "pinocchio_model": robot.model.saveToString(),
            "tip": robot.tip,
            "stiffness": _vec(robot.stiffness),
            "joint_names": list(robot.joint_names),
            "capsules": [
                {"joint": c.joint, "a": _vec(c.a), "b": _vec(c.b), "radius": c.radius, "link": c.link}
                for c in robot.link_capsules()
            ],
        },
        "braces": braces,
        "holding": {
            "gravity": sc.holding.gravity,
            "preloads": list(sc.holding.brace_preloads(len(sc.braced.braces))),
        },
        "task": {"duration": sc.task.duration, "path": [_vec(sc.task.position(float(t))) for t in ts]},
        "runs": checks,
    }


def _tip(robot: Robot, q: Array) -> Array:
    model = robot.model
    data = model.createData()
    pin.framesForwardKinematics(model, data, np.asarray(q, dtype=float))
    return np.array(data.oMf[robot.tip_id].translation)


# --- reading -------------------------------------------------------------------------------------
def _read_json(path: Path, what: str) -> Any:
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise InputError(f"cannot read {what} {path}: {exc}") from exc


def _scene_json(folder: Path) -> dict[str, Any]:
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


def _robot(data: dict[str, Any]) -> tuple[Robot, tuple[Capsule, ...]]:
    model = pin.Model()
    try:
        model.loadFromString(data["pinocchio_model"])
        capsules = tuple(
            Capsule(
                int(c["joint"]),
                np.array(c["a"], dtype=float),
                np.array(c["b"], dtype=float),
                float(c["radius"]),
                str(c["link"]),
            )
            for c in data["capsules"]
        )
        robot = Robot(model=model, tip=data["tip"], stiffness=np.array(data["stiffness"], dtype=float))
    except (RuntimeError, KeyError, TypeError, ValueError, BracekitError) as exc:
        raise InputError(f"the robot of scene.json cannot be rebuilt ({exc}); {RERUN}") from exc
    return robot, capsules


def _braced(robot: Robot, braces: list[dict[str, Any]]) -> BracedRobot:
    try:
        built = [
            Brace(
                frame=b["frame"],
                surface=Surface(np.array(b["point"]), np.array(b["normal"]), np.array(b["tangent"])),
                contact=contact_type(b["contact"]),
                region_radius=b["region_radius"],
                environment_stiffness=b["environment_stiffness"],
                pad_axis=bool(b["pad_axis"]),
                surface_radius=b["surface_radius"],
            )
            for b in braces
        ]
        return BracedRobot(robot, built[0] if len(built) == 1 else built)
    except (KeyError, TypeError, IndexError, BracekitError) as exc:
        raise InputError(f"the braces of scene.json cannot be rebuilt ({exc}); {RERUN}") from exc


def _runs(folder: Path, checks: dict[str, Any], summaries: Any) -> dict[str, dict[str, Run]]:
    path = folder / "trajectories.npz"
    try:
        with np.load(path, allow_pickle=False) as npz:
            arrays = {k: np.asarray(npz[k]) for k in npz.files if k != "joint_names"}
    except (OSError, ValueError) as exc:
        raise InputError(f"cannot read {path}: {exc}") from exc
    grouped: dict[tuple[str, str], dict[str, Array]] = {}
    for key, values in arrays.items():
        parts = key.split("/")
        if len(parts) != 3:
            continue
        grouped.setdefault((parts[0], parts[1]), {})[parts[2]] = values
    runs: dict[str, dict[str, Run]] = {}
    for (model, strategy), items in grouped.items():
        if "t" not in items or "q" not in items:
            raise InputError(f"{path} has no t or q for {model}/{strategy}; {RERUN}")
        check = checks.get(f"{model}/{strategy}", {})
        summary = {}
        if isinstance(summaries, dict):
            summary = summaries.get(model, {}).get("strategies", {}).get(strategy, {})
        t, q = items.pop("t").astype(float), items.pop("q").astype(float)
        runs.setdefault(model, {})[strategy] = Run(
            model, strategy, t, q, items, bool(check.get("braced", strategy != "free_space_min_norm")), summary
        )
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
            if stored is None or run.q.shape[1] != robot.n:
                raise InputError(f"{folder}: scene.json and trajectories.npz do not belong together; {RERUN}")
            for q, want in zip((run.q[0], run.q[-1]), stored, strict=True):
                gap = float(np.linalg.norm(_tip(robot, q) - np.asarray(want, dtype=float)))
                if not gap <= TIP_TOLERANCE:
                    raise InputError(
                        f"{folder}: the rebuilt robot puts the tip {gap:.3g} m from where run {model}/{name} had it; "
                        f"scene.json and trajectories.npz do not belong together; {RERUN}"
                    )


def load_scene(out_dir: str | os.PathLike[str]) -> Scene:
    """The scene of a `bracekit run` output folder (scene.json, trajectories.npz, summary.json).

    Raises:
        InputError: the folder is not a run output, has no scene.json (written by older bracekit versions), or
            its files cannot be read or do not agree (one line, ending with what to do).
    """
    folder = Path(os.fspath(out_dir))
    data = _scene_json(folder)
    robot, capsules = _robot(data.get("robot", {}))
    braces = data.get("braces")
    if not isinstance(braces, list) or not braces:
        raise InputError(f"{folder / SCENE_FILE} names no brace; {RERUN}")
    braced = _braced(robot, braces)
    summaries: Any = {}
    if (folder / "summary_all_models.json").is_file():
        summaries = _read_json(folder / "summary_all_models.json", "the summaries")
    checks = data.get("runs", {})
    runs = _runs(folder, checks, summaries)
    _check_tips(braced.robot, runs, checks, folder)
    model = str(data.get("compliance_model", ""))
    if (folder / "summary.json").is_file():
        model = str(_read_json(folder / "summary.json", "the summary").get("compliance_model", model))
    holding = data.get("holding", {})
    views = tuple(
        BraceView(
            b["frame"],
            np.array(b["point"], dtype=float),
            np.array(b["normal"], dtype=float),
            b["region_radius"],
            b["surface_radius"],
        )
        for b in braces
    )
    return Scene(
        name=str(data.get("scenario", folder.name)),
        description=str(data.get("description", "")),
        braced=braced,
        capsules=capsules,
        braces=views,
        path=np.array(data["task"]["path"], dtype=float),
        compliance_model=model,
        runs=runs,
        gravity=bool(holding.get("gravity", False)),
        preloads=tuple(float(p) for p in holding.get("preloads", [0.0] * len(braces))),
    )
