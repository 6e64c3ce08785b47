"""A task context: what every candidate of the same task shares, computed once per task.

The reference start is the configuration nearest the base scenario's start guess (minimum-norm Gauss–Newton)
with the tip at the task's start pose (the task's rotation, else the guess's tip orientation); the free-space
minimum-norm run goes from there along the task. Candidates that differ only in where the brace is share a
context; the other inputs (task centre and radius, stiffness, preload, friction) make new ones. A candidate's
run needs the reference start only (:func:`reference_context`), so a sweep runs its candidates while the
free-space run (:func:`free_space_context`) is still under way and adds its columns to their rows afterwards.
A worker solves a task's reference start and builds its scenario once (:func:`held_reference`,
:func:`held_scenario`): its candidates' tasks then depend on no other task, so the scheduler hands each to
whichever worker is free, and a candidate does not parse the task's scenario again.
"""

from __future__ import annotations

import threading
import time
import warnings
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from bracekit.errors import BracekitError
from bracekit.simulation.scenario import parse_scenario
from bracekit.simulation.scenario_model import Scenario
from bracekit.simulation.simulate import correct, simulate
from bracekit.studies.sweep.collector import collector_paused
from bracekit.studies.sweep.spec import BRACE_AXES, SweepSpec

Array = NDArray[np.float64]


@dataclass(frozen=True)
class TaskContext:
    """The shared part of a task's candidates. Arrays in SI units (rad, s).

    Attributes:
        key: the context inputs as a key (:attr:`Candidate.context_key`).
        inputs: the context inputs.
        q_ref: the reference start (n,), or None when it could not be solved (``failure`` says why).
        t: sample times of the free-space run (N,). Q: its configurations (N, n). beta: β_x at each sample (N, 6).
        free: the free-space run's summary (Ci_mean, k_mean, completed, failure, ...).
    """

    key: str
    inputs: dict[str, Any]
    q_ref: Array | None
    t: Array = field(default_factory=lambda: np.zeros(0))
    Q: Array = field(default_factory=lambda: np.zeros((0, 0)))
    beta: Array = field(default_factory=lambda: np.zeros((0, 6)))
    free: dict[str, Any] = field(default_factory=dict)
    failure: str | None = None
    wall_s: float = 0.0


def context_scenario(spec: SweepSpec, inputs: dict[str, Any]) -> Scenario:
    """The base scenario with the context inputs (its own brace kept; free space does not use it)."""
    from bracekit.studies.sweep.scenario import context_data

    return parse_scenario(context_data(spec, inputs), base=spec.base_dir, name=spec.name)


def reference_start(scenario: Scenario) -> Array:
    """The configuration nearest the scenario's guess with the tip at the task's start pose (free space).

    Raises:
        ConvergenceError: no such configuration near the guess. JointLimitError: it is outside the joint limits.
    """
    from bracekit.errors import JointLimitError

    braced = scenario.braced
    guess = scenario.guess
    rotation = scenario.task.rotation
    if rotation is None:
        rotation = braced.state(guess).R_e
    q = correct(braced, guess, scenario.task.position(0.0), rotation, None, space=scenario.task_space).q
    robot = scenario.robot
    outside = np.flatnonzero((q < robot.lower) | (q > robot.upper))
    if outside.size:
        raise JointLimitError(
            f"the reference start puts joint {int(outside[0]) + 1} outside its limits; change the start guess"
        )
    return q


def reference_context(spec: SweepSpec, inputs: dict[str, Any], key: str) -> TaskContext:
    """The task context's reference start only (no free-space run): all a candidate's run needs.

    Never raises a BracekitError: a reference start that cannot be solved is the context's ``failure``.
    """
    began = time.perf_counter()
    try:
        q_ref = reference_start(context_scenario(spec, inputs))
    except BracekitError as exc:
        return TaskContext(key, inputs, None, failure=f"task context: {exc}", wall_s=time.perf_counter() - began)
    return TaskContext(key, inputs, q_ref, wall_s=time.perf_counter() - began)


def free_space_context(spec: SweepSpec, reference: TaskContext) -> TaskContext:
    """`reference` (:func:`reference_context`) completed by the free-space minimum-norm run from its start.

    Never raises a BracekitError: a free-space run that fails makes the context a failed one (``q_ref`` None),
    as when the reference start cannot be solved. Python's garbage collector is held off during the run
    (:mod:`.collector`).
    """
    if reference.q_ref is None:
        return reference
    with collector_paused():
        return _free_space(spec, reference, reference.q_ref)


def _free_space(spec: SweepSpec, reference: TaskContext, q_ref: Array) -> TaskContext:
    key, inputs = reference.key, reference.inputs
    began = time.perf_counter() - reference.wall_s
    try:
        sc = context_scenario(spec, inputs)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            tr = simulate(
                sc.braced,
                sc.strategy("free_space_min_norm"),
                sc.task,
                q_ref,
                sc.dt,
                sc.beta_x,
                feedback_gain=sc.feedback_gain,
            )
    except BracekitError as exc:
        return TaskContext(key, inputs, None, failure=f"task context: {exc}", wall_s=time.perf_counter() - began)
    summary = tr.summary(sc.compliance_model if sc.compliance_model != "preloaded" else "constrained")
    beta = np.array([sc.beta_x(float(t)) for t in tr.t])
    return TaskContext(
        key,
        inputs,
        q_ref,
        t=tr.t,
        Q=tr.q,
        beta=beta,
        free=summary,
        failure=None,
        wall_s=time.perf_counter() - began,
    )


def task_context(spec: SweepSpec, inputs: dict[str, Any], key: str) -> TaskContext:
    """Solve the reference start and run free-space minimum norm along the task; never raises a BracekitError."""
    return free_space_context(spec, reference_context(spec, inputs, key))


def context_inputs(inputs: dict[str, Any]) -> dict[str, Any]:
    """A candidate's inputs without where the brace is: its task context's inputs."""
    return {k: v for k, v in inputs.items() if k not in BRACE_AXES}


#: Task contexts this process holds (:func:`held_reference`), at most this many (the oldest dropped first).
MAX_HELD = 64


@dataclass(frozen=True)
class _Held:
    spec: SweepSpec
    scenario: Scenario | None  # None: it could not be built (the reference's failure says why)
    reference: TaskContext


_HELD: dict[str, _Held] = {}
_HELD_LOCK = threading.Lock()


def _held(spec: SweepSpec, key: str) -> _Held | None:
    with _HELD_LOCK:
        hit = _HELD.get(key)
    return hit if hit is not None and (hit.spec is spec or hit.spec == spec) else None


def held_reference(spec: SweepSpec, inputs: dict[str, Any], key: str) -> TaskContext:
    """:func:`reference_context` of the task, solved once in this process per spec and context key.

    The same as solving it again (the solve is deterministic); never raises a BracekitError.
    """
    hit = _held(spec, key)
    if hit is not None:
        return hit.reference
    began = time.perf_counter()
    scenario: Scenario | None = None
    try:
        scenario = context_scenario(spec, inputs)
        reference = TaskContext(key, inputs, reference_start(scenario), wall_s=time.perf_counter() - began)
    except BracekitError as exc:
        reference = TaskContext(key, inputs, None, failure=f"task context: {exc}", wall_s=time.perf_counter() - began)
    with _HELD_LOCK:
        _HELD.pop(key, None)
        _HELD[key] = _Held(spec, scenario, reference)
        while len(_HELD) > MAX_HELD:
            del _HELD[next(iter(_HELD))]
    return reference


_BASE: list[tuple[SweepSpec, Scenario]] = []  # the last spec's base scenario


def held_base(spec: SweepSpec) -> Scenario:
    """:meth:`SweepSpec.base_scenario`, built once in this process per spec (the last spec's kept)."""
    with _HELD_LOCK:
        hit = _BASE[0] if _BASE else None
    if hit is not None and (hit[0] is spec or hit[0] == spec):
        return hit[1]
    base = spec.base_scenario()
    with _HELD_LOCK:
        _BASE[:] = [(spec, base)]
    return base


def held_scenario(spec: SweepSpec, context: TaskContext) -> Scenario:
    """:func:`context_scenario` of `context`'s inputs: the one :func:`held_reference` built, else a new one."""
    hit = _held(spec, context.key)
    if hit is not None and hit.scenario is not None and hit.reference.inputs == context.inputs:
        return hit.scenario
    return context_scenario(spec, context.inputs)
