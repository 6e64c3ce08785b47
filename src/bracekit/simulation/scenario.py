"""Scenario files (TOML): robot, brace, task, strategies and gains, validated into a :class:`Scenario`.

Every mistake raises ScenarioError naming the key and the fix. Shipped scenarios live in
``bracekit/simulation/scenarios/`` and are addressed by name (``paper``).
"""

from __future__ import annotations

import math
import os
import tomllib
from collections.abc import Callable
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any, cast

import numpy as np
from numpy.typing import NDArray

from bracekit._linalg import show
from bracekit.compliance.first_order import ComplianceModel
from bracekit.compliance.preloaded import RUN_MODELS, simulated_model
from bracekit.contact import REGISTRY, Brace, Surface, contact_type
from bracekit.errors import BracekitError, FrameNotFoundError, InputError, ScenarioError
from bracekit.kinematics import BracedRobot
from bracekit.model.robot import Robot
from bracekit.model.shipped import MODELS, load_model
from bracekit.objective import TERMS, Objective, TermContext
from bracekit.resolution.multi import MultiBraceObjective
from bracekit.resolution.strategies import (
    GRADIENT_MODES,
    BracedGradientProjection,
    BracedMinNorm,
    FreeSpaceMinNorm,
    GradientMode,
    Strategy,
)
from bracekit.resolution.task_space import POSE, TASK_SPACES, TaskSpace
from bracekit.simulation.holding import Holding
from bracekit.simulation.tasks import Circle, Line, Task, Waypoints, in_plane
from bracekit.spatial import rotation_with_z, unit
from bracekit.statics.equilibrium import MAX_FRICTION, MAX_PRELOAD
from bracekit.tolerances import MAX_STEPS

Array = NDArray[np.float64]
STRATEGIES = ("free_space_min_norm", "braced_min_norm", "braced_gradient_projection", "braced_qp")
#: The strategies a scenario runs when it names none.
DEFAULT_STRATEGIES = STRATEGIES[:3]
#: The strategies that descend the objective (run once per compliance model).
OPTIMISING = ("braced_gradient_projection", "braced_qp")
#: The start solve's θ_z weight when the brace has a pad axis and gradient projection weights θ_z.
START_THETA_WEIGHT = 0.3


def weight_keys() -> tuple[str, ...]:
    """The weight keys of ``[gradient_projection.weights]``: one per registered objective term, now."""
    return tuple(TERMS)


def shipped_scenarios() -> dict[str, Path]:
    """Name → path of the scenarios shipped with bracekit."""
    root = resources.files("bracekit.simulation").joinpath("scenarios")
    return {p.name[:-5]: Path(str(p)) for p in root.iterdir() if p.name.endswith(".toml")}


class _Table:
    """A TOML table being read: tracks its path for messages and rejects unknown keys."""

    def __init__(self, data: Any, path: str, allowed: tuple[str, ...]) -> None:
        if not isinstance(data, dict):
            if not path:
                raise ScenarioError(f"a scenario must be a TOML table of keys, got {show(data)}")
            raise ScenarioError(f"'{path}' must be a table ([{path}] and its keys), got {show(data)}")
        unknown = sorted(set(data) - set(allowed))
        if unknown:
            where = f"[{path}]" if path else "the top level"
            keys = ", ".join(allowed)
            raise ScenarioError(f"unknown key '{_join(path, unknown[0])}'; allowed keys in {where}: {keys}")
        self.data, self.path = data, path

    def key(self, name: str) -> str:
        return _join(self.path, name)

    def has(self, name: str) -> bool:
        return name in self.data

    def raw(self, name: str, default: Any = ...) -> Any:
        if name not in self.data:
            if default is ...:
                raise ScenarioError(f"missing key '{self.key(name)}'")
            return default
        return self.data[name]

    def number(self, name: str, default: Any = ..., positive: bool = False) -> float:
        v = self.raw(name, default)
        x = _float(v)
        if x is None:
            raise ScenarioError(f"'{self.key(name)}' must be a number, got {show(v)}")
        if positive and x <= 0:
            raise ScenarioError(f"'{self.key(name)}' must be positive, got {show(v)}")
        return x

    def vector(self, name: str, size: int | None = None, default: Any = ...) -> Array:
        v = self.raw(name, default)
        values = [_float(x) for x in v] if isinstance(v, list) else [None]
        if None in values or (size is not None and len(values) != size) or (size is None and not values):
            want = f"{size} numbers" if size else "a list of numbers"
            raise ScenarioError(f"'{self.key(name)}' must be {want}, got {show(v)}")
        return np.asarray(values, dtype=float)

    def points(self, name: str, width: int = 3) -> Array:
        """A list of at least two [x, y, z] points (k×3); with width 6, of at least one [fx, fy, fz, mx, my, mz]."""
        v = self.raw(name)
        rows: list[list[float | None]] = [[None]]
        if isinstance(v, list):
            rows = [[_float(x) for x in p] if isinstance(p, list) and len(p) == width else [None] for p in v]
        least = 2 if width == 3 else 1
        if len(rows) < least or any(None in r for r in rows):
            want = (
                "a list of at least two [x, y, z] points (m)"
                if width == 3
                else "a list of wrenches [fx, fy, fz, mx, my, mz] (N, N·m, world axes)"
            )
            raise ScenarioError(f"'{self.key(name)}' must be {want}, got {show(v)}")
        return np.asarray(rows, dtype=float)

    def string(self, name: str, choices: tuple[str, ...] | None = None, default: Any = ...) -> str:
        v = self.raw(name, default)
        if not isinstance(v, str):
            raise ScenarioError(f"'{self.key(name)}' must be a string, got {show(v)}")
        if choices is not None and v not in choices:
            raise ScenarioError(f"'{self.key(name)}' = {show(v)} is not one of: {', '.join(choices)}")
        return v

    def table(self, name: str, allowed: tuple[str, ...], default: Any = ...) -> _Table:
        return _Table(self.raw(name, default), self.key(name), allowed)


def _join(path: str, key: str) -> str:
    return f"{path}.{key}" if path else key


def _float(v: object) -> float | None:
    """A TOML number as a finite float; None for anything else (booleans, strings, inf, nan, huge integers)."""
    if isinstance(v, bool) or not isinstance(v, int | float):
        return None
    try:
        x = float(v)
    except OverflowError:
        return None
    return x if math.isfinite(x) else None


@dataclass(frozen=True, eq=False)
class Scenario:
    """A validated scenario. Lengths in m, times in s, stiffness in N·m/rad.

    ``start_theta_weight`` is the start solve's θ_z weight ('[start] theta_weight'; 0 without a pad axis).
    """

    name: str
    braced: BracedRobot
    task: Task
    guess: Array
    compliance_model: str
    beta_x: Callable[[float], Array]
    beta_x_spec: str
    alpha: float
    weights: dict[str, float]
    gradient: GradientMode
    dt: float
    strategies: tuple[str, ...]
    feedback_gain: float = 1.0
    description: str = ""
    source: Path | None = None
    task_space: TaskSpace = POSE
    start_theta_weight: float = 0.0
    holding: Holding = field(default_factory=Holding)

    @property
    def robot(self) -> Robot:
        """The robot."""
        return self.braced.robot

    def objective(
        self, model: ComplianceModel | None = None, beta_x: Array | None = None
    ) -> Objective | MultiBraceObjective:
        """G of eq:objective with this scenario's weights (β_x at t = 0 unless given).

        With several braces, the stacked objective: C_i of the stacked constrained C_e, each brace's d and the
        joint-limit barrier.
        """
        beta = self.beta_x(0.0) if beta_x is None else beta_x
        if len(self.braced.braces) > 1:
            return MultiBraceObjective(
                beta,
                ci_weight=self.weights["Ci"],
                region_weight=self.weights["d"],
                joint_limit_weight=self.weights["joint_limit_barrier"],
                theta_weight=self.weights["theta_z"],
            )
        context = TermContext(self.braced, beta, model or simulated_model(self.compliance_model), self.holding)
        keys = [k for k in weight_keys() if self.weights.get(k, 0.0) > 0]
        kept = [(TERMS[k].from_scenario(context), self.weights[k]) for k in keys]
        return Objective([t for t, _ in kept], [w for _, w in kept])

    def strategy(
        self, name: str, *, gradient: GradientMode | None = None, model: ComplianceModel | None = None
    ) -> Strategy:
        """One of the strategies (STRATEGIES) with this scenario's gains, task space and, for braced_qp, its dt."""
        if name not in STRATEGIES:
            raise InputError(f"unknown strategy {show(name)}; choose one of {', '.join(STRATEGIES)}")
        if name == "free_space_min_norm":
            return cast(Strategy, FreeSpaceMinNorm(space=self.task_space))
        if name == "braced_min_norm":
            return cast(Strategy, BracedMinNorm(space=self.task_space))
        if name == "braced_qp":
            from bracekit.resolution.qp import BracedQP

            mode = gradient or self.gradient
            qp = BracedQP(self.objective(model), alpha=self.alpha, gradient=mode, dt=self.dt, space=self.task_space)
            return cast(Strategy, qp)
        strategy = BracedGradientProjection(
            self.objective(model), alpha=self.alpha, gradient=gradient or self.gradient, space=self.task_space
        )
        return cast(Strategy, strategy)


def load_scenario(source: str | os.PathLike[str]) -> Scenario:
    """Read and validate a scenario: a TOML path (a str or an os.PathLike) or a shipped scenario's name ('paper').

    Raises:
        ScenarioError: the file is missing, not TOML, or a key is missing, unknown or malformed (the message
            names the key).
    """
    shipped = shipped_scenarios()
    if isinstance(source, str) and source in shipped:
        path = shipped[source]
    elif isinstance(source, str | os.PathLike) and isinstance(os.fspath(source), str) and os.fspath(source):
        path = Path(os.fspath(source))
    else:
        raise ScenarioError(
            f"a scenario must be a .toml path or a shipped name ({', '.join(sorted(shipped))}), got {show(source)}"
        )
    try:
        found = path.is_file()
    except (OSError, ValueError):  # a name the file system cannot hold
        found = False
    if not found:
        raise ScenarioError(
            f"scenario not found: {show(str(source), 200)}; give a .toml file or one of: {', '.join(sorted(shipped))}"
        )
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{path} is not valid TOML: {show(str(exc), 200)}") from exc
    except (OSError, UnicodeDecodeError) as exc:
        raise ScenarioError(f"cannot read scenario {path}: {show(str(exc), 200)}") from exc
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
        ),
    )
    robot_t = top.table("robot", ("model", "urdf", "tip", "stiffness", "gravity"))
    robot = _robot(robot_t, base)
    brace_ts = _brace_tables(top)
    several = len(brace_ts) > 1
    braced = _braces(brace_ts, robot)
    loads_t = top.table("loads", ("wrenches",), {})
    if several:
        holding = _holding_braces(robot_t, brace_ts, loads_t)
    else:
        holding = _holding(robot_t, brace_ts[0], loads_t)
    robot = braced.robot
    pad_axis = any(b.pad_axis for b in braced.braces) if several else braced.brace.pad_axis
    region = (
        next((b.region_radius for b in braced.braces if b.region_radius is not None), None)
        if several
        else braced.brace.region_radius
    )
    task_t = top.table(
        "task",
        (
            "type",
            "centre",
            "radius",
            "normal",
            "start_direction",
            "period",
            "turns",
            "start",
            "end",
            "duration",
            "points",
            "times",
            "space",
            "axis",
        ),
    )
    task = _task(task_t)
    task_space = _task_space(task_t)
    start = top.table("start", ("guess", "theta_weight"))
    guess = start.vector("guess", robot.n)
    comp = top.table("compliance", ("model", "beta_x"), {})
    model = comp.string("model", RUN_MODELS, "constrained")
    if several and model != "constrained":
        raise ScenarioError(
            f"'compliance.model' = {show(model)} is defined for one brace; with several [[brace]] tables use "
            '"constrained"'
        )
    if model == "preloaded" and not (holding.gravity or holding.preload > 0.0):
        raise ScenarioError(
            "'compliance.model' = \"preloaded\" needs '[robot] gravity = true' or '[brace] preload' > 0 "
            "(without them it is the constrained model)"
        )
    beta_raw = comp.raw("beta_x", "radial")
    if isinstance(beta_raw, str) and beta_raw != "radial":
        want = '"radial" or 6 numbers [vx, vy, vz, wx, wy, wz]'
        raise ScenarioError(f"'compliance.beta_x' must be {want}, got {show(beta_raw)}")
    if beta_raw == "radial":
        if not isinstance(task, Circle):
            raise ScenarioError(
                "'compliance.beta_x' = \"radial\" needs a circle task; give 6 numbers [vx, vy, vz, wx, wy, wz]"
            )
        circle = task

        def beta_x(t: float) -> Array:
            return np.concatenate([circle.radial(t), np.zeros(3)])

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
    weights = {k: w.number(k, 0.0) for k in weight_keys()}
    for k, v in weights.items():
        if v < 0:
            raise ScenarioError(f"'gradient_projection.weights.{k}' must be ≥ 0, got {v}")
    if several:
        _refuse_one_brace_weights(weights, start)
    if weights["theta_z"] > 0 and not pad_axis:
        raise ScenarioError(
            "'gradient_projection.weights.theta_z' needs a pad axis, and a link-point brace has none: give "
            "'brace.pad_axis' = [x, y, z] (link axes) or set theta_z = 0"
        )
    theta_weight = _start_theta_weight(start, pad_axis and not several, weights["theta_z"] if not several else 0.0)
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
            robot = Robot.from_urdf(urdf if urdf.is_absolute() else base / urdf, tip=tip)
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
        rotation = None
        pad_axis = t.has("pad_axis")
        if pad_axis:
            rotation = rotation_with_z(t.vector("pad_axis", 3), f"'{t.key('pad_axis')}' (link axes)", ScenarioError)
        try:
            robot = robot.with_point_frame(frame, t.string("link"), t.vector("offset", 3, [0.0, 0.0, 0.0]), rotation)
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
        )
        BracedRobot(robot, brace)  # the checks of one brace (frame, link), with this table's key
        return robot, brace
    except ScenarioError:
        raise
    except BracekitError as exc:
        named = [k for k in ("surface_radius", "region_radius", "environment_stiffness", "contact") if k in str(exc)]
        key = named[0] if named else ("link" if t.has("link") else "frame")
        raise ScenarioError(f"'{t.key(key)}': {exc}") from exc


def _holding_braces(robot_t: _Table, tables: list[_Table], loads_t: _Table) -> Holding:
    """``[robot] gravity``, ``[loads] wrenches`` and each ``[[brace]]`` table's ``preload`` and ``friction``."""
    preloads: list[float] = []
    frictions: list[float | None] = []
    for t in tables:
        preload = t.number("preload", 0.0)
        if not 0.0 <= preload <= MAX_PRELOAD:
            raise ScenarioError(
                f"'{t.key('preload')}' must be a force in [0, {MAX_PRELOAD:g}] N (the brace pressing), got {preload:g}"
            )
        friction = t.number("friction") if t.has("friction") else None
        if friction is not None and not 0.0 <= friction <= MAX_FRICTION:
            raise ScenarioError(
                f"'{t.key('friction')}' must be a coefficient μ in [0, {MAX_FRICTION:g}], got {friction:g}"
            )
        preloads.append(preload)
        frictions.append(friction)
    shared = _holding(robot_t, tables[0], loads_t)  # gravity and the loads, checked as for one brace
    return Holding(
        gravity=shared.gravity,
        wrenches=shared.wrenches,
        preloads=tuple(preloads) if any(p > 0.0 for p in preloads) else None,
        frictions=tuple(frictions) if any(f is not None for f in frictions) else None,
    )


#: The weight keys of the several-brace objective (:class:`bracekit.resolution.multi.MultiBraceObjective`).
MULTI_BRACE_WEIGHTS = ("Ci", "theta_z", "d", "joint_limit_barrier")


def _refuse_one_brace_weights(weights: dict[str, float], start: _Table) -> None:
    """ScenarioError for weights the several-brace objective does not have (it has C_i and each brace's d)."""
    for key, value in weights.items():
        if key not in MULTI_BRACE_WEIGHTS and value > 0:
            raise ScenarioError(
                f"'gradient_projection.weights.{key}' is defined for one brace: with several [[brace]] tables the "
                f"objective has {' and '.join(MULTI_BRACE_WEIGHTS)}; set {key} = 0"
            )
    if start.has("theta_weight") and start.number("theta_weight") != 0:
        raise ScenarioError(
            "'start.theta_weight' is defined for one brace; with several [[brace]] tables set it to 0 or remove it"
        )


def _holding(robot_t: _Table, brace_t: _Table, loads_t: _Table) -> Holding:
    """``[robot] gravity``, ``[brace] preload`` and ``friction``, ``[loads] wrenches``: what the brace must hold."""
    gravity = robot_t.raw("gravity", False)
    if not isinstance(gravity, bool):
        raise ScenarioError(f"'robot.gravity' must be true or false, got {show(gravity)}")
    preload = brace_t.number("preload", 0.0)
    if not 0.0 <= preload <= MAX_PRELOAD:
        raise ScenarioError(
            f"'brace.preload' must be a force in [0, {MAX_PRELOAD:g}] N (the brace pressing), got {preload:g}"
        )
    friction = brace_t.number("friction") if brace_t.has("friction") else None
    if friction is not None and not 0.0 <= friction <= MAX_FRICTION:
        raise ScenarioError(f"'brace.friction' must be a coefficient μ in [0, {MAX_FRICTION:g}], got {friction:g}")
    wrenches = loads_t.points("wrenches", 6) if loads_t.has("wrenches") else None
    try:
        return Holding(gravity=gravity, preload=preload, friction=friction, wrenches=wrenches)
    except BracekitError as exc:
        raise ScenarioError(f"[loads]: {exc}") from exc


def _task(t: _Table) -> Task:
    kind = t.string("type", ("circle", "line", "waypoints"))
    try:
        if kind == "circle":
            normal = unit(t.vector("normal", 3), "'task.normal'", ScenarioError)
            start = t.vector("start_direction", 3)
            if in_plane(normal, start) is None:
                raise ScenarioError(
                    "'task.start_direction' is parallel to 'task.normal'; give a direction in the circle's plane"
                )
            return Circle(
                centre=t.vector("centre", 3),
                radius=t.number("radius", positive=True),
                normal=t.vector("normal", 3),
                period=t.number("period", positive=True),
                start_direction=start,
                turns=t.number("turns", 1.0, positive=True),
            )
        if kind == "line":
            return Line(t.vector("start", 3), t.vector("end", 3), t.number("duration", positive=True))
        points = t.points("points")
        times = t.vector("times")
        if times.size != len(points) or times[0] != 0.0 or np.any(np.diff(times) <= 0):
            raise ScenarioError(
                f"'task.times' must start at 0, increase strictly and give one time per point ({len(points)}), "
                f"got {show(times.tolist())}"
            )
        return Waypoints(points, times)
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
