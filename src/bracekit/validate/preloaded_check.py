"""The preloaded check: the preloaded compliance (gravity and preload in the tangent stiffness) against the references.

:func:`run_preloaded_validation` compares :func:`preloaded_tip_compliance` and the ``constrained`` model with
MuJoCo and the nonlinear statics, both loaded about the gravity-loaded, preloaded equilibrium, for one brace or
several.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from bracekit._linalg import show
from bracekit.compliance.preloaded import preloaded_compliance
from bracekit.errors import (
    BracekitError,
    ContactError,
    InputError,
    NumericalError,
)
from bracekit.kinematics import BracedRobot
from bracekit.simulation.scenario_model import Scenario
from bracekit.statics import contact_responses
from bracekit.validate.compliance_check import DeflectionCases, _config, _model_stats, _references, _status_counts
from bracekit.validate.deflection_record import case_record, failed_record
from bracekit.validate.inputs import (
    DEFAULT_DIRECTIONS,
    MUJOCO_SETTINGS,
    Array,
    _configurations,
    _count,
    _positive,
    _scenario,
    _tip_loads,
)
from bracekit.validate.table import aligned, fmt_rel

__all__ = ["PRELOADED_MODELS", "PreloadedValidationReport", "preloaded_tip_compliance", "run_preloaded_validation"]


def preloaded_tip_compliance(braced: BracedRobot, q: ArrayLike, preload: float, gravity: bool) -> Array:
    """The preloaded compliance at the tip (6×6; wrench [f; m] at e → [Δp; Δθ], world axes).

    The core's one-brace :func:`~bracekit.compliance.preloaded.preloaded_compliance`; where that refuses several
    braces (ContactError), J_e δq/δw of the several-brace statics' first-order response
    (:func:`bracekit.statics.contact_responses` with the tangent stiffness of gravity and the
    preloads P_i = ``preload``, every contact closed).
    """
    try:
        return preloaded_compliance(braced, q, preload, gravity=gravity)
    except ContactError:
        resp = contact_responses(braced, q, preload=preload, gravity=gravity, geometric=True)
        return np.asarray(braced.state(q).J_e @ resp.joint_gain[0], dtype=float)


#: The models of :func:`run_preloaded_validation`, in report order.
PRELOADED_MODELS = ("preloaded", "constrained")


@dataclass
class PreloadedValidationReport(DeflectionCases):
    """Result of :func:`run_preloaded_validation`.

    ``cases``: one JSON-able dict per (configuration, preload, load): ``config``, ``preload_N``, ``label``,
    ``wrench``, ``status`` (``ok`` | ``contact_opened`` | ``failed``), ``message``, ``length_scale_m``,
    ``deflection`` {mujoco, static, preloaded, constrained} → [Δp; Δθ] (m, rad) or None, ``rel_err``
    {model: {mujoco, static}}, ``rel_err_mujoco_vs_static``, ``contact_force_static`` / ``contact_force_mujoco``
    (N), ``opened`` (``opened_static`` / ``opened_mujoco``), ``mujoco_steps``, ``mujoco_timestep_s``: the layout of
    :func:`~bracekit.validate.deflection_record.case_record`.
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

    def by_preload(self) -> list[dict[str, Any]]:
        """Per preload P (N): the statistics of both models and the case counts."""
        out = []
        for p in self.preloads:
            mine = [c for c in self.cases if c["preload_N"] == p]
            out.append(
                {
                    "preload_N": p,
                    **{m: self.model_stats(m, p) for m in PRELOADED_MODELS},
                    "counts": _status_counts(mine),
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
            **self.record(),
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
        return "\n".join([*head, *aligned(cols, rows, left=(1,)), "", agree, *tail])


#: The message of a case whose contact opened.
_OPENED = "the contact opened under this load (it pulls more than the preload): not in the statistics"


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
    loads = _tip_loads(force, moment, directions)
    max_steps = _count(max_steps, "max_steps")
    labelled, scale = loads.labelled, loads.scale
    qs = _configurations(sc, configs)
    report = PreloadedValidationReport(
        scenario=sc.name,
        gravity=gravity,
        preloads=ps,
        configurations=[np.asarray(q, dtype=float).tolist() for q in qs],
        settings={
            "force_N": loads.force,
            "moment_Nm": loads.moment,
            "directions": loads.directions_json(),
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
                report.cases.extend(_failed(i, p, labelled, scale, None, f"configuration {i}: {exc}"))
            if progress is not None:
                progress(len(ps) * len(labelled))
            continue
        for p in ps:
            comp = {"constrained": cfg.compliances["constrained"]}
            try:
                comp["preloaded"] = preloaded_tip_compliance(sc.braced, q, p, gravity)
            except NumericalError as exc:
                report.cases.extend(_failed(i, p, labelled, scale, cfg.length, f"preloaded compliance: {exc}"))
                if progress is not None:
                    progress(len(labelled))
                continue
            for label, d in labelled:
                w = d * scale
                refs, messages = _references(sc.braced, cfg.q, w, p, max_steps, gravity)
                pred = {m: comp[m] @ w for m in PRELOADED_MODELS}
                head = {"config": i, "preload_N": p, "label": label}
                report.cases.append(case_record(head, w, pred, refs, messages, cfg.length, _OPENED))
                if progress is not None:
                    progress(1)
    return report


def _failed(
    index: int, preload: float, labelled: list[tuple[str, Array]], scale: Array, length: float | None, message: str
) -> list[dict[str, Any]]:
    """The failed records of every load at configuration `index` and preload P (N)."""
    head = {"config": index, "preload_N": preload}
    return [
        failed_record({**head, "label": label}, d * scale, PRELOADED_MODELS, length, message) for label, d in labelled
    ]
