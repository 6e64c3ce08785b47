"""A cobot scenario (TOML): a bracekit scenario's braced robot, and the worker, the work and the controller.

The file names a base scenario (``scenario``: a shipped name or a path relative to the file) for the robot, its
braces, the start guess and the strategies' objective, and adds

* ``[robot]``: ``preload`` P (N, the normal force every brace's set point presses with), ``friction`` μ of
  the pad while it is clamped for the work, ``gravity`` (the URDF's masses, held by the set points),
  ``damping_time`` τ (s): the servo's damping D = τK;
* ``[control]``: ``rate`` (Hz, 1000), ``physics_dt`` (MuJoCo's step, s), ``strategies``, ``feedback`` (1/s, the
  tool reference's feedback gain);
* ``[admittance]``: ``mass`` (kg), ``damping`` (N·s/m), ``deadband`` (N) of the virtual mass–damper;
* ``[operator]``: ``targets`` (k×3, m, world), the human arm's ``stiffness`` (N/m) and ``damping`` (N·s/m),
  ``travel`` (s per target, minimum-jerk hand path), ``approach`` (s holding the hand at the target),
  ``dwell`` (s of work at each target, the worker's hand off the handle), ``tremor`` (N rms);
* ``[process]``: ``wrench`` (6,) the work's wrench on the tool (N, N·m, world axes), ``start`` (s into the
  dwell), ``ramp`` (s), ``hold`` (s).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from bracekit._linalg import show
from bracekit.errors import InputError, ScenarioError
from bracekit.simulation.scenario import load_scenario
from bracekit.simulation.scenario_model import Scenario
from bracekit.simulation.toml_table import Table, read_source

Array = NDArray[np.float64]

__all__ = ["CobotScenario", "Operator", "Process", "load_cobot", "shipped_cobots"]

STRATEGIES = ("free_space_min_norm", "braced_min_norm", "braced_gradient_projection", "braced_qp")


@dataclass(frozen=True)
class Operator:
    """The worker: hand targets (k×3, m), arm stiffness (N/m) and damping (N·s/m), phase times (s), tremor (N)."""

    targets: Array
    stiffness: float
    damping: float
    travel: float
    approach: float
    dwell: float
    tremor: float


@dataclass(frozen=True)
class Process:
    """The work's wrench on the tool (6,), N and N·m, world; on at ``start`` s into a dwell, ramped, held."""

    wrench: Array
    start: float
    ramp: float
    hold: float


@dataclass(frozen=True)
class CobotScenario:
    """A cobot scenario (module docstring); ``base`` is the braced robot's scenario."""

    name: str
    description: str
    base: Scenario
    seed: int
    preload: float
    friction: float
    gravity: bool
    damping_time: float
    rate: float
    physics_dt: float
    feedback: float
    strategies: tuple[str, ...]
    mass: float
    admittance_damping: float
    deadband: float
    operator: Operator
    process: Process

    @property
    def dt(self) -> float:
        """The control period (s)."""
        return 1.0 / self.rate

    @property
    def duration(self) -> float:
        """The whole run (s): per target a travel, an approach and a dwell."""
        op = self.operator
        return len(op.targets) * (op.travel + op.approach + op.dwell)


def shipped_cobots() -> dict[str, Path]:
    """Name → path of the cobot scenarios shipped with bracekit."""
    root = Path(__file__).resolve().parent / "scenarios"
    return {p.stem: p for p in sorted(root.glob("*.toml"))}


def load_cobot(source: str | os.PathLike[str]) -> CobotScenario:
    """Read a cobot scenario: a shipped name ('panda-cobot') or a TOML path; ScenarioError naming a bad key."""
    path, data = read_source(source, shipped_cobots(), "cobot scenario")
    try:
        return parse_cobot(data, path)
    except ScenarioError:
        raise
    except InputError as exc:
        raise ScenarioError(f"{path.name}: {exc}") from exc


def _positive(t: Table, key: str, default: Any = ...) -> float:
    return t.number(key, default, positive=True)


def _nonnegative(t: Table, key: str, default: Any = ...) -> float:
    value = t.number(key, default)
    if value < 0.0:
        raise ScenarioError(f"'{t.key(key)}' must be ≥ 0, got {show(value)}")
    return value


def parse_cobot(data: dict[str, Any], path: Path) -> CobotScenario:
    """Validate the TOML data of a cobot scenario read from ``path``."""
    top = Table(
        data, "", ("name", "description", "scenario", "seed", "robot", "control", "admittance", "operator", "process")
    )
    base_name = top.string("scenario")
    local = path.parent / base_name
    base = load_scenario(local if local.suffix == ".toml" and local.is_file() else base_name)
    robot = top.table("robot", ("preload", "friction", "gravity", "damping_time"), {})
    gravity = robot.raw("gravity", True)
    if not isinstance(gravity, bool):
        raise ScenarioError(f"'robot.gravity' must be true or false, got {show(gravity)}")
    control = top.table("control", ("rate", "physics_dt", "strategies", "feedback"), {})
    strategies = control.raw("strategies", list(base.strategies))
    if not isinstance(strategies, list) or not strategies or any(s not in STRATEGIES for s in strategies):
        raise ScenarioError(f"'control.strategies' must list some of {', '.join(STRATEGIES)}, got {show(strategies)}")
    rate = _positive(control, "rate", 1000.0)
    physics_dt = _positive(control, "physics_dt", 2.5e-4)
    if physics_dt > 1.0 / rate or abs(round(1.0 / (rate * physics_dt)) * physics_dt * rate - 1.0) > 1e-9:
        raise ScenarioError(
            f"'control.physics_dt' = {physics_dt:g} s must divide the control period 1/rate = {1.0 / rate:g} s"
        )
    adm = top.table("admittance", ("mass", "damping", "deadband"), {})
    op_t = top.table("operator", ("targets", "stiffness", "damping", "travel", "approach", "dwell", "tremor"))
    operator = Operator(
        targets=op_t.points("targets"),
        stiffness=_positive(op_t, "stiffness"),
        damping=_nonnegative(op_t, "damping"),
        travel=_positive(op_t, "travel"),
        approach=_nonnegative(op_t, "approach"),
        dwell=_positive(op_t, "dwell"),
        tremor=_nonnegative(op_t, "tremor", 0.0),
    )
    pr = top.table("process", ("wrench", "start", "ramp", "hold"))
    process = Process(
        wrench=pr.vector("wrench", 6),
        start=_positive(pr, "start", 0.3),
        ramp=_positive(pr, "ramp", 0.1),
        hold=_positive(pr, "hold"),
    )
    needed = process.start + 2 * process.ramp + process.hold
    if needed > operator.dwell:
        raise ScenarioError(
            f"'operator.dwell' = {operator.dwell:g} s is shorter than the work (start + 2·ramp + hold = {needed:g} s)"
        )
    seed = top.raw("seed", 0)
    if not isinstance(seed, int) or isinstance(seed, bool) or seed < 0:
        raise ScenarioError(f"'seed' must be an integer ≥ 0, got {show(seed)}")
    return CobotScenario(
        name=str(top.raw("name", path.stem)),
        description=str(top.raw("description", "")),
        base=base,
        seed=seed,
        preload=_nonnegative(robot, "preload", 10.0),
        friction=_nonnegative(robot, "friction", 0.8),
        gravity=gravity,
        damping_time=_positive(robot, "damping_time", 0.05),
        rate=rate,
        physics_dt=physics_dt,
        feedback=_nonnegative(control, "feedback", 20.0),
        strategies=tuple(strategies),
        mass=_positive(adm, "mass", 2.0),
        admittance_damping=_positive(adm, "damping", 30.0),
        deadband=_nonnegative(adm, "deadband", 0.5),
        operator=operator,
        process=process,
    )
