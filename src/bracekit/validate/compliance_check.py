"""The compliance check: the first-order models of N ≥ 1 braces against MuJoCo and the nonlinear static solve.

For a few configurations and a set of small tip wrenches w, the tip deflection predicted by each first-order
model, Δx_pred = C w, is compared with two independent references loaded the same way:

* MuJoCo (:func:`~bracekit.validate.mujoco_check.mujoco_static_deflection`): spring-jointed chain, a unilateral
  frictionless sphere contact per brace, each preloaded with a force P, settled quasi-statically;
* the nonlinear static equilibrium (:func:`~bracekit.validate.statics.solve_statics`) with the same preloads
  and unilateral contacts.

Models: ``constrained`` (C_e with the Lagrange-multiplier C̃1, stacked over the braces), ``projection`` (the
paper's (I − P) C1 (I − P), one brace) and ``free_space`` (J K⁻¹ Jᵀ). Errors in ‖·‖_L (:mod:`~bracekit.validate.table`).
A case whose contact opens is reported with status ``contact_opened`` and kept out of the statistics; a failed
reference gives ``failed`` with its message, and the run goes on.
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from bracekit.compliance.first_order import end_effector_compliance, free_space_compliance
from bracekit.errors import (
    BracekitError,
    ContactError,
    InputError,
    MujocoValidationError,
    RedundantContactWarning,
    StaticSolveError,
)
from bracekit.kinematics import BracedRobot, BracedState
from bracekit.simulation.scenario_model import Scenario
from bracekit.validate.contacts import plane_contacts
from bracekit.validate.deflection_record import case_record, failed_record
from bracekit.validate.inputs import (
    _TIMESTEPS,
    DEFAULT_DIRECTIONS,
    MODELS,
    MUJOCO_SETTINGS,
    Array,
    _configurations,
    _count,
    _scenario,
    _tip_loads,
)
from bracekit.validate.mujoco_check import mujoco_static_deflection
from bracekit.validate.statics import solve_statics
from bracekit.validate.table import _stats, aligned, fmt_rel

__all__ = ["ValidationReport", "check_compliance", "first_order_state", "run_validation"]


@dataclass(frozen=True)
class _Config:
    """What every case at one configuration shares: the compliances of the models defined here, and L."""

    q: Array
    compliances: dict[str, Array]
    length: float


def first_order_state(braced: BracedRobot, q: ArrayLike) -> BracedState:
    """The state the first-order models take at q (any number of braces; the projection model needs one)."""
    return braced.state(q)


def _config(braced: BracedRobot, q: ArrayLike, index: int) -> _Config:
    with warnings.catch_warnings():
        warnings.simplefilter("error", RedundantContactWarning)
        try:
            st = first_order_state(braced, q)
            stacked = st
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


#: The message of a case whose contact opened.
_OPENED = (
    "the contact opened under this load (preload too small for it): the braced first-order models assume a closed "
    "contact, so this case is not in the statistics"
)


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


class DeflectionCases:
    """What the compliance and preloaded reports share over their load ``cases``.

    The references' agreement, the case counts and the record of how the cases were made (settings,
    configurations, the cases).
    """

    scenario: str
    configurations: list[list[float]]
    settings: dict[str, Any]
    cases: list[dict[str, Any]]

    def mujoco_vs_static(self) -> dict[str, float | int | None]:
        """Agreement of the two references on every case where both ran (opened contacts included)."""
        return _references_agree(self.cases)

    def counts(self) -> dict[str, int]:
        """Number of cases per status."""
        return _status_counts(self.cases)

    def record(self) -> dict[str, Any]:
        """The JSON record of the cases: ``settings``, ``configurations`` and ``cases``."""
        return {"settings": self.settings, "configurations": self.configurations, "cases": self.cases}


@dataclass
class ValidationReport(DeflectionCases):
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
            **self.record(),
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
        fails = [f"  config {c['config']}, {c['label']}: {c['message']}" for c in self.cases if c["status"] == "failed"]
        ms = self.mujoco_vs_static()
        agree = (
            f"MuJoCo vs static solve ({ms['n_cases']} cases where both ran): median {fmt_rel(ms['median_rel_err'])}, "
            f"max {fmt_rel(ms['max_rel_err'])}"
        )
        tail = ["", "failed cases:", *fails] if fails else []
        return "\n".join([*head, *aligned(cols, rows), "", agree, *tail])


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
    loads = _tip_loads(force, moment, directions)
    plane_contacts(braced, preload)  # checks the preloads and the contact types
    if not isinstance(mujoco, bool):
        raise InputError(f"mujoco must be True or False, got {mujoco!r}")
    max_steps = _count(max_steps, "max_steps")
    labelled, scale = loads.labelled, loads.scale
    qs = [braced.robot.check_q(q) for q in configs]
    p_json = float(preload) if isinstance(preload, int | float) else [float(p) for p in preload]
    report = ValidationReport(
        scenario=name,
        configurations=[np.asarray(q, dtype=float).tolist() for q in qs],
        settings={
            "force_N": loads.force,
            "moment_Nm": loads.moment,
            "preload_N": p_json,
            "directions": loads.directions_json(),
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
            report.cases.extend(
                failed_record({"config": i, "label": label}, d * scale, MODELS, None, f"configuration {i}: {exc}")
                for label, d in labelled
            )
            if progress is not None:
                progress(len(labelled))
            continue
        report.models = tuple(cfg.compliances)  # the projection model is the paper's, for one brace
        for label, d in labelled:
            w = d * scale
            refs, messages = _references(braced, cfg.q, w, preload, max_steps, mujoco=mujoco)
            pred = {m: c @ w for m, c in cfg.compliances.items()}
            head = {"config": i, "label": label}
            report.cases.append(case_record(head, w, pred, refs, messages, cfg.length, _OPENED))
            if progress is not None:
                progress(1)
    return report
