"""Scenario files (TOML): robot, brace, task, strategies and gains, validated into a :class:`Scenario`.

Every mistake raises ScenarioError naming the key and the fix. Shipped scenarios live in
``bracekit/simulation/scenarios/`` and are addressed by name (``paper``).
"""

from __future__ import annotations

import math
import os
from importlib import resources
from pathlib import Path
from typing import Any, cast

import numpy as np
from numpy.typing import NDArray

from bracekit._linalg import show
from bracekit.compliance.preloaded import RUN_MODELS
from bracekit.contact import REGISTRY, Brace, Surface, contact_type
from bracekit.errors import BracekitError, FrameNotFoundError, InputError, ScenarioError
from bracekit.geometry.obstacle_tables import obstacle_tables, with_obstacles
from bracekit.geometry.pad import brace_point
from bracekit.kinematics import BracedRobot
from bracekit.model.robot import Robot
from bracekit.model.shipped import MODELS, load_model
from bracekit.resolution.strategies import (
    GRADIENT_MODES,
    GradientMode,
)
from bracekit.resolution.task_space import TASK_SPACES, TaskSpace
from bracekit.simulation.holding import Holding
from bracekit.simulation.scenario_model import DEFAULT_STRATEGIES, STRATEGIES, Scenario, weight_keys
from bracekit.simulation.tasks import TASK_SHAPES, Task, radial_of
from bracekit.simulation.toml_table import Table as _Table
from bracekit.simulation.toml_table import read_source
from bracekit.spatial import rotation_with_z
from bracekit.statics.equilibrium import MAX_FRICTION, MAX_PRELOAD
from bracekit.tolerances import MAX_STEPS

#: Most tool wrenches ``[loads] wrenches`` may list (each costs a capacity search at every sample).
MAX_WRENCHES = 32

Array = NDArray[np.float64]
#: Weights on by default unless ``[gradient_projection.weights]`` gives them (0 turns one off): the
#: joint-limit barrier, and with one brace (whose surface is the links' obstacle: the link clearance of
#: several braces is not defined) the clearance barrier. docs/scenarios.md.
SAFETY_WEIGHTS = {"clearance": 0.01, "joint_limit_barrier": 0.01, "conditioning": 0.01}

#: The start solve's θ_z weight when the brace has a pad axis and gradient projection weights θ_z.
START_THETA_WEIGHT = 0.3


def task_keys() -> tuple[str, ...]:
    """The keys of ``[task]``: its type, every registered shape's keys, the task space and its axis."""
    shaped = dict.fromkeys(k for shape in TASK_SHAPES.values() for k in shape.keys)
    return ("type", *shaped, "space", "axis")


def shipped_scenarios() -> dict[str, Path]:
    """Name → path of the scenarios shipped with bracekit."""
    root = resources.files("bracekit.simulation").joinpath("scenarios")
    return {p.name[:-5]: Path(str(p)) for p in root.iterdir() if p.name.endswith(".toml")}


def load_scenario(source: str | os.PathLike[str]) -> Scenario:
    """Read and validate a scenario: a TOML path (a str or an os.PathLike) or a shipped scenario's name ('paper').

    Raises:
        ScenarioError: the file is missing, not TOML, or a key is missing, unknown or malformed (the message
            names the key).
    """
    path, data = read_source(source, shipped_scenarios(), "scenario")
    try:
        return parse_scenario(data, base=path.parent, name=path.stem, source=path)
    except ScenarioError:
        raise
    except InputError as exc:
        raise ScenarioError(f"{path.name}: {exc}") from exc


def parse_scenario(
    data: dict[str, Any], base: Path = Path("."), name: str = "scenario", source: Path | None = None
) -> Scenario:
    """Validate the TOML data of a scenario (see ``scenarios/paper.toml`` for every key).

    One ``[brace]`` table is the paper's model. Several braces are an array of tables, ``[[brace]]``, each
    with the keys of ``[brace]`` (named 'brace[1]', 'brace[2]', … in messages), each with its own preload and
    friction ('[robot] gravity' and '[loads]' are shared); with several braces the compliance model is
    "constrained" and the weights of θ_z and d (one brace's pad and region) are 0.
    """
    top = _Table(
        data,
        "",
        (
            "name",
            "description",
            "robot",
            "brace",
            "task",
            "start",
            "compliance",
            "gradient_projection",
            "simulation",
            "loads",
            "obstacle",
        ),
    )
    robot_t = top.table("robot", ("model", "urdf", "tip", "stiffness", "gravity", "package_dirs"))
    robot = _robot(robot_t, base)
    brace_ts = _brace_tables(top)
    several = len(brace_ts) > 1
    braced = with_obstacles(_braces(brace_ts, robot), obstacle_tables(top.raw("obstacle", None), base))
    loads_t = top.table("loads", ("wrenches",), {})
    if several:
        holding = _holding_of(robot_t, brace_ts, loads_t)
    else:
        holding = _holding(robot_t, brace_ts[0], loads_t)
    robot = braced.robot
    pad_axis = any(b.pad_axis for b in braced.braces) if several else braced.split.brace.pad_axis
    region = (
        next((b.region_radius for b in braced.braces if b.region_radius is not None), None)
        if several
        else braced.split.brace.region_radius
    )
    task_t = top.table("task", task_keys())
    task = _task(task_t)
    task_space = _task_space(task_t)
    start = top.table("start", ("guess", "theta_weight"))
    guess = start.vector("guess", robot.n)
    comp = top.table("compliance", ("model", "beta_x"), {})
    model = comp.string("model", RUN_MODELS, "constrained")
    if several and model == "projection":
        raise ScenarioError(
            f"'compliance.model' = {show(model)} is defined for one brace (it needs the chain split at {{b}}); with "
            'several [[brace]] tables use "constrained" or "preloaded"'
        )
    if model == "preloaded" and not (holding.gravity or max(holding.brace_preloads(len(braced.braces))) > 0.0):
        raise ScenarioError(
            "'compliance.model' = \"preloaded\" needs '[robot] gravity = true' or '[brace] preload' > 0 "
            "(without them it is the constrained model)"
        )
    beta_raw = comp.raw("beta_x", "radial")
    if isinstance(beta_raw, str) and beta_raw != "radial":
        want = '"radial" or 6 numbers [vx, vy, vz, wx, wy, wz]'
        raise ScenarioError(f"'compliance.beta_x' must be {want}, got {show(beta_raw)}")
    if beta_raw == "radial":
        radial = radial_of(task)
        if radial is None:
            raise ScenarioError(
                "'compliance.beta_x' = \"radial\" needs a task with a radial direction (a circle); give 6 numbers "
                "[vx, vy, vz, wx, wy, wz]"
            )

        def beta_x(t: float) -> Array:
            return np.concatenate([radial(t), np.zeros(3)])

        spec = "radial"
    else:
        vec = comp.vector("beta_x", 6)
        with np.errstate(over="ignore"):
            size = float(np.linalg.norm(vec))
        if not 1e-12 <= size < math.inf:
            raise ScenarioError(f"'compliance.beta_x' must be a non-zero twist of moderate size, got {vec.tolist()}")
        fixed = vec / size

        def beta_x(t: float) -> Array:
            return fixed

        spec = f"fixed {np.round(fixed, 4).tolist()}"
    gp = top.table("gradient_projection", ("alpha", "weights", "gradient"), {})
    alpha = gp.number("alpha", -1.0)
    if alpha >= 0:
        raise ScenarioError(f"'gradient_projection.alpha' must be negative (it descends g), got {alpha}")
    default_weights = (
        {"Ci": 100.0, "d": 0.01 if region is not None else 0.0}
        if several
        else {"k": 0.5, "Ci": 100.0, "theta_z": 0.6 if pad_axis else 0.0, "d": 0.01}
    )
    w = gp.table("weights", weight_keys(), default_weights)
    safety = {k: v for k, v in SAFETY_WEIGHTS.items() if not (several and k == "clearance")}
    weights = {k: w.number(k, safety.get(k, 0.0)) for k in weight_keys()}
    for k, v in weights.items():
        if v < 0:
            raise ScenarioError(f"'gradient_projection.weights.{k}' must be ≥ 0, got {v}")
    if weights["theta_z"] > 0 and not pad_axis:
        raise ScenarioError(
            "'gradient_projection.weights.theta_z' needs a pad axis, and a link-point brace has none: give "
            "'brace.pad_axis' = [x, y, z] (link axes) or set theta_z = 0"
        )
    theta_weight = _start_theta_weight(start, pad_axis, weights["theta_z"])
    if weights["d"] > 0 and region is None:
        raise ScenarioError("'gradient_projection.weights.d' needs 'brace.region_radius' (r_max, m)")
    gradient = gp.string("gradient", GRADIENT_MODES, "analytic")
    sim = top.table("simulation", ("dt", "strategies", "feedback_gain"), {})
    dt = sim.number("dt", 0.05, positive=True)
    if dt > task.duration:
        raise ScenarioError(
            f"'simulation.dt' = {dt} s is longer than the task ({task.duration:g} s); give a smaller dt"
        )
    if task.duration / dt > MAX_STEPS:
        raise ScenarioError(
            f"'simulation.dt' = {dt} s gives {task.duration / dt:.0f} steps (more than {MAX_STEPS}); give a larger dt"
        )
    feedback_gain = sim.number("feedback_gain", 1.0)
    if feedback_gain < 0:
        raise ScenarioError(f"'simulation.feedback_gain' must be ≥ 0 (1/s), got {feedback_gain}")
    strategies = sim.raw("strategies", list(DEFAULT_STRATEGIES))
    if not isinstance(strategies, list) or not strategies or any(s not in STRATEGIES for s in strategies):
        raise ScenarioError(
            f"'simulation.strategies' must be a list drawn from: {', '.join(STRATEGIES)}; got {show(strategies)}"
        )
    return Scenario(
        name=top.string("name", default=name),
        description=top.string("description", default=""),
        braced=braced,
        task=task,
        guess=guess,
        compliance_model=model,
        beta_x=beta_x,
        beta_x_spec=spec,
        alpha=alpha,
        weights=weights,
        gradient=cast(GradientMode, gradient),
        dt=dt,
        strategies=tuple(strategies),
        feedback_gain=feedback_gain,
        source=source,
        task_space=task_space,
        start_theta_weight=theta_weight,
        holding=holding,
    )


def _start_theta_weight(start: _Table, pad_axis: bool, theta_z: float) -> float:
    """The start solve's θ_z weight: '[start] theta_weight', by default START_THETA_WEIGHT if θ_z is weighted."""
    default = START_THETA_WEIGHT if pad_axis and theta_z > 0 else 0.0
    value = start.number("theta_weight", default)
    if value < 0:
        raise ScenarioError(f"'start.theta_weight' must be ≥ 0, got {value}")
    if value > 0 and not pad_axis:
        raise ScenarioError(
            "'start.theta_weight' needs a pad axis, and a link-point brace has none: give 'brace.pad_axis' = "
            "[x, y, z] (link axes) or set start.theta_weight = 0"
        )
    return value


def _robot(t: _Table, base: Path) -> Robot:
    if t.has("model") == t.has("urdf"):
        raise ScenarioError(
            f"[robot] needs exactly one of 'robot.model' ({', '.join(MODELS)}) or 'robot.urdf' (a path)"
        )
    stiffness = t.raw("stiffness", 170.0)
    if isinstance(stiffness, list):
        stiffness = t.vector("stiffness")
    else:
        stiffness = t.number("stiffness", 170.0, positive=True)
    tip = t.string("tip", default=None) if t.has("tip") else None
    try:
        if t.has("model"):
            robot = load_model(t.string("model", tuple(MODELS)), tip=tip)
        else:
            if tip is None:
                raise ScenarioError("'robot.tip' is needed with 'robot.urdf': name the end-effector frame")
            urdf = Path(t.string("urdf"))
            dirs = t.raw("package_dirs", [])  # where the collision meshes' package:// paths are found
            if not (isinstance(dirs, list) and all(isinstance(d, str) and d for d in dirs)):
                raise ScenarioError(f"'{t.key('package_dirs')}' must be a list of folders (strings), got {show(dirs)}")
            dirs = [base / Path(d) for d in dirs]
            robot = Robot.from_urdf(urdf if urdf.is_absolute() else base / urdf, tip=tip, package_dirs=dirs)
    except FrameNotFoundError as exc:
        raise ScenarioError(f"'robot.tip': {exc}") from exc
    except BracekitError as exc:
        raise ScenarioError(f"'{t.key('model' if t.has('model') else 'urdf')}': {exc}") from exc
    try:
        return robot.with_stiffness(stiffness)
    except BracekitError as exc:
        raise ScenarioError(f"'robot.stiffness': {exc}") from exc


BRACE_KEYS = (
    "frame",
    "link",
    "offset",
    "surface",
    "snap",
    "pad_radius",
    "pad_axis",
    "contact",
    "point",
    "normal",
    "tangent",
    "region_radius",
    "surface_radius",
    "environment_stiffness",
    "preload",
    "friction",
)


def _brace_tables(top: _Table) -> list[_Table]:
    """The ``[brace]`` table, or each table of ``[[brace]]`` (an array of tables), named 'brace[i]' from 1."""
    raw = top.raw("brace")
    if not isinstance(raw, list):
        return [top.table("brace", BRACE_KEYS)]
    if not raw:
        raise ScenarioError("'brace' is an empty array: give a [brace] table or at least one [[brace]] table")
    return [_Table(item, f"brace[{i}]", BRACE_KEYS) for i, item in enumerate(raw, start=1)]


def _braces(tables: list[_Table], robot: Robot) -> BracedRobot:
    """The braced robot of one brace table (the paper's model) or of several (the stacked constraint).

    A link-point brace without 'frame' is named "brace" (the first) or "brace_i" (the i-th, from 1).
    """
    braces: list[Brace] = []
    for i, t in enumerate(tables, start=1):
        robot, brace = _brace(t, robot, "brace" if i == 1 else f"brace_{i}")
        braces.append(brace)
    if len(braces) == 1:
        return BracedRobot(robot, braces[0])
    try:
        return BracedRobot(robot, braces)
    except BracekitError as exc:
        raise ScenarioError(f"[[brace]]: {exc}") from exc


def _brace(t: _Table, robot: Robot, default_frame: str = "brace") -> tuple[Robot, Brace]:
    """One brace table: the robot (with the brace's link-point frame added, if any) and the Brace."""
    pad_axis = True  # a frame of the robot's description: its z is the pad direction
    if t.has("link"):
        frame = t.string("frame", default=default_frame)
        if robot.model.existFrame(frame):
            raise ScenarioError(
                f"'{t.key('frame')}' = {show(frame)} is already a frame of the robot; name the new brace point "
                "otherwise"
            )
        try:  # a point on the link's surface (bracekit.geometry.pad) or the offset as given
            offset, normal = brace_point(
                robot,
                t.string("link"),
                t.vector("offset", 3) if t.has("offset") else None,
                t.raw("surface", None),
                t.vector("snap", 3) if t.has("snap") else None,
            )
        except BracekitError as exc:
            raise ScenarioError(f"'{t.key('surface' if t.has('surface') else 'link')}': {exc}") from exc
        rotation = None
        pad_axis = t.has("pad_axis") or normal is not None
        if pad_axis:
            axis = t.vector("pad_axis", 3) if t.has("pad_axis") or normal is None else normal
            rotation = rotation_with_z(axis, f"'{t.key('pad_axis')}' (link axes)", ScenarioError)
        try:
            robot = robot.with_point_frame(frame, t.string("link"), offset, rotation)
        except BracekitError as exc:
            raise ScenarioError(f"'{t.key('link')}': {exc}") from exc
    else:
        if t.has("pad_axis"):
            raise ScenarioError(
                f"'{t.key('pad_axis')}' goes with '{t.key('link')}' (a link point); a brace frame's own z is its "
                "pad axis"
            )
        frame = t.string("frame")
    point, normal = t.vector("point", 3), t.vector("normal", 3)
    if not np.any(normal):
        raise ScenarioError(f"'{t.key('normal')}' must be a non-zero vector (the surface normal, toward the robot)")
    try:
        surface = Surface(point, normal, t.vector("tangent", 3) if t.has("tangent") else None)
    except BracekitError as exc:
        raise ScenarioError(f"'{t.key('tangent')}': {exc}") from exc
    try:
        brace = Brace(
            frame=frame,
            surface=surface,
            contact=contact_type(t.string("contact", tuple(REGISTRY), "frictionless_point")),
            region_radius=t.number("region_radius", positive=True) if t.has("region_radius") else None,
            surface_radius=t.number("surface_radius", positive=True) if t.has("surface_radius") else None,
            environment_stiffness=t.number("environment_stiffness", positive=True)
            if t.has("environment_stiffness")
            else None,
            pad_axis=pad_axis,
            pad_radius=t.number("pad_radius", 0.02) if t.has("pad_radius") else 0.02,
        )
        BracedRobot(robot, brace)  # the checks of one brace (frame, link), with this table's key
        return robot, brace
    except ScenarioError:
        raise
    except BracekitError as exc:
        keys = ("surface_radius", "region_radius", "environment_stiffness", "contact", "pad_radius")
        named = [k for k in keys if k in str(exc)]
        key = named[0] if named else ("link" if t.has("link") else "frame")
        raise ScenarioError(f"'{t.key(key)}': {exc}") from exc


def _holding_of(robot_t: _Table, tables: list[_Table], loads_t: _Table) -> Holding:
    """``[robot] gravity``, ``[loads] wrenches`` and each ``[[brace]]`` table's ``preload`` and ``friction``."""
    preloads, frictions = zip(*(_brace_statics(t) for t in tables), strict=True)
    shared = _holding(robot_t, tables[0], loads_t)  # gravity and the loads, checked as for one brace
    return Holding(
        gravity=shared.gravity,
        wrenches=shared.wrenches,
        preloads=tuple(preloads) if any(p > 0.0 for p in preloads) else None,
        frictions=tuple(frictions) if any(f is not None for f in frictions) else None,
    )


def _brace_statics(t: _Table) -> tuple[float, float | None]:
    """A brace table's ``preload`` P (N, default 0) and ``friction`` μ (None when not given), range-checked."""
    preload = t.number("preload", 0.0)
    if not 0.0 <= preload <= MAX_PRELOAD:
        raise ScenarioError(
            f"'{t.key('preload')}' must be a force in [0, {MAX_PRELOAD:g}] N (the brace pressing), got {preload:g}"
        )
    friction = t.number("friction") if t.has("friction") else None
    if friction is not None and not 0.0 <= friction <= MAX_FRICTION:
        raise ScenarioError(f"'{t.key('friction')}' must be a coefficient μ in [0, {MAX_FRICTION:g}], got {friction:g}")
    return preload, friction


def _holding(robot_t: _Table, brace_t: _Table, loads_t: _Table) -> Holding:
    """``[robot] gravity``, ``[brace] preload`` and ``friction``, ``[loads] wrenches``: what the brace must hold."""
    gravity = robot_t.raw("gravity", False)
    if not isinstance(gravity, bool):
        raise ScenarioError(f"'robot.gravity' must be true or false, got {show(gravity)}")
    preload, friction = _brace_statics(brace_t)
    wrenches = loads_t.points("wrenches", 6) if loads_t.has("wrenches") else None
    if wrenches is not None and len(wrenches) > MAX_WRENCHES:
        raise ScenarioError(f"'loads.wrenches' lists {len(wrenches)} wrenches; give at most {MAX_WRENCHES}")
    try:
        return Holding(gravity=gravity, preload=preload, friction=friction, wrenches=wrenches)
    except BracekitError as exc:
        raise ScenarioError(f"[loads]: {exc}") from exc


def _task(t: _Table) -> Task:
    """The task of ``[task] type``: the registered shape of that kind reads its keys (``simulation.tasks``)."""
    kind = t.string("type", tuple(TASK_SHAPES))
    try:
        return TASK_SHAPES[kind].from_table(t)
    except ScenarioError:
        raise
    except BracekitError as exc:
        raise ScenarioError(f"[task] ({kind}): {exc}") from exc


def _task_space(t: _Table) -> TaskSpace:
    """``[task] space`` ("pose" by default) and ``[task] axis`` (3 numbers, only with "position+axis")."""
    kind = t.string("space", TASK_SPACES, "pose")
    if t.has("axis") and kind != "position+axis":
        raise ScenarioError(
            f"'task.axis' is used only with 'task.space' = \"position+axis\" (here {show(kind)}); remove it"
        )
    axis = t.vector("axis", 3) if t.has("axis") else None
    if axis is not None and not np.any(axis):
        raise ScenarioError("'task.axis' must be a non-zero direction [x, y, z] in tip coordinates")
    try:
        return TaskSpace(cast(Any, kind), axis)
    except BracekitError as exc:
        raise ScenarioError(f"'task.axis': {exc}") from exc
