"""The inputs of the validation checks: load directions, MuJoCo settings, scenarios and their configurations.

Default loads (:data:`DEFAULT_DIRECTIONS`, world axes), the configurations of a scenario's braced path
(:func:`validation_configurations`; one brace or several) and the checks of numbers and counts shared by the
checks. Units: N, N·m, m, rad.
"""

from __future__ import annotations

import math
import os
import warnings
from collections.abc import Sequence
from dataclasses import replace
from typing import Any, Literal, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from bracekit._linalg import as_array, show
from bracekit.errors import (
    BracekitError,
    ContactError,
    InputError,
    NumericalError,
    RegionWarning,
)
from bracekit.simulation.run import run_scenario
from bracekit.simulation.scenario import load_scenario
from bracekit.simulation.scenario_model import Scenario
from bracekit.simulation.simulate import Trajectory, simulate, solve_start
from bracekit.validate.contacts import plane_contacts

__all__ = [
    "DEFAULT_DIRECTIONS",
    "FORCE_DIRECTIONS",
    "MODELS",
    "MUJOCO_SETTINGS",
    "path_samples",
    "validation_configurations",
]

Array = NDArray[np.float64]
ModelName = Literal["constrained", "projection", "free_space"]

#: The first-order models compared, in report order.
MODELS: tuple[ModelName, ...] = ("constrained", "projection", "free_space")

_S3 = 1.0 / np.sqrt(3.0)
_S2 = 1.0 / np.sqrt(2.0)
#: Default load directions [f̂; m̂] (world axes): each non-zero part is scaled to ``force`` N / ``moment`` N·m.
DEFAULT_DIRECTIONS: tuple[tuple[str, tuple[float, ...]], ...] = (
    ("force +x", (1.0, 0.0, 0.0, 0.0, 0.0, 0.0)),
    ("force -x", (-1.0, 0.0, 0.0, 0.0, 0.0, 0.0)),
    ("force +y", (0.0, 1.0, 0.0, 0.0, 0.0, 0.0)),
    ("force -y", (0.0, -1.0, 0.0, 0.0, 0.0, 0.0)),
    ("force +z", (0.0, 0.0, 1.0, 0.0, 0.0, 0.0)),
    ("force -z", (0.0, 0.0, -1.0, 0.0, 0.0, 0.0)),
    ("force (1,1,-1)/√3", (_S3, _S3, -_S3, 0.0, 0.0, 0.0)),
    ("force (-1,1,-1)/√3", (-_S3, _S3, -_S3, 0.0, 0.0, 0.0)),
    ("moment +x", (0.0, 0.0, 0.0, 1.0, 0.0, 0.0)),
    ("moment (0,1,1)/√2", (0.0, 0.0, 0.0, 0.0, _S2, _S2)),
)
#: The pure-force directions of :data:`DEFAULT_DIRECTIONS` (used by :func:`preload_study`).
FORCE_DIRECTIONS = tuple(d for d in DEFAULT_DIRECTIONS if not any(d[1][3:]))

#: MuJoCo timesteps (s) tried in turn until the chain settles (None: the default, min(1 ms, τ/20)): several
#: stiff contacts can keep bouncing in a limit cycle at one timestep and settle at another.
_TIMESTEPS: tuple[float | None, ...] = (None, 5e-4, 2.5e-4)

#: MuJoCo settings used by the validation (recorded in the report).
MUJOCO_SETTINGS: dict[str, Any] = {
    "contact": "frictionless sphere on a plane, condim 1, solref '0.002 1', solimp '0.9999 0.9999 0.001'",
    "sphere_radius_m": 1e-4,
    "integrator": "implicitfast, Newton solver, timestep <= 1 ms, joint damping tau*k_i (heaviest mode critical)",
    "settle_tol_rad": 1e-11,
    "gravity": False,
}


# --------------------------------------------------------------------------------------------------
# Inputs
# --------------------------------------------------------------------------------------------------
def _scenario(scenario: Scenario | str | os.PathLike[str]) -> Scenario:
    if not isinstance(scenario, Scenario | str | os.PathLike):
        raise InputError(f"scenario must be a Scenario, a .toml path or a shipped name, got {type(scenario).__name__}")
    sc = scenario if isinstance(scenario, Scenario) else load_scenario(scenario)
    plane_contacts(sc.braced)  # every brace of a contact type MuJoCo and the static solve model
    return sc


def _positive(value: float, name: str, unit: str, *, zero_ok: bool = False) -> float:
    ok = isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(_as_float(value))
    if not ok or value < 0 or (value == 0 and not zero_ok):
        want = ">= 0" if zero_ok else "> 0"
        raise InputError(f"{name} must be a finite number {want} {unit}, got {show(value)}")
    return float(value)


def _as_float(value: float) -> float:
    try:
        return float(value)
    except OverflowError:  # an int beyond float64
        return math.inf


def _count(n: object, name: str) -> int:
    if isinstance(n, bool) or not isinstance(n, int | np.integer) or int(n) < 1:
        raise InputError(f"{name} must be a whole number >= 1, got {show(n)}")
    return int(n)


def _directions(directions: Sequence[tuple[str, ArrayLike]] | Sequence[ArrayLike]) -> list[tuple[str, Array]]:
    """Normalise load directions to (label, [f̂; m̂]) with unit (or zero) force and moment parts."""
    out = []
    if len(directions) == 0:
        raise InputError("directions must hold at least one load direction [fx, fy, fz, mx, my, mz]")
    for i, item in enumerate(directions):
        if isinstance(item, tuple) and len(item) == 2 and isinstance(item[0], str):
            label, vec = item[0], item[1]
        else:
            label, vec = f"direction {i}", item
        v = as_array(vec, f"load direction '{label}'", finite=False).reshape(-1)
        if v.size != 6 or not np.all(np.isfinite(v)):
            raise InputError(f"load direction '{label}' must be 6 finite numbers [fx, fy, fz, mx, my, mz]")
        nf, nm = np.linalg.norm(v[:3]), np.linalg.norm(v[3:])
        if nf == 0.0 and nm == 0.0:
            raise InputError(f"load direction '{label}' is zero")
        out.append((label, np.concatenate([v[:3] / nf if nf else v[:3], v[3:] / nm if nm else v[3:]])))
    return out


class TipLoads(NamedTuple):
    """The loads of a deflection check: each unit direction [f̂; m̂] (world axes) scaled to ``force`` / ``moment``."""

    force: float  # N
    moment: float  # N·m
    labelled: list[tuple[str, Array]]  # (label, [f̂; m̂])

    @property
    def scale(self) -> Array:
        """[force ×3, moment ×3]: a direction times it is the tip wrench w = [f; m] (N, N·m)."""
        return np.array([self.force] * 3 + [self.moment] * 3)

    def directions_json(self) -> list[dict[str, Any]]:
        """The directions as the reports' settings list them."""
        return [{"label": lab, "direction": d.tolist()} for lab, d in self.labelled]


def _tip_loads(
    force: float, moment: float, directions: Sequence[tuple[str, ArrayLike]] | Sequence[ArrayLike]
) -> TipLoads:
    """Check the load magnitudes (> 0) and normalise the directions (InputError naming the bad one)."""
    return TipLoads(_positive(force, "force", "N"), _positive(moment, "moment", "N·m"), _directions(directions))


def path_samples(scenario: Scenario) -> int:
    """Samples of a scenario's path (steps + 1): the most configurations :func:`validation_configurations` gives."""
    return max(1, round(scenario.task.duration / scenario.dt)) + 1


def validation_configurations(scenario: Scenario | str | os.PathLike[str], n: int) -> list[Array]:
    """N braced configurations (each (n_joints,), rad) of a scenario, contact closed at every one.

    The first is the solved start configuration; the others are evenly spaced samples (in time) of the
    braced minimum-norm run along the task, ``k·N/n`` for k = 0..n−1 of the N samples (the task's end,
    which repeats the start of a closed circle, is not taken). Raises InputError for n < 1 or n beyond the
    path's samples (:func:`path_samples`), NumericalError when the run ends early and ConvergenceError when
    the start cannot be solved.
    """
    n = _count(n, "the number of configurations")
    sc = _scenario(scenario)
    most = path_samples(sc)
    if n > most:
        raise InputError(
            f"asked for {n} configurations, but the path of scenario '{sc.name}' has {most} samples "
            f"(task {sc.task.duration:g} s, dt {sc.dt:g} s); ask for at most {most}"
        )
    try:
        start = solve_start(
            sc.braced, sc.task.position(0.0), sc.guess, rotation=sc.task.rotation, theta_weight=sc.start_theta_weight
        )
    except ContactError:  # no start near the guess: take the configurations of the scenario's own run
        return _run_configurations(sc, n)
    if n == 1:
        return [start.q.copy()]
    with warnings.catch_warnings():  # leaving the bracing region does not matter for a static check
        warnings.simplefilter("ignore", RegionWarning)
        tr = simulate(
            sc.braced,
            sc.strategy("braced_min_norm"),
            sc.task,
            start.q,
            sc.dt,
            sc.beta_x,
            feedback_gain=sc.feedback_gain,
        )
    return _samples(tr, n)


def _samples(tr: Trajectory, n: int) -> list[Array]:
    """The samples k·N/n (k = 0..n−1) of a run's N configurations; NumericalError if it has fewer than n."""
    samples = tr.q.shape[0]
    if samples < n:
        raise NumericalError(
            f"the braced minimum-norm run gave {samples} samples, fewer than the {n} configurations asked for"
            + (f" ({tr.failure})" if tr.failure else "")
        )
    idx = (np.arange(n) * samples) // n
    return [tr.q[i].copy() for i in idx]


def _run_configurations(sc: Scenario, n: int) -> list[Array]:
    """N samples ``k·N/n`` of the scenario's braced minimum-norm run (:func:`run_scenario`, any brace count)."""
    result = run_scenario(replace(sc, strategies=("braced_min_norm",)), both_models=False)
    tr = result.trajectories[result.compliance_model]["braced_min_norm"]
    return _samples(tr, n)


def _configurations(sc: Scenario, configs: int | Sequence[ArrayLike]) -> list[Array]:
    """`configs` as a list of configurations: a count (:func:`validation_configurations`) or the list itself."""
    if isinstance(configs, int | np.integer) and not isinstance(configs, bool):
        return validation_configurations(sc, _count(configs, "configs"))
    if isinstance(configs, bool) or isinstance(configs, str) or not isinstance(configs, Sequence | np.ndarray):
        raise InputError(f"configs must be a whole number >= 1 or a list of configurations, got {show(configs)}")
    if len(configs) == 0:
        raise InputError("configs must hold at least one configuration")
    try:
        return [sc.robot.check_q(q) for q in configs]
    except (BracekitError, ValueError, TypeError) as exc:
        raise InputError(f"bad configuration in configs: {exc}") from exc
