"""Physical validation of the first-order compliance models (``bracekit validate``): orchestration only.

For a few configurations of a scenario's braced path and a set of small tip wrenches w, the tip deflection
predicted by each first-order model, Δx_pred = C w, is compared with two independent references:

* MuJoCo (:func:`~bracekit.validate.mujoco_check.mujoco_static_deflection`): spring-jointed chain, unilateral
  frictionless sphere contact, the contact preloaded with a force P, settled quasi-statically;
* the nonlinear static equilibrium (:func:`~bracekit.validate.statics.solve_static_equilibrium`) with the
  same preload and a unilateral contact (``bilateral=False``).

Models: ``constrained`` (C_e with the Lagrange-multiplier C̃1), ``projection`` (C_e with the paper's
(I − P) C1 (I − P)) and ``free_space`` (J K⁻¹ Jᵀ, the unbraced robot).

Error measure. Δx = [Δp; Δθ] mixes metres and radians, so both deflections are compared in the weighted
norm ‖Δx‖_L = ‖[Δp; L·Δθ]‖ (m), L = ‖e − b‖ the lever from the brace point to the tip at the configuration
(a rotation of the tip by Δθ about the brace moves the tip by about L·Δθ). The relative error is
‖Δx_pred − Δx_ref‖_L / ‖Δx_ref‖_L. Units: wrench [f; m] in N and N·m, deflections in m and rad, world axes.

:func:`run_preloaded_validation` compares the preloaded compliance (tangent stiffness of gravity and the
preload) and the ``constrained`` model with both references loaded about the gravity-loaded, preloaded
equilibrium; :func:`run_capacity_validation` compares bracekit's lift-off and slip scales with those MuJoCo
shows under a slow load ramp and with the nonlinear statics' scales.

A case whose contact opens under the load (either reference ends with no contact force) is reported with
status ``contact_opened`` and kept out of the error statistics: the first-order braced models assume a
closed contact. A case where MuJoCo or the static solve fails is reported with status ``failed`` and the
message, and the run goes on. Statistics are ``None`` (never NaN) when no case contributes.
"""

from __future__ import annotations

import math
import os
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from bracekit._linalg import as_array, show
from bracekit.compliance.first_order import end_effector_compliance, free_space_compliance
from bracekit.compliance.preloaded import preloaded_compliance
from bracekit.errors import (
    BracekitError,
    ContactError,
    InputError,
    MujocoValidationError,
    NumericalError,
    RedundantContactWarning,
    RegionWarning,
    StaticSolveError,
)
from bracekit.kinematics import BracedRobot, BracedState
from bracekit.kinematics.multi import MultiBracedState
from bracekit.simulation.holding import Holding
from bracekit.simulation.run import run_scenario
from bracekit.simulation.scenario import Scenario, load_scenario
from bracekit.simulation.simulate import simulate, solve_start
from bracekit.statics import capacity_along, effort_limits
from bracekit.statics.equilibrium import multi_contact_responses, wrench_list
from bracekit.validate.capacity_check import RAMP_SETTINGS, mujoco_capacity_ramp
from bracekit.validate.contacts import plane_contacts
from bracekit.validate.holding_check import (
    DEFAULT_FRACTIONS,
    FAIL_ABOVE,
    HOLD_BELOW,
    HOLDING_SETTINGS,
    mujoco_holding_check,
)
from bracekit.validate.mujoco_check import mujoco_static_deflection
from bracekit.validate.statics import solve_statics

__all__ = [
    "DEFAULT_DIRECTIONS",
    "FORCE_DIRECTIONS",
    "MODELS",
    "PRELOADED_MODELS",
    "CapacityValidationReport",
    "HoldingValidationReport",
    "PreloadedValidationReport",
    "ValidationReport",
    "check_compliance",
    "first_order_state",
    "path_samples",
    "preload_study",
    "run_capacity_validation",
    "run_holding_validation",
    "run_preloaded_validation",
    "run_validation",
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
    except ContactError:  # the one-brace start solve refuses several braces: take the scenario's own run
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
    samples = tr.q.shape[0]
    if samples < n:
        raise NumericalError(
            f"the braced minimum-norm run gave {samples} samples, fewer than the {n} configurations asked for"
            + (f" ({tr.failure})" if tr.failure else "")
        )
    idx = (np.arange(n) * samples) // n
    return [tr.q[i].copy() for i in idx]


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


# --------------------------------------------------------------------------------------------------
# One configuration
# --------------------------------------------------------------------------------------------------
def _weighted(dx: Array, length: float) -> Array:
    return np.concatenate([dx[:3], length * dx[3:]])


def _rel_err(pred: Array, ref: Array | None, length: float) -> float | None:
    """‖pred − ref‖_L / ‖ref‖_L with ‖[Δp; Δθ]‖_L = ‖[Δp; L Δθ]‖; None if there is no reference."""
    if ref is None:
        return None
    den = float(np.linalg.norm(_weighted(ref, length)))
    if not np.isfinite(den) or den <= 1e-300:
        return None
    val = float(np.linalg.norm(_weighted(pred - ref, length))) / den
    return val if np.isfinite(val) else None


@dataclass(frozen=True)
class _Config:
    """What every case at one configuration shares: the compliances of the models defined here, and L."""

    q: Array
    compliances: dict[str, Array]
    length: float


def first_order_state(braced: BracedRobot, q: ArrayLike) -> BracedState | MultiBracedState:
    """The state the first-order models take at q: the one-brace state, or the stacked state of several braces.

    The one-brace view (the paper's chain split at {b}) refuses several braces by name (ContactError); the
    stacked state carries the ``constrained`` and ``free_space`` models for any number of braces.
    """
    try:
        return braced.state(q)
    except ContactError:
        return braced.stacked_state(q)


def _config(braced: BracedRobot, q: ArrayLike, index: int) -> _Config:
    with warnings.catch_warnings():
        warnings.simplefilter("error", RedundantContactWarning)
        try:
            st = first_order_state(braced, q)
            stacked = braced.stacked_state(q)
            comp: dict[str, Array] = {}
            for model in MODELS:
                try:
                    comp[model] = (
                        free_space_compliance(st) if model == "free_space" else end_effector_compliance(st, model)
                    )
                except ContactError:  # the projection model is the paper's one-brace C̃1
                    continue
        except RedundantContactWarning as exc:
            raise InputError(
                f"configuration {index}: the braces constrain dependent motions ({exc}); give independent contacts"
            ) from exc
    for i, (brace, b) in enumerate(zip(braced.braces, stacked.b_i, strict=True)):
        gap = brace.surface.signed_distance(b)
        if abs(gap) > 1e-8:
            which = "brace point" if len(braced.braces) == 1 else f"point of brace {i}"
            raise InputError(
                f"configuration {index}: the {which} is {gap:.3e} m from the surface; give braced configurations"
            )
    length = float(min(np.linalg.norm(stacked.e - b) for b in stacked.b_i))
    return _Config(q=np.asarray(stacked.q, dtype=float), compliances=comp, length=length)


def preloaded_tip_compliance(braced: BracedRobot, q: ArrayLike, preload: float, gravity: bool) -> Array:
    """The preloaded compliance at the tip (6×6; wrench [f; m] at e → [Δp; Δθ], world axes).

    The core's one-brace :func:`~bracekit.compliance.preloaded.preloaded_compliance`; where that refuses several
    braces (ContactError), J_e δq/δw of the several-brace statics' first-order response
    (:func:`bracekit.statics.equilibrium.multi_contact_responses` with the tangent stiffness of gravity and the
    preloads P_i = ``preload``, every contact closed).
    """
    try:
        return preloaded_compliance(braced, q, preload, gravity=gravity)
    except ContactError:
        resp = multi_contact_responses(braced, q, preloads=preload, gravity=gravity, geometric=True)
        return np.asarray(braced.stacked_state(q).J_e @ resp.joint_gain[0], dtype=float)


def _references(
    braced: BracedRobot,
    q: Array,
    w: Array,
    preload: float | Sequence[float],
    max_steps: int,
    gravity: bool = False,
    *,
    mujoco: bool = True,
) -> tuple[dict[str, Any], list[str]]:
    """Static and MuJoCo deflections of one load case (the brace's k_env in both); failures go into the messages."""
    robot = braced.robot
    contacts = plane_contacts(braced, preload)  # each brace's k_env in both references
    common = (robot.model, q, robot.stiffness, robot.tip_id, contacts, w)
    out: dict[str, Any] = {"static": None, "mujoco": None}
    messages = []
    try:
        out["static"] = solve_statics(*common, bilateral=False, gravity=gravity)
    except (StaticSolveError, ValueError, np.linalg.LinAlgError) as exc:
        messages.append(f"static solve failed: {exc}")
    out["timestep"] = None
    for step in _TIMESTEPS if mujoco else ():
        try:
            out["mujoco"] = mujoco_static_deflection(
                *common, gravity=gravity, max_steps=max_steps, sphere_radius=MUJOCO_SETTINGS["sphere_radius_m"],
                timestep=step,
            )  # fmt: skip
        except (MujocoValidationError, ValueError) as exc:
            if "did not settle" in str(exc) and step != _TIMESTEPS[-1]:
                continue
            messages.append(f"MuJoCo failed: {exc}")
            break
        out["timestep"] = step  # None: the default timestep
        break
    return out, messages


def _case(
    braced: BracedRobot,
    cfg: _Config,
    index: int,
    label: str,
    w: Array,
    preload: float | Sequence[float],
    max_steps: int,
    mujoco: bool = True,
) -> dict[str, Any]:
    refs, messages = _references(braced, cfg.q, w, preload, max_steps, mujoco=mujoco)
    st, mj = refs["static"], refs["mujoco"]
    ref = {
        "static": None if st is None else np.asarray(st.deflection, dtype=float),
        "mujoco": None if mj is None else np.asarray(mj.deflection, dtype=float),
    }
    models = tuple(cfg.compliances)
    pred = {m: cfg.compliances[m] @ w for m in models}
    opened = bool((st is not None and st.contact_opened) or (mj is not None and mj.contact_opened))
    if messages:
        status = "failed"
    elif opened:
        status = "contact_opened"
        messages.append(
            "the contact opened under this load (preload too small for it): the braced first-order models "
            "assume a closed contact, so this case is not in the statistics"
        )
    else:
        status = "ok"
    return {
        "config": index,
        "label": label,
        "wrench": w.tolist(),
        "status": status,
        "message": "; ".join(messages) if messages else None,
        "length_scale_m": cfg.length,
        "deflection": {
            **{k: (None if v is None else v.tolist()) for k, v in ref.items()},
            **{m: pred[m].tolist() for m in models},
        },
        "rel_err": {m: {k: _rel_err(pred[m], ref[k], cfg.length) for k in ("mujoco", "static")} for m in models},
        "rel_err_mujoco_vs_static": (
            _rel_err(ref["mujoco"], ref["static"], cfg.length) if ref["mujoco"] is not None else None
        ),
        "contact_force_static": None if st is None else float(st.contact_force),
        "contact_force_mujoco": None if mj is None else float(mj.contact_force),
        "opened": opened,
        "opened_static": None if st is None else bool(st.contact_opened),
        "opened_mujoco": None if mj is None else bool(mj.contact_opened),
        "mujoco_steps": None if mj is None else int(mj.steps),
        "contact_forces_static": None if st is None else st.contact_forces.tolist(),
        "contact_forces_mujoco": None if mj is None else mj.contact_forces.tolist(),
        "mujoco_timestep_s": refs["timestep"],
    }


def _failed_config(index: int, labelled: list[tuple[str, Array]], scale: Array, exc: Exception) -> list[dict]:
    return [
        {
            "config": index,
            "label": label,
            "wrench": (d * scale).tolist(),
            "status": "failed",
            "message": f"configuration {index}: {exc}",
            "length_scale_m": None,
            "deflection": {k: None for k in ("mujoco", "static", *MODELS)},
            "rel_err": {m: {"mujoco": None, "static": None} for m in MODELS},
            "rel_err_mujoco_vs_static": None,
            "contact_force_static": None,
            "contact_force_mujoco": None,
            "opened": False,
            "opened_static": None,
            "opened_mujoco": None,
            "mujoco_steps": None,
            "contact_forces_static": None,
            "contact_forces_mujoco": None,
            "mujoco_timestep_s": None,
        }
        for label, d in labelled
    ]


# --------------------------------------------------------------------------------------------------
# Report
# --------------------------------------------------------------------------------------------------
def _stats(values: list[float | None]) -> tuple[float | None, float | None]:
    v = [x for x in values if x is not None and np.isfinite(x)]
    if not v:
        return None, None
    return float(np.median(v)), float(np.max(v))


def _model_stats(ok: list[dict[str, Any]], model: str) -> dict[str, float | int | None]:
    """Median and max relative error of `model` vs MuJoCo and vs the static solve over the cases `ok`."""
    ok = [c for c in ok if model in c["rel_err"]]
    med_m, max_m = _stats([c["rel_err"][model]["mujoco"] for c in ok])
    med_s, max_s = _stats([c["rel_err"][model]["static"] for c in ok])
    return {
        "median_rel_err_mujoco": med_m,
        "max_rel_err_mujoco": max_m,
        "median_rel_err_static": med_s,
        "max_rel_err_static": max_s,
        "n_cases": len(ok),
    }


def _references_agree(cases: list[dict[str, Any]]) -> dict[str, float | int | None]:
    """Agreement of MuJoCo and the static solve on every case where both ran."""
    vals = [c["rel_err_mujoco_vs_static"] for c in cases if c["rel_err_mujoco_vs_static"] is not None]
    med, mx = _stats(vals)
    return {"median_rel_err": med, "max_rel_err": mx, "n_cases": len(vals)}


def _status_counts(cases: list[dict[str, Any]]) -> dict[str, int]:
    """Number of cases per status (ok, contact_opened, failed)."""
    return {s: sum(c["status"] == s for c in cases) for s in ("ok", "contact_opened", "failed")}


def fmt_rel(x: float | None) -> str:
    """A relative error as a percentage (3 significant digits), 'n/a' when missing."""
    return "n/a" if x is None else f"{100.0 * x:.3g} %"


@dataclass
class ValidationReport:
    """Result of :func:`run_validation`.

    ``cases``: one JSON-able dict per (configuration, load): ``config`` (index), ``label``, ``wrench`` [f; m]
    (N, N·m, world), ``status`` (``ok`` | ``contact_opened`` | ``failed``), ``message``, ``length_scale_m`` L,
    ``deflection`` {mujoco, static, constrained, projection, free_space} → [Δp; Δθ] (m, rad) or None,
    ``rel_err`` {model: {mujoco, static}}, ``rel_err_mujoco_vs_static``, ``contact_force_static`` /
    ``contact_force_mujoco`` (N), ``opened`` (+ per reference), ``mujoco_steps``.
    """

    scenario: str
    configurations: list[list[float]]
    settings: dict[str, Any]
    cases: list[dict[str, Any]] = field(default_factory=list)
    models: tuple[str, ...] = MODELS

    def _ok(self) -> list[dict[str, Any]]:
        return [c for c in self.cases if c["status"] == "ok"]

    def model_stats(self, model: str) -> dict[str, float | int | None]:
        """Median and max relative error of a model vs MuJoCo and vs the static solve (closed-contact cases)."""
        return _model_stats(self._ok(), model)

    def mujoco_vs_static(self) -> dict[str, float | int | None]:
        """Agreement of the two references on every case where both ran (opened contacts included)."""
        return _references_agree(self.cases)

    def counts(self) -> dict[str, int]:
        """Number of cases per status."""
        return _status_counts(self.cases)

    def summary(self) -> dict[str, Any]:
        """{median, max, n} of the constrained model vs the static solve and MuJoCo, and of the references; counts."""
        st, ms = self.model_stats("constrained"), self.mujoco_vs_static()
        return {
            "constrained_vs_static": {
                "median": st["median_rel_err_static"], "max": st["max_rel_err_static"], "n": st["n_cases"]
            },
            "constrained_vs_mujoco": {
                "median": st["median_rel_err_mujoco"], "max": st["max_rel_err_mujoco"], "n": st["n_cases"]
            },
            "mujoco_vs_static": {"median": ms["median_rel_err"], "max": ms["max_rel_err"], "n": ms["n_cases"]},
            "n_ok": self.counts()["ok"],
            "n_opened": self.counts()["contact_opened"],
            "n_failed": self.counts()["failed"],
        }  # fmt: skip

    def to_json(self) -> dict[str, Any]:
        """One JSON-serialisable dict (no NaN: missing numbers are None)."""
        return {
            "scenario": self.scenario,
            "error_measure": (
                "relative error ||dx_pred - dx_ref||_L / ||dx_ref||_L with ||[dp; dtheta]||_L = ||[dp; L*dtheta]||, "
                "L = |e - b| (m) at the configuration; statistics over the cases whose contact stays closed"
            ),
            "counts": self.counts(),
            **{m: self.model_stats(m) for m in self.models},
            "mujoco_vs_static": self.mujoco_vs_static(),
            "summary": self.summary(),
            "n_ok": self.counts()["ok"],
            "n_opened": self.counts()["contact_opened"],
            "n_failed": self.counts()["failed"],
            "settings": self.settings,
            "configurations": self.configurations,
            "cases": self.cases,
        }

    def table_text(self) -> str:
        """Aligned text table: median and max relative error of each model vs MuJoCo and vs the static solve."""
        cnt = self.counts()
        s = self.settings
        head = [
            f"Validation of the first-order compliance models, scenario '{self.scenario}'",
            f"{len(self.configurations)} configuration(s), {len(self.cases)} load case(s): {cnt['ok']} compared, "
            f"{cnt['contact_opened']} with the contact opened, {cnt['failed']} failed",
            f"loads: |f| = {s['force_N']:g} N, |m| = {s['moment_Nm']:g} N·m; contact preload P = {s['preload_N']:g} N",
            "relative error ‖Δx_pred − Δx_ref‖ / ‖Δx_ref‖ with Δx = [Δp; L·Δθ], L = ‖e − b‖ (m)",
            "",
        ]
        cols = ("model", "median vs MuJoCo", "max vs MuJoCo", "median vs static", "max vs static")
        keys = ("median_rel_err_mujoco", "max_rel_err_mujoco", "median_rel_err_static", "max_rel_err_static")
        rows = [(m, *(fmt_rel(self.model_stats(m)[k]) for k in keys)) for m in self.models]
        widths = [max(len(r[i]) for r in (cols, *rows)) for i in range(len(cols))]
        line = "  ".join(c.ljust(widths[0]) if i == 0 else c.rjust(widths[i]) for i, c in enumerate(cols))
        body = ["  ".join(c.ljust(widths[0]) if i == 0 else c.rjust(widths[i]) for i, c in enumerate(r)) for r in rows]
        fails = [f"  config {c['config']}, {c['label']}: {c['message']}" for c in self.cases if c["status"] == "failed"]
        ms = self.mujoco_vs_static()
        agree = (
            f"MuJoCo vs static solve ({ms['n_cases']} cases where both ran): median {fmt_rel(ms['median_rel_err'])}, "
            f"max {fmt_rel(ms['max_rel_err'])}"
        )
        tail = ["", "failed cases:", *fails] if fails else []
        return "\n".join([*head, line, "-" * len(line), *body, "", agree, *tail])


def run_validation(
    scenario: Scenario | str | os.PathLike[str],
    configs: int | Sequence[ArrayLike] = 3,
    *,
    force: float = 0.5,
    moment: float = 0.05,
    preload: float = 1.0,
    directions: Sequence[tuple[str, ArrayLike]] | Sequence[ArrayLike] = DEFAULT_DIRECTIONS,
    max_steps: int = 100_000,
    progress: Callable[[int], None] | None = None,
) -> ValidationReport:
    """Compare the first-order compliance models of a scenario with MuJoCo and the nonlinear static solve.

    :func:`check_compliance` at the scenario's configurations (one brace or several).

    Args:
        scenario: a Scenario, a shipped name ('paper') or a TOML path; contact types MuJoCo models.
        configs: number of configurations (:func:`validation_configurations`) or the configurations
            themselves (each (n,), rad, brace points on their surfaces).
        force: magnitude of the force part of each load, N (> 0).
        moment: magnitude of the moment part, N·m (> 0).
        preload: contact force P of every brace before loading, N (≥ 0).
        directions: load directions, (label, [f̂; m̂]) pairs or bare 6-vectors (world axes).
        max_steps: MuJoCo step budget per case.
        progress: called with 1 after each case (for a progress bar).

    Raises:
        InputError: bad scenario, configs, loads or directions.
    """
    sc = _scenario(scenario)
    return check_compliance(
        sc.braced, _configurations(sc, configs), name=sc.name, force=force, moment=moment, preload=preload,
        directions=directions, max_steps=max_steps, progress=progress,
    )  # fmt: skip


def check_compliance(
    braced: BracedRobot,
    configs: Sequence[ArrayLike],
    *,
    name: str = "",
    force: float = 0.5,
    moment: float = 0.05,
    preload: float | Sequence[float] = 1.0,
    directions: Sequence[tuple[str, ArrayLike]] | Sequence[ArrayLike] = DEFAULT_DIRECTIONS,
    max_steps: int = 100_000,
    mujoco: bool = True,
    progress: Callable[[int], None] | None = None,
) -> ValidationReport:
    """Compare the first-order compliance models of ``braced`` with MuJoCo and the nonlinear static solve.

    For N ≥ 1 braces: the ``constrained`` C_e (stacked over the braces), the paper's ``projection`` model where
    it is defined (one brace) and ``free_space``, against the unilateral static solve and MuJoCo with every
    brace preloaded by P_i (each brace's k_env in both references). L = min_i ‖e − b_i‖.

    Args:
        braced: the braced robot (each brace of a contact type MuJoCo models).
        configs: the configurations (each (n,), rad, every b_i on its surface within 1e-8 m).
        name: the scenario's name, for the report.
        force: magnitude of the force part of each load, N (> 0).
        moment: magnitude of the moment part, N·m (> 0).
        preload: contact force P_i before loading, N (≥ 0): one for every brace or one per brace; both
            references set their springs so that the configuration is the equilibrium under the preloads. A
            load that pulls more than P_i off a surface opens that contact.
        directions: load directions, (label, [f̂; m̂]) pairs or bare 6-vectors (world axes); each non-zero part
            is scaled to ``force`` / ``moment``.
        max_steps: MuJoCo step budget per case (retried at 0.5 ms and 0.25 ms if it does not settle).
        mujoco: also run MuJoCo (False: the static solve only).
        progress: called with 1 after each case (for a progress bar).

    Returns:
        :class:`ValidationReport`; failed and opened cases are marked in it, never dropped.

    Raises:
        InputError: bad configurations (a brace off its surface, dependent contacts), loads or directions.
    """
    force = _positive(force, "force", "N")
    moment = _positive(moment, "moment", "N·m")
    plane_contacts(braced, preload)  # checks the preloads and the contact types
    if not isinstance(mujoco, bool):
        raise InputError(f"mujoco must be True or False, got {mujoco!r}")
    max_steps = _count(max_steps, "max_steps")
    labelled = _directions(directions)
    qs = [braced.robot.check_q(q) for q in configs]
    scale = np.array([force] * 3 + [moment] * 3)
    p_json = float(preload) if isinstance(preload, int | float) else [float(p) for p in preload]
    report = ValidationReport(
        scenario=name,
        configurations=[np.asarray(q, dtype=float).tolist() for q in qs],
        settings={
            "force_N": force,
            "moment_Nm": moment,
            "preload_N": p_json,
            "directions": [{"label": lab, "direction": d.tolist()} for lab, d in labelled],
            "length_scale": "L = |e - b| at each configuration (m)",
            "static_solve": "Newton on the KKT system, unilateral contact (opens if it would pull), tol 1e-12",
            "mujoco": {**MUJOCO_SETTINGS, "max_steps": max_steps} if mujoco else None,
        },
    )
    for i, q in enumerate(qs):
        try:
            cfg = _config(braced, q, i)
        except InputError:
            raise
        except (BracekitError, np.linalg.LinAlgError) as exc:
            report.cases.extend(_failed_config(i, labelled, scale, exc))
            if progress is not None:
                progress(len(labelled))
            continue
        report.models = tuple(cfg.compliances)  # the projection model is the paper's, for one brace
        for label, d in labelled:
            report.cases.append(_case(braced, cfg, i, label, d * scale, preload, max_steps, mujoco))
            if progress is not None:
                progress(1)
    return report


# --------------------------------------------------------------------------------------------------
# Preload study
# --------------------------------------------------------------------------------------------------
def preload_study(
    scenario: Scenario | str | os.PathLike[str],
    preloads: Sequence[float] = (0.1, 0.3, 1.0, 3.0, 10.0, 30.0, 50.0),
    loads: Sequence[float] = (0.05, 0.5, 2.0),
    *,
    config: ArrayLike | None = None,
    directions: Sequence[tuple[str, ArrayLike]] | Sequence[ArrayLike] = FORCE_DIRECTIONS,
    reference: Literal["static", "mujoco"] = "static",
) -> dict[str, Any]:
    """Error of the first-order ``constrained`` model vs the preload P (N) and the load magnitude (N).

    Physics: with a preload the contact pushes on b with P n̂ through the configuration-dependent J_b,
    so the equilibrium K (q − rest) = J_eᵀ w + J_b,vᵀ n̂ λ has the tangent stiffness
    K_t = K − P ∂(J_b,vᵀ n̂)/∂q: a geometric (conservative-congruence) stiffness −∂(J_bᵀ n̂ P)/∂q that the
    first-order models, built on K alone, neglect. Its error is first order in w and grows about linearly
    with P / k (at fixed load); the dead load's own geometric term −∂(J_eᵀ w)/∂q adds an error growing
    linearly with |w| (at fixed P). ``corrected`` is the constrained model with K_t
    (:func:`bracekit.compliance.preloaded_compliance`): it removes the preload term and leaves the load term.

    The reference is the nonlinear static solve with a bilateral contact (every (P, load) pair
    comparable; ``would_open`` counts the cases where a unilateral contact would have opened), or MuJoCo
    (unilateral; opened cases excluded). Loads are pure forces of magnitude ``loads`` along ``directions``
    at the start configuration unless ``config`` is given.

    Returns a JSON-able dict; the arrays are indexed ``[preload][load]``: ``median_rel_err``, ``max_rel_err``
    (constrained), ``median_rel_err_corrected``, ``max_rel_err_corrected``, ``would_open``, ``failed``;
    errors in the L-weighted norm of :func:`run_validation`, None where no case contributes.
    """
    sc = _scenario(scenario)
    if reference not in ("static", "mujoco"):
        raise InputError(f"reference must be 'static' or 'mujoco', got {show(reference)}")
    ps = [_positive(p, "preload", "N", zero_ok=True) for p in preloads]
    fs = [_positive(f, "load", "N") for f in loads]
    if not ps or not fs:
        raise InputError("preloads and loads must each hold at least one value")
    labelled = _directions(directions)
    q = validation_configurations(sc, 1)[0] if config is None else sc.robot.check_q(config)
    cfg = _config(sc.braced, q, 0)
    c_first = cfg.compliances["constrained"]
    robot = sc.robot
    shape = (len(ps), len(fs))
    med, mx = np.full(shape, None, dtype=object), np.full(shape, None, dtype=object)
    med_c, mx_c = np.full(shape, None, dtype=object), np.full(shape, None, dtype=object)
    opened, failed = np.zeros(shape, dtype=int), np.zeros(shape, dtype=int)
    messages: list[str] = []
    for i, p in enumerate(ps):
        c_corr = preloaded_compliance(sc.braced, q, p)
        args = (robot.model, q, robot.stiffness, robot.tip_id, plane_contacts(sc.braced, p, environment=False))
        for j, f in enumerate(fs):
            errs, errs_c = [], []
            for label, d in labelled:
                w = np.concatenate([d[:3] * f, d[3:] * f * cfg.length])  # a moment part: f·L N·m
                try:
                    if reference == "static":
                        rs = solve_statics(*args, w, bilateral=True)
                        is_open, dx = rs.contact_force < 0.0, rs.deflection
                    else:
                        rm = mujoco_static_deflection(*args, w)
                        is_open, dx = rm.contact_opened, rm.deflection
                except (StaticSolveError, MujocoValidationError, ValueError, np.linalg.LinAlgError) as exc:
                    failed[i, j] += 1
                    messages.append(f"P = {p:g} N, |f| = {f:g} N, {label}: {exc}")
                    continue
                opened[i, j] += int(is_open)
                if is_open and reference == "mujoco":
                    continue
                ref = np.asarray(dx, dtype=float)
                errs.append(_rel_err(c_first @ w, ref, cfg.length))
                errs_c.append(_rel_err(c_corr @ w, ref, cfg.length))
            med[i, j], mx[i, j] = _stats(errs)
            med_c[i, j], mx_c[i, j] = _stats(errs_c)
    return {
        "scenario": sc.name,
        "reference": reference,
        "contact": "bilateral" if reference == "static" else "unilateral (opened cases excluded)",
        "config": np.asarray(q, dtype=float).tolist(),
        "length_scale_m": cfg.length,
        "preloads_N": ps,
        "loads_N": fs,
        "directions": [{"label": lab, "direction": d.tolist()} for lab, d in labelled],
        "median_rel_err": med.tolist(),
        "max_rel_err": mx.tolist(),
        "median_rel_err_corrected": med_c.tolist(),
        "max_rel_err_corrected": mx_c.tolist(),
        "would_open": opened.tolist(),
        "failed": failed.tolist(),
        "messages": messages,
    }


# --------------------------------------------------------------------------------------------------
# Holding: contact forces, slip and lift-off under gravity, preload and friction
# --------------------------------------------------------------------------------------------------
@dataclass
class HoldingValidationReport:
    """Result of :func:`run_holding_validation`.

    ``checks``: one JSON-able dict per (configuration, listed wrench): ``config`` and ``wrench_index``,
    ``status`` (``ok`` | ``failed``), ``message``, and the :meth:`HoldingCheck.to_json` fields (``check``; None
    when it failed).
    """

    scenario: str
    holding: dict[str, Any]
    configurations: list[list[float]]
    settings: dict[str, Any]
    checks: list[dict[str, Any]] = field(default_factory=list)

    def _cases(self) -> list[dict[str, Any]]:
        return [c for ch in self.checks if ch["check"] is not None for c in ch["check"]["cases"]]

    def summary(self) -> dict[str, Any]:
        """Agreement in numbers: unloaded force, loaded force and torque errors, outcomes against the margins."""
        done = [ch["check"] for ch in self.checks if ch["check"] is not None]
        cases = self._cases()
        med_n, max_n = _stats([c["unloaded_normal_rel_err"] for c in done])
        med_f, max_f = _stats([c["rel_err"] for c in cases])
        med_c, max_c = _stats([c["rel_err_change"] for c in cases])
        med_t, max_t = _stats([c["torque_rel_err"] for c in cases])
        judged = [c for c in cases if c["agrees"] is not None]
        tangential = [c["unloaded_tangential_N"] for c in done]
        return {
            "unloaded_normal_median_rel_err": med_n,
            "unloaded_normal_max_rel_err": max_n,
            "unloaded_tangential_max_N": max(tangential) if tangential else None,
            "force_median_rel_err": med_f,
            "force_max_rel_err": max_f,
            "force_change_median_rel_err": med_c,
            "force_change_max_rel_err": max_c,
            "torque_median_rel_err": med_t,
            "torque_max_rel_err": max_t,
            "n_force_cases": sum(c["rel_err"] is not None for c in cases),
            "margin_cases": len(judged),
            "margin_agree": sum(bool(c["agrees"]) for c in judged),
            "margin_disagreements": [
                {"fraction_of_margin": c["fraction_of_margin"], "expected": c["expected"], "mujoco": c["outcome"]}
                for c in judged
                if not c["agrees"]
            ],
            "max_creep_m": max((ch["creep_m"] for ch in done), default=None),
            "counts": {s: sum(ch["status"] == s for ch in self.checks) for s in ("ok", "failed")},
        }

    def to_json(self) -> dict[str, Any]:
        """One JSON-serialisable dict (no NaN: missing numbers and infinite margins are None)."""
        return {
            "scenario": self.scenario,
            "holding": self.holding,
            "error_measure": (
                "rel_err = |f_mujoco - f_pred| / |f_pred| (contact force on the robot at b, N, world axes), "
                "f_pred = f_c0 + s*df_c(w) first order; rel_err_change divides by |s*df_c(w)|; statistics over the "
                "cases predicted and found to hold"
            ),
            "summary": self.summary(),
            "settings": self.settings,
            "configurations": self.configurations,
            "checks": self.checks,
        }

    def table_text(self) -> str:
        """A few aligned lines: unloaded force, loaded force errors, margin agreement, creep."""
        s = self.summary()
        h = self.holding
        mu = "none" if h["friction"] is None else f"{h['friction']:g}"
        cnt = s["counts"]
        creep = "n/a" if s["max_creep_m"] is None else f"{s['max_creep_m']:.2g} m"
        tang = "n/a" if s["unloaded_tangential_max_N"] is None else f"{s['unloaded_tangential_max_N']:.2g} N"
        lines = [
            f"Validation of the holding statics in MuJoCo, scenario '{self.scenario}'",
            f"gravity {'on' if h['gravity'] else 'off'}, preload P = {h['preload_N']:g} N, friction μ = {mu}; "
            f"{len(self.configurations)} configuration(s), {len(self.checks)} check(s): {cnt['ok']} ran, "
            f"{cnt['failed']} failed",
            f"unloaded normal force vs P: median {fmt_rel(s['unloaded_normal_median_rel_err'])}, "
            f"max {fmt_rel(s['unloaded_normal_max_rel_err'])}; tangential at most {tang}",
            f"loaded contact force vs first order ({s['n_force_cases']} cases): median "
            f"{fmt_rel(s['force_median_rel_err'])}, max {fmt_rel(s['force_max_rel_err'])} "
            f"(of the load's change: median {fmt_rel(s['force_change_median_rel_err'])}, "
            f"max {fmt_rel(s['force_change_max_rel_err'])}); joint torques median "
            f"{fmt_rel(s['torque_median_rel_err'])}, max {fmt_rel(s['torque_max_rel_err'])}",
            f"slip / lift-off against the predicted margin (hold below 0.8×, fail above 1.2×): "
            f"{s['margin_agree']} of {s['margin_cases']} agree; tangential creep of sticking contacts ≤ {creep}",
        ]
        fails = [
            f"  config {ch['config']}, wrench {ch['wrench_index']}: {ch['message']}"
            for ch in self.checks
            if ch["status"] == "failed"
        ]
        return "\n".join([*lines, *(["failed checks:", *fails] if fails else [])])


def run_holding_validation(
    scenario: Scenario | str | os.PathLike[str],
    configs: int | Sequence[ArrayLike] = 1,
    *,
    fractions: Sequence[float] = DEFAULT_FRACTIONS,
    progress: Callable[[int], None] | None = None,
) -> HoldingValidationReport:
    """Check the scenario's holding statics (``sc.holding``: gravity, preload, friction, wrenches) in MuJoCo.

    At each configuration and for each listed wrench w, :func:`~bracekit.validate.holding_check.mujoco_holding_check`
    settles the preloaded chain and loads it with s·w at ``fractions`` of the predicted slip / lift-off margin
    (a wrench with no finite margin: s = 0.5, 1). Without listed wrenches only the unloaded state is checked.
    About 1 s of wall time per wrench and configuration (plus solving the configurations).

    Args:
        scenario: a Scenario, a shipped name or a TOML path; frictionless point contact, rigid surface, and a
            holding that is active ([robot] gravity, [brace] preload or friction, or [loads] wrenches).
        configs: number of configurations (:func:`validation_configurations`) or the configurations.
        fractions: fractions of the predicted margin to load each wrench to.
        progress: called with 1 after each check.

    Raises:
        InputError: bad scenario, a scenario without holding statics, bad configs or fractions.
    """
    sc = _scenario(scenario)
    h = sc.holding
    if not h.active:
        raise InputError(
            f"scenario '{sc.name}' has no holding statics to check: set [robot] gravity, [brace] preload or "
            "friction, or [loads] wrenches"
        )
    fr = [_positive(f, "each fraction of the margin", "", zero_ok=True) for f in fractions]
    if not fr:
        raise InputError("fractions must hold at least one fraction of the margin")
    qs = _configurations(sc, configs)
    wrenches: list[Array] = [np.zeros(6)] if h.wrenches is None else list(h.wrenches)
    report = HoldingValidationReport(
        scenario=sc.name,
        holding={
            "gravity": h.gravity,
            "preload_N": h.preload,
            "friction": h.friction,
            "wrenches": None if h.wrenches is None else h.wrenches.tolist(),
        },
        configurations=[np.asarray(q, dtype=float).tolist() for q in qs],
        settings={**HOLDING_SETTINGS, "fractions_of_margin": fr, "hold_below": HOLD_BELOW, "fail_above": FAIL_ABOVE},
    )
    for i, q in enumerate(qs):
        for j, w in enumerate(wrenches):
            entry: dict[str, Any] = {"config": i, "wrench_index": j, "status": "ok", "message": None, "check": None}
            try:
                chk = mujoco_holding_check(sc.braced, q, h, w, scales=[] if h.wrenches is None else None, fractions=fr)
                entry["check"] = chk.to_json()
            except (MujocoValidationError, NumericalError) as exc:
                entry["status"], entry["message"] = "failed", str(exc)
            report.checks.append(entry)
            if progress is not None:
                progress(1)
    return report


# --------------------------------------------------------------------------------------------------
# The preloaded compliance with gravity
# --------------------------------------------------------------------------------------------------
#: The models of :func:`run_preloaded_validation`, in report order.
PRELOADED_MODELS = ("preloaded", "constrained")


@dataclass
class PreloadedValidationReport:
    """Result of :func:`run_preloaded_validation`.

    ``cases``: one JSON-able dict per (configuration, preload, load): ``config``, ``preload_N``, ``label``,
    ``wrench``, ``status`` (``ok`` | ``contact_opened`` | ``failed``), ``message``, ``length_scale_m``,
    ``deflection`` {mujoco, static, preloaded, constrained} → [Δp; Δθ] (m, rad) or None, ``rel_err``
    {model: {mujoco, static}}, ``rel_err_mujoco_vs_static``, ``contact_force_static`` / ``contact_force_mujoco``
    (N), ``opened``, ``mujoco_steps``.
    """

    scenario: str
    gravity: bool
    preloads: list[float]
    configurations: list[list[float]]
    settings: dict[str, Any]
    cases: list[dict[str, Any]] = field(default_factory=list)

    def model_stats(self, model: str, preload: float | None = None) -> dict[str, float | int | None]:
        """Median and max relative error of ``preloaded`` or ``constrained`` vs MuJoCo and the static solve.

        Over the closed-contact cases of every preload, or of one ``preload`` (N).
        """
        ok = [c for c in self.cases if c["status"] == "ok" and (preload is None or c["preload_N"] == preload)]
        return _model_stats(ok, model)

    def mujoco_vs_static(self) -> dict[str, float | int | None]:
        """Agreement of the two references on every case where both ran."""
        return _references_agree(self.cases)

    def counts(self) -> dict[str, int]:
        """Number of cases per status."""
        return _status_counts(self.cases)

    def by_preload(self) -> list[dict[str, Any]]:
        """Per preload P (N): the statistics of both models and the case counts."""
        out = []
        for p in self.preloads:
            mine = [c for c in self.cases if c["preload_N"] == p]
            out.append(
                {
                    "preload_N": p,
                    **{m: self.model_stats(m, p) for m in PRELOADED_MODELS},
                    "counts": {s: sum(c["status"] == s for c in mine) for s in ("ok", "contact_opened", "failed")},
                }
            )
        return out

    def to_json(self) -> dict[str, Any]:
        """One JSON-serialisable dict (no NaN: missing numbers are None).

        The ``preloaded`` model's statistics at the top level (the keys of the ``constrained`` block of
        :class:`ValidationReport`), ``constrained`` on the same cases, ``by_preload``, ``mujoco_vs_static``,
        ``counts``, ``settings``, ``configurations`` and ``cases``.
        """
        return {
            **self.model_stats("preloaded"),
            "constrained": self.model_stats("constrained"),
            "by_preload": self.by_preload(),
            "gravity": self.gravity,
            "preloads_N": self.preloads,
            "error_measure": (
                "relative error ||dx_pred - dx_ref||_L / ||dx_ref||_L as in run_validation; dx_pred = C w with C the "
                "preloaded compliance (tangent stiffness of gravity and the preload) or the constrained C_e"
            ),
            "mujoco_vs_static": self.mujoco_vs_static(),
            "counts": self.counts(),
            "settings": self.settings,
            "configurations": self.configurations,
            "cases": self.cases,
        }

    def table_text(self) -> str:
        """Aligned text table: per preload, median and max error of both models vs MuJoCo and the static solve."""
        cnt = self.counts()
        s = self.settings
        head = [
            f"Validation of the preloaded compliance, scenario '{self.scenario}', gravity "
            f"{'on' if self.gravity else 'off'}",
            f"{len(self.configurations)} configuration(s) × {len(self.preloads)} preload(s), "
            f"{len(self.cases)} case(s): {cnt['ok']} compared, {cnt['contact_opened']} with the contact opened, "
            f"{cnt['failed']} failed",
            f"loads: |f| = {s['force_N']:g} N, |m| = {s['moment_Nm']:g} N·m",
            "",
        ]
        cols = ("P [N]", "model", "median vs MuJoCo", "max vs MuJoCo", "median vs static", "max vs static", "n")
        keys = ("median_rel_err_mujoco", "max_rel_err_mujoco", "median_rel_err_static", "max_rel_err_static")
        rows = []
        for entry in self.by_preload():
            for m in PRELOADED_MODELS:
                st = entry[m]
                rows.append((f"{entry['preload_N']:g}", m, *(fmt_rel(st[k]) for k in keys), str(st["n_cases"])))
        widths = [max(len(r[i]) for r in (cols, *rows)) for i in range(len(cols))]

        def fmt(r: tuple[str, ...]) -> str:
            return "  ".join(c.ljust(widths[i]) if i == 1 else c.rjust(widths[i]) for i, c in enumerate(r))

        ms = self.mujoco_vs_static()
        agree = (
            f"MuJoCo vs static solve ({ms['n_cases']} cases): median {fmt_rel(ms['median_rel_err'])}, "
            f"max {fmt_rel(ms['max_rel_err'])}"
        )
        fails = [
            f"  config {c['config']}, P = {c['preload_N']:g} N, {c['label']}: {c['message']}"
            for c in self.cases
            if c["status"] == "failed"
        ]
        tail = ["", "failed cases:", *fails] if fails else []
        return "\n".join([*head, fmt(cols), "-" * len(fmt(cols)), *map(fmt, rows), "", agree, *tail])


def _preloaded_case(
    braced: BracedRobot,
    q: Array,
    length: float,
    comp: dict[str, Array],
    index: int,
    label: str,
    w: Array,
    preload: float,
    gravity: bool,
    max_steps: int,
) -> dict[str, Any]:
    refs, messages = _references(braced, q, w, preload, max_steps, gravity)
    st, mj = refs["static"], refs["mujoco"]
    ref = {
        "static": None if st is None else np.asarray(st.deflection, dtype=float),
        "mujoco": None if mj is None else np.asarray(mj.deflection, dtype=float),
    }
    pred = {m: comp[m] @ w for m in PRELOADED_MODELS}
    opened = bool((st is not None and st.contact_opened) or (mj is not None and mj.contact_opened))
    status = "failed" if messages else ("contact_opened" if opened else "ok")
    if status == "contact_opened":
        messages.append("the contact opened under this load (it pulls more than the preload): not in the statistics")
    return {
        "config": index,
        "preload_N": preload,
        "label": label,
        "wrench": w.tolist(),
        "status": status,
        "message": "; ".join(messages) if messages else None,
        "length_scale_m": length,
        "deflection": {
            **{k: (None if v is None else v.tolist()) for k, v in ref.items()},
            **{m: pred[m].tolist() for m in PRELOADED_MODELS},
        },
        "rel_err": {m: {k: _rel_err(pred[m], ref[k], length) for k in ("mujoco", "static")} for m in PRELOADED_MODELS},
        "rel_err_mujoco_vs_static": (
            _rel_err(ref["mujoco"], ref["static"], length) if ref["mujoco"] is not None else None
        ),
        "contact_force_static": None if st is None else float(st.contact_force),
        "contact_force_mujoco": None if mj is None else float(mj.contact_force),
        "opened": opened,
        "mujoco_steps": None if mj is None else int(mj.steps),
    }


def run_preloaded_validation(
    scenario: Scenario | str | os.PathLike[str],
    configs: int | Sequence[ArrayLike] = 3,
    *,
    preloads: Sequence[float] = (1.0, 5.0, 20.0, 50.0),
    gravity: bool = True,
    force: float = 0.5,
    moment: float = 0.05,
    directions: Sequence[tuple[str, ArrayLike]] | Sequence[ArrayLike] = DEFAULT_DIRECTIONS,
    max_steps: int = 100_000,
    progress: Callable[[int], None] | None = None,
) -> PreloadedValidationReport:
    """Compare the preloaded compliance and the ``constrained`` model with MuJoCo and the nonlinear statics.

    At each configuration and preload P the references are loaded about the preloaded, gravity-loaded
    equilibrium: the springs' set points q_s = q + K⁻¹ (g(q) − J_b,vᵀ n̂ P) hold q under gravity (with
    ``gravity``: the URDF's masses, 9.81 m/s² along −z, in MuJoCo and in the static solve) and the contact
    force P n̂. The loads are those of :func:`run_validation` (``directions`` scaled to ``force`` / ``moment``);
    the predictions are Δx = C w with C = :func:`~bracekit.compliance.preloaded_compliance` (K_t = K + ∂g/∂q −
    P ∂(J_b,vᵀ n̂)/∂q) and the first-order ``constrained`` C_e (K alone). Errors in the L-weighted norm of
    :func:`run_validation`; a case whose contact opens is reported and not compared. About 0.1 s per case
    (MuJoCo), so 4 s per configuration with the 4 default preloads and 10 loads.

    Args:
        scenario: a Scenario, a shipped name or a TOML path; frictionless point contact, rigid surface.
        configs: number of configurations (:func:`validation_configurations`) or the configurations.
        preloads: contact forces P (N, ≥ 0).
        gravity: gravity on in both references and in the preloaded model.
        force: magnitude of the force part of each load, N (> 0).
        moment: magnitude of the moment part, N·m (> 0).
        directions: load directions as for :func:`run_validation`.
        max_steps: MuJoCo step budget per case.
        progress: called with 1 after each case.

    Raises:
        InputError: bad scenario, configs, preloads, loads or directions.
    """
    sc = _scenario(scenario)
    if not isinstance(gravity, bool):
        raise InputError(f"gravity must be True or False, got {show(gravity)}")
    ps = [_positive(p, "each preload", "N", zero_ok=True) for p in preloads]
    if not ps:
        raise InputError("preloads must hold at least one contact force (N)")
    force = _positive(force, "force", "N")
    moment = _positive(moment, "moment", "N·m")
    max_steps = _count(max_steps, "max_steps")
    labelled = _directions(directions)
    qs = _configurations(sc, configs)
    scale = np.array([force] * 3 + [moment] * 3)
    report = PreloadedValidationReport(
        scenario=sc.name,
        gravity=gravity,
        preloads=ps,
        configurations=[np.asarray(q, dtype=float).tolist() for q in qs],
        settings={
            "force_N": force,
            "moment_Nm": moment,
            "directions": [{"label": lab, "direction": d.tolist()} for lab, d in labelled],
            "length_scale": "L = |e - b| at each configuration (m)",
            "set_points": "q_s = q + K^-1 (g(q) - J_b,v^T n P): q is the equilibrium under gravity and the preload",
            "static_solve": "Newton on the KKT system, unilateral contact, gravity as set, tol 1e-12",
            "mujoco": {**MUJOCO_SETTINGS, "gravity": gravity, "max_steps": max_steps},
        },
    )
    for i, q in enumerate(qs):
        try:
            cfg = _config(sc.braced, q, i)
        except InputError:
            raise
        except (BracekitError, np.linalg.LinAlgError) as exc:
            for p in ps:
                report.cases.extend(
                    {**_preloaded_case_failed(i, p, label, d * scale, None), "message": f"configuration {i}: {exc}"}
                    for label, d in labelled
                )
            if progress is not None:
                progress(len(ps) * len(labelled))
            continue
        for p in ps:
            comp = {"constrained": cfg.compliances["constrained"]}
            try:
                comp["preloaded"] = preloaded_tip_compliance(sc.braced, q, p, gravity)
            except NumericalError as exc:
                report.cases.extend(
                    {
                        **_preloaded_case_failed(i, p, label, d * scale, cfg.length),
                        "message": f"preloaded compliance: {exc}",
                    }
                    for label, d in labelled
                )
                if progress is not None:
                    progress(len(labelled))
                continue
            for label, d in labelled:
                report.cases.append(
                    _preloaded_case(sc.braced, cfg.q, cfg.length, comp, i, label, d * scale, p, gravity, max_steps)
                )
                if progress is not None:
                    progress(1)
    return report


def _preloaded_case_failed(index: int, preload: float, label: str, w: Array, length: float | None) -> dict[str, Any]:
    return {
        "config": index,
        "preload_N": preload,
        "label": label,
        "wrench": w.tolist(),
        "status": "failed",
        "message": None,
        "length_scale_m": length,
        "deflection": {k: None for k in ("mujoco", "static", *PRELOADED_MODELS)},
        "rel_err": {m: {"mujoco": None, "static": None} for m in PRELOADED_MODELS},
        "rel_err_mujoco_vs_static": None,
        "contact_force_static": None,
        "contact_force_mujoco": None,
        "opened": False,
        "mujoco_steps": None,
    }


# --------------------------------------------------------------------------------------------------
# Capacity: lift-off and slip scales under a slow load ramp
# --------------------------------------------------------------------------------------------------
_CAPACITY_STATUSES = ("ok", "disagrees", "no_limit", "failed")


@dataclass
class CapacityValidationReport:
    """Result of :func:`run_capacity_validation`.

    ``cases``: one JSON-able dict per (configuration, wrench, contact variant): ``config``, ``wrench_index``,
    ``wrench``, ``variant`` (``scenario``: the scenario's friction; ``frictionless``: the same without μ, for a
    lift-off that friction pre-empts), ``status`` (``ok``: MuJoCo failed the predicted way; ``disagrees``: it
    failed otherwise or not at all; ``no_limit``: bracekit predicts neither lift-off nor slip; ``failed``),
    ``message``, and the :meth:`CapacityRamp.to_json` fields under ``ramp`` (None unless run).
    """

    scenario: str
    holding: dict[str, Any]
    configurations: list[list[float]]
    settings: dict[str, Any]
    cases: list[dict[str, Any]] = field(default_factory=list)

    def _stats_of(self, mode: str | None = None) -> dict[str, float | int | None]:
        ok = [c["ramp"] for c in self.cases if c["status"] == "ok" and (mode is None or c["ramp"]["mode"] == mode)]
        med, mx = _stats([r["rel_err"] for r in ok])
        med_s, max_s = _stats([r["rel_err_static"] for r in ok])
        return {
            "median_rel_err": med,
            "max_rel_err": mx,
            "median_rel_err_static": med_s,
            "max_rel_err_static": max_s,
            "n_cases": len(ok),
        }

    def counts(self) -> dict[str, int]:
        """Number of cases per status."""
        return {s: sum(c["status"] == s for c in self.cases) for s in _CAPACITY_STATUSES}

    def to_json(self) -> dict[str, Any]:
        """One JSON-serialisable dict (no NaN: missing numbers are None).

        ``median_rel_err``, ``max_rel_err`` (first-order scale vs MuJoCo), ``median_rel_err_static``,
        ``max_rel_err_static`` (nonlinear statics vs MuJoCo), ``n_cases``, ``by_mode`` (the same per failure),
        ``counts``, ``holding``, ``settings``, ``configurations``, ``cases``.
        """
        return {
            **self._stats_of(),
            "by_mode": {m: self._stats_of(m) for m in ("slipped", "lifted_off")},
            "error_measure": (
                "rel_err = |s_pred - s_mujoco| / s_mujoco with s the scale of the tool wrench at which the brace lifts "
                "off or slips: s_pred first order (bracekit.statics), rel_err_static with the nonlinear statics' "
                "scale; statistics over the cases where MuJoCo failed the predicted way"
            ),
            "counts": self.counts(),
            "holding": self.holding,
            "settings": self.settings,
            "configurations": self.configurations,
            "cases": self.cases,
        }

    def table_text(self) -> str:
        """One line per case (scales: first order, nonlinear statics, MuJoCo) and the summary."""
        s = self._stats_of()
        cnt = self.counts()
        lines = [
            f"Lift-off and slip scales under a slow load ramp in MuJoCo, scenario '{self.scenario}'",
            f"{len(self.cases)} case(s): {cnt['ok']} compared, {cnt['disagrees']} disagree, {cnt['no_limit']} with "
            f"no predicted limit, {cnt['failed']} failed",
            "",
        ]
        cols = ("config", "wrench", "contact", "mode", "first order", "nonlinear", "MuJoCo", "error", "error (nl)")
        rows = []
        for c in self.cases:
            r = c["ramp"]
            if r is None:
                rows.append((str(c["config"]), str(c["wrench_index"]), c["variant"], c["status"], *("–",) * 5))
                continue

            def num(x: float | None) -> str:
                return "n/a" if x is None else f"{x:.4g}"

            if r["mode"] == "held":
                mj = f"held to {r['stop_scale']:g}" if r["mujoco_outcome"] == "held" else num(r["mujoco_scale"])
            else:
                mj = num(r["mujoco_scale"])
            mj += "" if r["mujoco_outcome"] in (None, r["mode"]) else f" ({r['mujoco_outcome']})"
            rows.append(
                (
                    str(c["config"]),
                    str(c["wrench_index"]),
                    c["variant"],
                    r["mode"],
                    "∞" if r["mode"] == "held" else num(r["predicted_scale"]),
                    "∞"
                    if r["mode"] == "held" and (r["static_message"] or "").startswith("nonlinear statics hold")
                    else num(r["static_scale"]),
                    mj,
                    fmt_rel(r["rel_err"]),
                    fmt_rel(r["rel_err_static"]),
                )
            )
        widths = [max(len(r[i]) for r in (cols, *rows)) for i in range(len(cols))]

        def fmt(r: tuple[str, ...]) -> str:
            return "  ".join(c.ljust(widths[i]) if i in (2, 3) else c.rjust(widths[i]) for i, c in enumerate(r))

        tail = [
            "",
            f"first-order scale vs MuJoCo ({s['n_cases']} cases): median {fmt_rel(s['median_rel_err'])}, max "
            f"{fmt_rel(s['max_rel_err'])}; nonlinear statics vs MuJoCo: median {fmt_rel(s['median_rel_err_static'])}, "
            f"max {fmt_rel(s['max_rel_err_static'])}",
        ]
        notes = [
            f"  config {c['config']}, wrench {c['wrench_index']} ({c['variant']}): {c['message']}"
            for c in self.cases
            if c["status"] in ("failed", "disagrees", "no_limit")
        ]
        return "\n".join([*lines, fmt(cols), "-" * len(fmt(cols)), *map(fmt, rows), *tail, *notes])


def _capacity_entry(
    braced: BracedRobot, q: Array, holding: Holding, w: Array, index: int, j: int, variant: str, ramp_time: float
) -> dict[str, Any]:
    entry: dict[str, Any] = {
        "config": index,
        "wrench_index": j,
        "wrench": w.tolist(),
        "variant": variant,
        "status": "ok",
        "message": None,
        "ramp": None,
    }
    try:
        r = mujoco_capacity_ramp(braced, q, holding, w, ramp_time=ramp_time)
    except (MujocoValidationError, NumericalError) as exc:
        entry["status"], entry["message"] = "failed", str(exc)
        return entry
    entry["ramp"] = r.to_json()
    if r.mode == "held":  # neither lift-off nor slip at any scale: shown by ramping to stop_scale × w
        entry["status"] = "no_limit" if r.mujoco_outcome == "held" else "disagrees"
        what = (
            "held"
            if r.mujoco_outcome == "held"
            else f"{str(r.mujoco_outcome).replace('_', ' ')} at s = {r.mujoco_scale:.4g}"
        )
        entry["message"] = f"holds at any scale; ramped to {r.stop_scale:g}x in MuJoCo, {what}"
        if r.static_message is not None:
            entry["message"] += f"; {r.static_message}"
        return entry
    if r.mujoco_outcome != r.mode:
        entry["status"] = "disagrees"
        what = "did not fail" if r.mujoco_outcome is None else f"{r.mujoco_outcome.replace('_', ' ')}"
        entry["message"] = (
            f"bracekit predicts {r.mode.replace('_', ' ')} first, MuJoCo {what} up to s = {r.stop_scale:.4g}"
        )
    elif r.static_message is not None:
        entry["message"] = f"nonlinear statics: {r.static_message}"
    return entry


def run_capacity_validation(
    scenario: Scenario | str | os.PathLike[str],
    configs: int | Sequence[ArrayLike] = 1,
    *,
    wrenches: ArrayLike | None = None,
    frictionless_liftoff: bool = True,
    ramp_time: float = RAMP_SETTINGS["ramp_time_tau"],
    progress: Callable[[int], None] | None = None,
) -> CapacityValidationReport:
    """Check bracekit's lift-off and slip scales against MuJoCo under a slow load ramp.

    For each configuration and tool wrench w, :func:`~bracekit.validate.holding_check.mujoco_capacity_ramp`
    ramps s·w slowly (s reaches the predicted scale after ``ramp_time`` damping time constants) from the
    settled preloaded state (the scenario's gravity, preload and friction) and records the scale at which
    MuJoCo's contact opens or reaches the Coulomb cone; it is compared with bracekit's first-order scale
    (:func:`bracekit.statics.capacity_of`) and with the nonlinear statics' scale. With ``frictionless_liftoff``,
    a wrench predicted to slip before it would lift off is also ramped on the frictionless brace (same preload
    and gravity) to check its lift-off scale. A wrench with neither limit holds at any scale: it is ramped to
    10 × w in MuJoCo (status ``no_limit`` when it held, ``disagrees`` otherwise). About 1 s per case.

    Args:
        scenario: a Scenario, a shipped name or a TOML path; frictionless point contact, rigid surface, a
            preload P > 0 ([brace] preload).
        configs: number of configurations (:func:`validation_configurations`) or the configurations.
        wrenches: tool wrenches (m×6, [f; m] at the tip, world axes, N and N·m); default the scenario's
            [loads] wrenches.
        frictionless_liftoff: also check lift-off without friction where friction pre-empts it.
        ramp_time: time for s to reach the predicted scale, in damping time constants τ (> 0).
        progress: called with 1 after each wrench.

    Raises:
        InputError: bad scenario (no preload), configs, wrenches or ramp_time; no wrenches to check.
    """
    sc = _scenario(scenario)
    h = sc.holding
    if not h.preload > 0.0:
        raise InputError(
            f"scenario '{sc.name}' has no preload: set [brace] preload (N) > 0 so that the brace can carry a load"
        )
    if wrenches is None:
        if h.wrenches is None:
            raise InputError(f"scenario '{sc.name}' lists no [loads] wrenches; give the tool wrenches to check")
        ws = np.asarray(h.wrenches, dtype=float)
    else:
        ws = wrench_list(wrenches)
    ramp_time = _positive(ramp_time, "ramp_time", "damping time constants")
    if not isinstance(frictionless_liftoff, bool):
        raise InputError(f"frictionless_liftoff must be True or False, got {show(frictionless_liftoff)}")
    qs = _configurations(sc, configs)
    mu = h.friction if h.friction else None
    bare = Holding(gravity=h.gravity, preload=h.preload)
    report = CapacityValidationReport(
        scenario=sc.name,
        holding={"gravity": h.gravity, "preload_N": h.preload, "friction": h.friction, "wrenches": ws.tolist()},
        configurations=[np.asarray(q, dtype=float).tolist() for q in qs],
        settings={**HOLDING_SETTINGS, **RAMP_SETTINGS, "ramp_time_tau": ramp_time},
    )
    effort = effort_limits(sc.robot)
    for i, q in enumerate(qs):
        try:
            cap = capacity_along(sc.braced, q, ws, preload=h.preload, gravity=h.gravity, friction=mu, effort=effort)
        except NumericalError as exc:
            report.cases.extend(
                {
                    "config": i,
                    "wrench_index": j,
                    "wrench": w.tolist(),
                    "variant": "scenario",
                    "status": "failed",
                    "message": str(exc),
                    "ramp": None,
                }
                for j, w in enumerate(ws)
            )
            continue
        for j, w in enumerate(ws):
            liftoff = float(cap.liftoff[0, j])
            slip = np.inf if cap.slip is None else float(cap.slip[0, j])
            report.cases.append(_capacity_entry(sc.braced, q, h, w, i, j, "scenario", ramp_time))
            if frictionless_liftoff and mu is not None and np.isfinite(liftoff) and slip < liftoff:
                report.cases.append(_capacity_entry(sc.braced, q, bare, w, i, j, "frictionless", ramp_time))
            if progress is not None:
                progress(1)
    return report
