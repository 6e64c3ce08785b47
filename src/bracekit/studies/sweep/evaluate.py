"""One candidate → one row: build its scenario, run both braced strategies along the task, check feasibility.

Never raises for a numerical failure: the row records it (``completed`` False, ``failure`` the reason). The row
is the same whichever process computes it (no times or process names in it, apart from ``wall_s``).
"""

from __future__ import annotations

import dataclasses
import math
import sys
import time
import warnings
from collections.abc import Callable
from typing import Any, TypeGuard

import numpy as np
from numpy.typing import NDArray

from bracekit.errors import BracekitError, InputError
from bracekit.simulation.scenario import parse_scenario
from bracekit.simulation.scenario_model import Scenario
from bracekit.studies.sweep.candidates import Candidate
from bracekit.studies.sweep.collector import collector_paused
from bracekit.studies.sweep.context import TaskContext
from bracekit.studies.sweep.scenario import candidate_data, point_offset
from bracekit.studies.sweep.spec import BRACED_STRATEGIES, POINT_FRAME, SweepSpec

Array = NDArray[np.float64]

#: The short names of the strategies in column names.
SHORT = {"free_space_min_norm": "free_space", "braced_min_norm": "min_norm", "braced_gradient_projection": "gp"}
#: The braced run a refinement's search reads (:func:`evaluate_candidate`): gradient projection's.
SEARCH_STRATEGIES = ("braced_gradient_projection",)
#: Output columns of a candidate's row, after its inputs (SI units: m/N, m, rad, s).
RESULT_COLUMNS = (
    "point_x",
    "point_y",
    "point_z",
    "screened_out",
    "screen_clearance_m",
    "screen_Ci_mean",
    "screen_k_max",
    "Ci_mean_free_space",
    "Ci_mean_min_norm",
    "Ci_mean_gp",
    "Ci_reduction_gp",
    "k_mean_min_norm",
    "k_mean_gp",
    "min_link_clearance_m",
    "max_joint_limit_violation_rad",
    "max_region_radius_m",
    "min_liftoff_margin",
    "min_slip_margin",
    "min_torque_margin",
    "holds",
    "unstable_samples",
    "completed_min_norm",
    "failure_min_norm",
    "completed",
    "valid",
    "invalid_reasons",
    "feasible",
    "failure",
    "warnings",
    "wall_s",
)


def single_thread() -> None:
    """One numba thread in this process (a worker runs one candidate at a time; no oversubscription)."""
    numba = sys.modules.get("numba")
    if numba is not None:
        numba.set_num_threads(1)


def input_columns(spec: SweepSpec) -> list[str]:
    """The input columns of a spec's rows: each axis, vectors as name_x, name_y, name_z."""
    out = []
    for a in spec.axes:
        out += [f"{a.name}_{c}" for c in "xyz"] if a.kind == "vector" else [a.name]
    return out


def input_values(spec: SweepSpec, candidate: Candidate) -> dict[str, Any]:
    """The candidate's inputs as columns."""
    out: dict[str, Any] = {}
    for a in spec.axes:
        v = candidate.inputs[a.name]
        if a.kind == "vector":
            out.update({f"{a.name}_{c}": float(x) for c, x in zip("xyz", v, strict=True)})
        else:
            out[a.name] = v
    return out


def empty_row(spec: SweepSpec, candidate: Candidate) -> dict[str, Any]:
    """A row with the candidate's inputs and every result column None (not run)."""
    row: dict[str, Any] = {"candidate": candidate.id, "index": candidate.index}
    row |= input_values(spec, candidate)
    row |= dict.fromkeys(RESULT_COLUMNS)
    row["screened_out"] = False
    row["completed"] = False
    row["feasible"] = False
    return row


def candidate_point(spec: SweepSpec, candidate: Candidate, context: TaskContext) -> np.ndarray:
    """The candidate point's world position at the context's reference start (m)."""
    from bracekit.studies.sweep.context import held_scenario

    if context.q_ref is None:
        raise ValueError("the task context has no reference start")
    robot = held_scenario(spec, context).robot
    point = robot.with_point_frame(POINT_FRAME, candidate.inputs["link"], point_offset(spec, robot, candidate.inputs))
    placement, _ = point.frame_kinematics(context.q_ref, [point.frame_id(POINT_FRAME)])[0]
    return np.asarray(placement[:3, 3], dtype=float)


def candidate_scenario(
    spec: SweepSpec, candidate: Candidate, context: TaskContext, point: Array | None = None
) -> Scenario:
    """The candidate's scenario (see :mod:`bracekit.studies.sweep.scenario`); needs a solved context.

    `point`: the candidate point (m, world) if already known (:func:`candidate_point`).
    """
    if context.q_ref is None:
        raise ValueError("the task context has no reference start")
    if point is None:
        point = candidate_point(spec, candidate, context)
    centre = point + np.asarray(candidate.inputs.get("region_offset", [0.0, 0.0, 0.0]), dtype=float)
    data = candidate_data(spec, candidate, context.q_ref, centre)
    return parse_scenario(data, base=spec.base_dir, name=data["name"])


def _num(value: Any) -> float | None:
    return None if value is None or not np.isfinite(value) else float(value)


def finite(value: Any) -> TypeGuard[float]:
    """Whether `value` is a finite number (not None, inf or NaN)."""
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def feasibility(spec: SweepSpec, row: dict[str, Any]) -> str | None:
    """Why a completed gradient-projection run, as its row's numbers, is not feasible (the first reason), or None.

    Uses the spec's current ``[feasibility]`` bounds only, so a row saved by an earlier run is judged again.
    """
    f = spec.feasibility
    if row.get("valid") is False:
        return f"not valid: {row.get('invalid_reasons') or 'see the run summary'}"
    k = row.get("k_mean_gp")
    if k is None or not finite(k):
        return "k_mean of gradient projection is not finite"
    if k > f.k_max:
        return f"k_mean {k:.3g} > k_max {f.k_max:g}"
    violation = row.get("max_joint_limit_violation_rad")
    if violation is not None and violation > f.joint_limit_tolerance:
        return f"outside the joint limits by {violation:.3g} rad"
    clearance = row.get("min_link_clearance_m")
    if clearance is not None and clearance < f.min_clearance:
        return f"a link comes {clearance:.3g} m from the surface (< {f.min_clearance:g} m)"
    for key in ("min_liftoff_margin", "min_slip_margin", "min_torque_margin"):
        margin = row.get(key)
        if margin is not None and margin < f.min_margin:
            return f"{key} {margin:.3g} < {f.min_margin:g}"
    unstable = row.get("unstable_samples")
    if unstable:
        return f"unstable: {unstable} samples where the preloaded contact is not stable"
    if row.get("holds") is False:
        return "the brace does not hold (holds = false: a margin below 1 or a torque beyond the effort limit)"
    if not finite(row.get("Ci_mean_gp")):
        return "mean C_i of gradient projection is not finite"
    return None


def judge(spec: SweepSpec, row: dict[str, Any]) -> dict[str, Any]:
    """The row with ``feasible`` and ``failure`` set by the spec's current bounds (a new dict).

    A screened-out row is returned as it is; a run that did not complete keeps its own failure reason.
    """
    out = dict(row)
    if out.get("screened_out"):
        out["feasible"] = False
        return out
    if not out.get("completed"):
        out["feasible"] = False
        return out
    reason = feasibility(spec, out)
    out["feasible"] = reason is None
    out["failure"] = reason
    return out


def evaluate_candidate(
    spec: SweepSpec, candidate: Candidate, context: TaskContext, strategies: tuple[str, ...] = BRACED_STRATEGIES
) -> dict[str, Any]:
    """The candidate's row: inputs, C_i and k of each strategy, margins, feasibility and the failure reason.

    `strategies`: the braced runs, both by default. With :data:`SEARCH_STRATEGIES` (gradient projection only,
    what a refinement's search reads) the minimum-norm columns are None and ``warnings`` counts that run's
    only; every other column is the one of both runs (the runs are independent of each other). Python's cyclic
    garbage collector is held off during the runs (:mod:`.collector`).
    """
    if strategies not in (BRACED_STRATEGIES, SEARCH_STRATEGIES):
        raise InputError(f"strategies must be {BRACED_STRATEGIES} or {SEARCH_STRATEGIES}, got {strategies!r}")
    single_thread()
    began = time.perf_counter()
    with collector_paused():
        row = _evaluate(spec, candidate, context, strategies, began)
    row["wall_s"] = time.perf_counter() - began  # with the collection of what the runs left
    return row


def evaluate_held(
    spec: SweepSpec, candidate: Candidate, strategies: tuple[str, ...] = BRACED_STRATEGIES
) -> dict[str, Any]:
    """:func:`evaluate_candidate` from the candidate's reference context as this process holds it.

    (:func:`.context.held_reference`: solved once per process and task.) A sweep's candidate task, which so
    depends on no other task; the row is the one :func:`evaluate_candidate` gives from
    :func:`.context.reference_context`.
    """
    from bracekit.studies.sweep.context import context_inputs, held_reference

    context = held_reference(spec, context_inputs(candidate.inputs), candidate.context_key)
    return evaluate_candidate(spec, candidate, context, strategies)


def _evaluate(
    spec: SweepSpec, candidate: Candidate, context: TaskContext, strategies: tuple[str, ...], began: float
) -> dict[str, Any]:
    row = empty_row(spec, candidate)
    row["Ci_mean_free_space"] = context.free.get("Ci_mean")
    if context.q_ref is None:
        row["failure"] = context.failure
        row["wall_s"] = time.perf_counter() - began
        return row

    def build() -> tuple[Array, Scenario]:
        point = candidate_point(spec, candidate, context)
        sc = candidate_scenario(spec, candidate, context, point)
        return point, sc if sc.strategies == strategies else dataclasses.replace(sc, strategies=strategies)

    return judged_run(spec, row, began, context, build)


def with_free_space(spec: SweepSpec, candidate: Candidate, row: dict[str, Any], context: TaskContext) -> dict[str, Any]:
    """The row of a candidate run from its reference context, with the free-space columns of the whole `context`.

    ``Ci_mean_free_space`` and ``Ci_reduction_gp`` (1 − C_i,gp / C_i,free, means in m/N) as
    :func:`evaluate_candidate` gives them from the whole context; when the free-space run failed, the row of a
    candidate whose context failed (not run; the context's failure), as then. A new dict; ``wall_s`` kept.
    """
    if context.q_ref is None:
        out = empty_row(spec, candidate)
        out["Ci_mean_free_space"] = context.free.get("Ci_mean")
        out["failure"] = context.failure
        out["wall_s"] = row.get("wall_s")
        return out
    out = dict(row)
    free, gp = context.free.get("Ci_mean"), out.get("Ci_mean_gp")
    out["Ci_mean_free_space"] = free
    if finite(free) and finite(gp):
        out["Ci_reduction_gp"] = 1.0 - gp / free
    return out


def judged_run(
    spec: SweepSpec,
    row: dict[str, Any],
    began: float,
    context: TaskContext,
    build: Callable[[], tuple[Array, Scenario]],
) -> dict[str, Any]:
    """`row` completed by the whole-task run of the scenario `build` gives (with its brace point, m, world).

    The run's result columns, its warnings and wall time; a numerical failure (of building the scenario or of the
    run) goes into ``failure``, never raised. The sweep's candidates and the placement's places both end here.
    """
    from bracekit.simulation.run import run_scenario

    try:
        point, sc = build()
        row["point_x"], row["point_y"], row["point_z"] = (float(x) for x in point)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            result = run_scenario(sc, both_models=False)
    except (BracekitError, ArithmeticError, np.linalg.LinAlgError) as exc:  # numerical failures: in the row
        row["failure"] = f"{type(exc).__name__}: {exc}"
        row["wall_s"] = time.perf_counter() - began
        return row
    row |= summary_columns(spec, result.summary["strategies"], context)
    row["warnings"] = len(caught)
    row["wall_s"] = time.perf_counter() - began
    return row


def summary_columns(spec: SweepSpec, strategies: dict[str, dict[str, Any]], context: TaskContext) -> dict[str, Any]:
    """The result columns from run_scenario's per-strategy summary (minimum norm's None when it did not run)."""
    gp = strategies["braced_gradient_projection"]
    mn = strategies.get("braced_min_norm", dict.fromkeys(("Ci_mean", "k_mean", "completed", "failure")))
    free = context.free.get("Ci_mean")
    out: dict[str, Any] = {
        "Ci_mean_min_norm": _num(mn["Ci_mean"]),
        "Ci_mean_gp": _num(gp["Ci_mean"]),
        "Ci_reduction_gp": None if not finite(free) or not finite(gp["Ci_mean"]) else 1.0 - gp["Ci_mean"] / free,
        "k_mean_min_norm": _num(mn["k_mean"]),
        "k_mean_gp": _num(gp["k_mean"]),
        "min_link_clearance_m": _num(gp["min_link_clearance_m"]),
        "max_joint_limit_violation_rad": _num(gp["max_joint_limit_violation_rad"]),
        "max_region_radius_m": _num(gp["max_region_radius_m"]),
        "min_liftoff_margin": _num(gp.get("min_liftoff_margin")),
        "min_slip_margin": _num(gp.get("min_slip_margin")),
        "min_torque_margin": _num(gp.get("min_torque_margin")),
        "completed_min_norm": None if mn["completed"] is None else bool(mn["completed"]),
        "failure_min_norm": mn["failure"],
        "holds": gp.get("holds"),
        "unstable_samples": gp.get("unstable_samples"),
        "completed": bool(gp["completed"]),
        "valid": gp.get("valid"),
        "invalid_reasons": "; ".join(gp.get("invalid_reasons") or ()) or None,
    }
    if not gp["completed"]:
        out["feasible"] = False
        out["failure"] = f"braced_gradient_projection did not complete: {gp['failure']}"
        return out
    return judge(spec, out)
