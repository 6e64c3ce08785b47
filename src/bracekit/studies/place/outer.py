"""The outer level: a place over the whole task (simulated like a sweep candidate) and a derivative-free refinement.

:func:`evaluate_place` runs the place's scenario (:mod:`bracekit.studies.place.scenario`: the start guess the
inner optimum's posture, the surface through the pad there) with both braced strategies (a compass trial with
gradient projection only, as the sweep's refinement), and judges the row by
the sweep's feasibility rules (:func:`bracekit.studies.sweep.evaluate.summary_columns`: k of J̃, clearance,
joint limits, margins, holding); :func:`settle_place` checks a feasible one in MuJoCo. The refinement is a
compass search on (s, φ) whose trial places (:func:`polls`: s ± h_s, φ ± h_φ, the start posture kept) run as
one parallel batch per round (:mod:`bracekit.studies.place.engine`): the best feasible trial with a lower mean
C_i of gradient projection that MuJoCo settles on becomes the centre, else the steps halve. Infeasible trials
never win.
"""

from __future__ import annotations

import time
from dataclasses import replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from bracekit.errors import BracekitError
from bracekit.simulation.scenario import parse_scenario
from bracekit.simulation.scenario_model import Scenario
from bracekit.studies.place.scenario import Place, pad_world, place_data
from bracekit.studies.place.settle import Settled, settles
from bracekit.studies.place.surface import SurfaceKind, link_surface
from bracekit.studies.sweep.collector import collector_paused
from bracekit.studies.sweep.context import TaskContext
from bracekit.studies.sweep.evaluate import RESULT_COLUMNS, SEARCH_STRATEGIES, judged_run, single_thread
from bracekit.studies.sweep.refine import usable
from bracekit.studies.sweep.spec import BRACED_STRATEGIES, SweepSpec

Array = NDArray[np.float64]

#: The whole-task columns of an evaluation row (the sweep's, without its screening columns).
TASK_COLUMNS = tuple(c for c in RESULT_COLUMNS if not c.startswith("screen"))


def _scenario(
    spec: SweepSpec, place: Place, q: Array, kind: SurfaceKind, strategies: tuple[str, ...] = BRACED_STRATEGIES
) -> tuple[Array, Scenario]:
    """The pad's world point at posture q and the place's scenario (the surface through it, `strategies` run)."""
    surface = link_surface(spec.base_scenario().robot, place.link, kind)
    centre = pad_world(spec, surface, place, q)
    data = place_data(spec, surface, place, q, centre)
    sc = parse_scenario(data, base=spec.base_dir, name=data["name"])
    return centre, sc if sc.strategies == strategies else replace(sc, strategies=strategies)


def evaluate_place(
    spec: SweepSpec,
    place: Place,
    q: Array,
    context: TaskContext,
    stage: str,
    kind: SurfaceKind = "capsule",
    check: bool = False,
) -> dict[str, Any]:
    """The whole-task row of a place braced at posture q: the sweep's result columns; never raises a BracekitError.

    A ``"refine"`` row runs gradient projection only, as the sweep's refinement does (its minimum-norm columns
    None: the search reads C_i of gradient projection); the other stages run both braced strategies, as the
    sweep's simulated candidates. Python's cyclic garbage collector is held off during the run (as a sweep
    candidate's: :mod:`bracekit.studies.sweep.collector`).

    ``mujoco_settles`` and ``mujoco_message``: with `check`, a feasible row's MuJoCo check (:func:`settle_place`,
    right after the run on the same worker); else None (not checked: the engine checks the feasible rows it
    may name the best, best first).
    """
    single_thread()
    began = time.perf_counter()
    row: dict[str, Any] = {"stage": stage, "link": place.link, "fraction": place.fraction}
    row["angle_deg"] = place.angle_deg
    row |= dict.fromkeys(TASK_COLUMNS)
    row |= {"completed": False, "feasible": False, "Ci_mean_free_space": context.free.get("Ci_mean")}
    strategies = SEARCH_STRATEGIES if stage == "refine" else BRACED_STRATEGIES
    with collector_paused():
        row = judged_run(spec, row, began, context, lambda: _scenario(spec, place, q, kind, strategies))
    row["mujoco_settles"] = row["mujoco_message"] = None
    if check and usable(row):
        row["mujoco_settles"], row["mujoco_message"] = settle_place(spec, place, q, kind)
        row["wall_s"] = time.perf_counter() - began
    return row


def settle_place(spec: SweepSpec, place: Place, q: Array, kind: SurfaceKind = "capsule") -> Settled:
    """MuJoCo's static check (:func:`bracekit.studies.place.settle.settles`) of the place's scenario at posture q."""
    single_thread()
    try:
        scenario = _scenario(spec, place, q, kind)[1]
    except BracekitError as exc:
        return Settled(False, f"MuJoCo's static check: {exc}")
    return settles(scenario)


def polls(place: Place, step: tuple[float, float], bounds: tuple[float, float]) -> list[Place]:
    """The compass step's trial places: the fraction ± step[0] (inside `bounds`) and the angle ± step[1] (rad)."""
    lo, hi = bounds
    out = [place._replace(fraction=f) for f in (place.fraction - step[0], place.fraction + step[0]) if lo <= f <= hi]
    return out + [place._replace(angle=place.angle + d) for d in (-step[1], step[1])]
