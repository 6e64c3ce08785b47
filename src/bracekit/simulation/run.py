"""The paper's experiment: every strategy of a scenario along its task, with the Table I metrics."""

from __future__ import annotations

import copy
import os
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from bracekit._linalg import show
from bracekit.compliance.first_order import check_model
from bracekit.compliance.measures import theta_z
from bracekit.compliance.preloaded import check_run_model, simulated_model
from bracekit.errors import HoldingWarning, InputError, NoRedundancyWarning, PadAxisWarning
from bracekit.kinematics import BracedState
from bracekit.kinematics.clearance import geometry_of
from bracekit.resolution.strategies import GRADIENT_MODES, GradientMode
from bracekit.simulation.holding import (
    holding_measures,
    holding_summary,
    holding_warnings,
    per_brace_summary,
    relief_summary,
)
from bracekit.simulation.loop import simulate
from bracekit.simulation.samples import compliance_models
from bracekit.simulation.scenario import load_scenario
from bracekit.simulation.scenario_model import OPTIMISING, Scenario
from bracekit.simulation.start import solve_start
from bracekit.simulation.trajectory import Trajectory
from bracekit.simulation.validity import verdict
from bracekit.statics import effort_limits

Array = NDArray[np.float64]


@dataclass
class RunResult:
    """All runs of a scenario. ``summary`` is what ``summary.json`` holds (chosen compliance model).

    ``trajectories[model][strategy]``: the runs under each compliance model (the minimum-norm runs do
    not depend on the model and are shared). ``summaries[model]`` the Table I metrics of each.
    """

    scenario: Scenario
    start: BracedState
    compliance_model: str
    gradient: GradientMode
    trajectories: dict[str, dict[str, Trajectory]]
    summaries: dict[str, dict[str, Any]] = field(default_factory=dict)
    start_warnings: list[str] = field(default_factory=list)

    @property
    def summary(self) -> dict[str, Any]:
        """{"strategies": {name: metrics}, ...} for the chosen compliance model."""
        return self.summaries[self.compliance_model]

    @property
    def completed(self) -> bool:
        """Whether every run finished its task."""
        return all(t.completed for runs in self.trajectories.values() for t in runs.values())

    @property
    def valid(self) -> bool:
        """Whether every run of every model is valid (:mod:`bracekit.simulation.validity`)."""
        return all(s["valid"] for out in self.summaries.values() for s in out["strategies"].values())


def _summaries(result: RunResult) -> None:
    sc = result.scenario
    reliefs: dict[int, dict[str, Any]] = {}  # a run shared by both models (not optimising) gets its LPs once
    for model, runs in result.trajectories.items():
        strategies = {name: tr.summary(model) for name, tr in runs.items()}
        for name, tr in runs.items():
            strategies[name].update(holding_summary(tr.measures))
            if tr.braces is not None and "liftoff_margin_0" in tr.measures:  # each brace's own margins
                extra = per_brace_summary(tr.measures, len(tr.braces))
                strategies[name]["braces"] = [b | e for b, e in zip(strategies[name]["braces"], extra, strict=True)]
            if sc.holding.active and tr.braced and tr.q.shape[0] and _has_limits(sc):
                if id(tr) not in reliefs:
                    reliefs[id(tr)] = relief_summary(sc.braced, tr.q, sc.holding)
                strategies[name]["actuator_relief"] = copy.deepcopy(reliefs[id(tr)])
            strategies[name].update(verdict(sc.braced, tr, strategies[name])._asdict())
        out: dict[str, Any] = {
            "scenario": result.scenario.name,
            "compliance_model": model,
            "gradient": result.gradient,
            "units": "SI: C_i in m/N, lengths in m, angles in rad",
            "geometry": geometry_of(sc.braced),  # what the link clearance is computed from
            "strategies": strategies,
        }
        free = strategies.get("free_space_min_norm")
        if free is not None:
            out["Ci_mean_reduction_vs_free_space"] = {
                name: None if s["Ci_mean"] is None or free["Ci_mean"] is None else 1.0 - s["Ci_mean"] / free["Ci_mean"]
                for name, s in strategies.items()
                if name != "free_space_min_norm"
            }
        out["warnings"] = result.start_warnings + [w for tr in runs.values() for w in tr.warnings]
        result.summaries[model] = out


def _start_warnings(sc: Scenario, start: BracedState) -> list[str]:
    """Warnings about the solved start: a pad axis that points away from its surface (θ_z > π/2)."""
    lines = []
    braces = sc.braced.braces
    for i, (brace, contact) in enumerate(zip(braces, start.contacts, strict=True)):
        angle = theta_z(brace.surface.normal, contact.z_b)
        if not brace.pad_axis or angle <= 0.5 * np.pi:
            continue
        which = "{b}" if len(braces) == 1 else f"{{b_{i}}} (braces[{i}])"
        lines.append(
            f"θ_z at the start is {angle:.3f} rad (> π/2): the pad axis of {which} points away from the surface; "
            "z_b (a frame's z, or '[brace] pad_axis') must point from the pad into the robot, along the normal; "
            "flip its sign"
        )
        warnings.warn(lines[-1], PadAxisWarning, stacklevel=3)
    return lines


#: Largest joint difference (rad or m) at which a gradient-projection path counts as minimum norm's own
#: (its null-space motion negligible).
SAME_PATH_TOL = 1e-6


def _same_path_note(runs: dict[str, Trajectory]) -> None:
    """Note a redundant gradient-projection run whose path is braced minimum norm's (∇g ⟂ the null space).

    With a null space (redundancy > 0) gradient projection moves in it unless ∇g is orthogonal to it all along
    the run: then no weighted term changes along the redundant motion (e.g. the tool's spin about its own axis
    in 'position+axis'), and the run says so rather than repeat minimum norm silently.
    """
    gp, mn = runs.get("braced_gradient_projection"), runs.get("braced_min_norm")
    if gp is None or mn is None or not gp.redundancy or gp.q.shape != mn.q.shape:
        return
    gap = float(np.max(np.abs(gp.q - mn.q))) if gp.q.size else 0.0
    if gap > SAME_PATH_TOL:
        return
    line = (
        f"braced_gradient_projection: its path is braced minimum norm's (max |Δq| {gap:.1e} rad) although the "
        f"{gp.task_space} task leaves {gp.redundancy} redundant motion(s): ∇g has (almost) no component along "
        "them all along the run (no weighted term changes along the redundant motion); weight a term that does, "
        "or choose a task space that frees another motion"
    )
    gp.warnings.append(line)
    warnings.warn(line, NoRedundancyWarning, stacklevel=3)


def _has_limits(sc: Scenario) -> bool:
    """Whether any joint of the scenario's robot has an effort limit (needed for torque ratios)."""
    return bool(np.any(np.isfinite(effort_limits(sc.robot))))


def _add_holding(sc: Scenario, tr: Trajectory) -> None:
    """The statics measures of a run's samples (:mod:`bracekit.simulation.holding`) into its measures."""
    if sc.holding.active and tr.q.shape[0]:
        beta = np.array([sc.beta_x(float(t)) for t in tr.t])
        tr.measures.update(holding_measures(sc.braced, tr.q, sc.holding, tr.braced, beta))
        for line in holding_warnings(tr.strategy, tr.t, tr.measures):
            tr.warnings.append(line)
            warnings.warn(line, HoldingWarning, stacklevel=3)


def run_scenario(
    scenario: Scenario | str | os.PathLike[str],
    gradient: GradientMode | None = None,
    compliance_model: str | None = None,
    *,
    both_models: bool = True,
    progress: Callable[[int], None] | None = None,
) -> RunResult:
    """Solve the start configuration and run every strategy of the scenario along its task.

    Args:
        scenario: a Scenario, a TOML path (a str or an os.PathLike) or a shipped name ('paper').
        gradient: 'analytic' (default of the scenario) or 'finite-difference' (the paper's).
        compliance_model: 'constrained', 'projection' or 'preloaded' (the constrained runs with C_i of the
            preloaded compliance: needs gravity or a preload); the model of ``summary``.
        both_models: also run gradient projection under the other compliance model (for Table I).
        progress: called with the number of steps done, for a progress bar.
    """
    if isinstance(scenario, Scenario):
        sc = scenario
    elif isinstance(scenario, str | os.PathLike):
        sc = load_scenario(scenario)
    else:
        raise InputError(f"scenario must be a Scenario, a .toml path or a shipped name, got {show(scenario)}")
    grad = sc.gradient if gradient is None else gradient
    if not isinstance(grad, str) or grad not in GRADIENT_MODES:
        raise InputError(f"unknown gradient mode {show(grad)}; choose one of {', '.join(GRADIENT_MODES)}")
    model = check_run_model(sc.compliance_model if compliance_model is None else compliance_model)
    count = len(sc.braced.braces)
    if model not in (*compliance_models(sc.braced), "preloaded"):
        raise InputError(
            f"the compliance model {show(model)} is defined for one brace (it needs the chain split at {{b}}); with "
            "several braces use 'constrained' or 'preloaded'"
        )
    if model == "preloaded" and not (sc.holding.gravity or max(sc.holding.brace_preloads(count)) > 0.0):
        raise InputError(
            "the preloaded compliance model needs gravity or a preload ('[robot] gravity = true' or "
            "'[brace] preload' > 0); without them it is the constrained model"
        )
    if not isinstance(both_models, bool):
        raise InputError(f"both_models must be True or False, got {show(both_models)}")
    if progress is not None and not callable(progress):
        raise InputError(f"progress must be a function of the number of steps done, got {show(progress)}")
    start = solve_start(
        sc.braced,
        sc.task.position(0.0),
        sc.guess,
        rotation=sc.task.rotation,
        theta_weight=sc.start_theta_weight,
        space=sc.task_space,
    )
    start_warnings = _start_warnings(sc, start)
    models = compliance_models(sc.braced) if both_models else (simulated_model(model),)
    shared: dict[str, Trajectory] = {}
    trajectories: dict[str, dict[str, Trajectory]] = {m: {} for m in models}
    for m in models:
        for name in sc.strategies:
            if name not in OPTIMISING and name in shared:
                trajectories[m][name] = shared[name]
                continue
            strategy = sc.strategy(name, gradient=grad, model=check_model(m))
            tr = simulate(
                sc.braced,
                strategy,
                sc.task,
                start.q,
                sc.dt,
                sc.beta_x,
                feedback_gain=sc.feedback_gain,
                progress=progress,
            )
            _add_holding(sc, tr)
            trajectories[m][name] = tr
            if name not in OPTIMISING:
                shared[name] = tr
    for runs in trajectories.values():
        _same_path_note(runs)
    if model == "preloaded":  # the same runs as the constrained model, C_i of the preloaded compliance
        trajectories["preloaded"] = trajectories["constrained"]
    result = RunResult(sc, start, model, grad, trajectories, start_warnings=start_warnings)
    _summaries(result)
    return result


def total_steps(scenario: Scenario, both_models: bool = True) -> int:
    """Steps a run_scenario call takes (for a progress bar)."""
    per = max(1, round(scenario.task.duration / scenario.dt))
    n_gp = sum(s in OPTIMISING for s in scenario.strategies) * (2 if both_models else 1)
    return per * (len([s for s in scenario.strategies if s not in OPTIMISING]) + n_gp)
