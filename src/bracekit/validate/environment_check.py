"""Validation of the compliance with a finite surface stiffness k_env (the brace's ``environment_stiffness``).

For each k_env the brace's surface becomes a spring of stiffness k_env along its normal and the first-order
``constrained`` compliance, C̃1 = C1 − C1 X (Xᵀ C1 X + I/k_env)⁻¹ Xᵀ C1 (docs/model.md), is compared with two
independent references loaded the same way (:func:`~bracekit.validate.runner.run_validation`'s load cases):

* MuJoCo with a soft contact whose stiffness is k_env
  (:func:`~bracekit.validate.mujoco_check.soft_contact_solref`, derived in docs/validation.md);
* the nonlinear static solve with a penalty contact λ = λ0 − k_env φ(q)
  (:func:`~bracekit.validate.statics.solve_static_equilibrium`, ``environment_stiffness``).

Each row also gives how much the surface's softness changes the predicted deflection (against the rigid
surface), so that a row that agrees does not merely repeat the rigid case.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from bracekit.compliance.first_order import end_effector_compliance
from bracekit.kinematics import BracedRobot
from bracekit.simulation.scenario_model import Scenario
from bracekit.validate.compliance_check import ValidationReport, check_compliance, first_order_state
from bracekit.validate.inputs import FORCE_DIRECTIONS, _configurations, _positive, _scenario
from bracekit.validate.table import _rel_err, _stats, aligned, fmt_rel

__all__ = ["DEFAULT_STIFFNESSES", "EnvironmentRow", "EnvironmentValidationReport", "run_environment_validation"]

#: The environment stiffnesses checked by default (N/m): a soft pad, a firm pad, a stiff panel.
DEFAULT_STIFFNESSES = (1e3, 1e4, 1e5)


@dataclass(frozen=True)
class EnvironmentRow:
    """One k_env: the constrained model against MuJoCo and the static solve, and the references' agreement.

    Attributes:
        k_env: the environment stiffness, N/m.
        report: the load cases (:class:`~bracekit.validate.runner.ValidationReport` of the soft brace).
        softening: median over the compared cases of ‖C(k_env) w‖_L / ‖C(rigid) w‖_L − 1, the change of the
            predicted deflection that the finite stiffness makes (‖[Δp; Δθ]‖_L = ‖[Δp; L Δθ]‖).
    """

    k_env: float
    report: ValidationReport
    softening: float | None

    def to_json(self) -> dict[str, Any]:
        """k_env, counts, the constrained model's statistics, the references' agreement, softening, cases."""
        return {
            "k_env_N_per_m": self.k_env,
            "counts": self.report.counts(),
            "constrained": self.report.model_stats("constrained"),
            "mujoco_vs_static": self.report.mujoco_vs_static(),
            "softening_median": self.softening,
            "cases": self.report.cases,
        }


@dataclass
class EnvironmentValidationReport:
    """Result of :func:`run_environment_validation`: one :class:`EnvironmentRow` per k_env."""

    scenario: str
    configurations: list[list[float]]
    settings: dict[str, Any]
    rows: list[EnvironmentRow] = field(default_factory=list)

    def counts(self) -> dict[str, int]:
        """Number of cases per status over every row."""
        out: dict[str, int] = {}
        for row in self.rows:
            for k, v in row.report.counts().items():
                out[k] = out.get(k, 0) + v
        return out

    def to_json(self) -> dict[str, Any]:
        """One JSON-serialisable dict (no NaN)."""
        return {
            "scenario": self.scenario,
            "error_measure": (
                "as the rigid block: ||dx_pred - dx_ref||_L / ||dx_ref||_L, model 'constrained' with k_env; "
                "MuJoCo's contact is a spring of stiffness k_env (solref (-s, -2 sqrt(s)), s = k_env (1 - d) A, "
                "docs/validation.md)"
            ),
            "counts": self.counts(),
            "settings": self.settings,
            "configurations": self.configurations,
            "rows": [r.to_json() for r in self.rows],
        }

    def table_text(self) -> str:
        """One line per k_env: median and max error vs MuJoCo and the static solve, agreement, softening."""
        cols = (
            "k_env (N/m)",
            "median vs MuJoCo",
            "max vs MuJoCo",
            "median vs static",
            "MuJoCo vs static",
            "change vs rigid",
        )
        rows = []
        for r in self.rows:
            st, ms = r.report.model_stats("constrained"), r.report.mujoco_vs_static()
            rows.append(
                (
                    f"{r.k_env:g}",
                    fmt_rel(st["median_rel_err_mujoco"]),
                    fmt_rel(st["max_rel_err_mujoco"]),
                    fmt_rel(st["median_rel_err_static"]),
                    fmt_rel(ms["median_rel_err"]),
                    fmt_rel(r.softening),
                )
            )
        cnt = self.counts()
        head = [
            f"Finite surface stiffness: constrained compliance with k_env, scenario '{self.scenario}'",
            f"{len(self.configurations)} configuration(s); {cnt.get('ok', 0)} cases compared, "
            f"{cnt.get('contact_opened', 0)} with the contact opened, {cnt.get('failed', 0)} failed "
            "(MuJoCo: soft contact of stiffness k_env; static: penalty contact)",
            "",
        ]
        fails = [
            f"  k_env {r.k_env:g}, config {c['config']}, {c['label']}: {c['message']}"
            for r in self.rows
            for c in r.report.cases
            if c["status"] == "failed"
        ]
        return "\n".join([*head, *aligned(cols, rows, left=()), *fails])


def _softening(soft: BracedRobot, rigid: BracedRobot, report: ValidationReport) -> float | None:
    """Median of ‖C(k_env) w‖_L / ‖C(rigid) w‖_L − 1 over the compared cases (the first-order predictions)."""
    values: list[float | None] = []
    by_config: dict[int, tuple[Any, Any, float]] = {}
    for c in report.cases:
        if c["status"] != "ok":
            continue
        i = int(c["config"])
        if i not in by_config:
            q = np.asarray(report.configurations[i], dtype=float)
            by_config[i] = (
                end_effector_compliance(first_order_state(soft, q), "constrained"),
                end_effector_compliance(first_order_state(rigid, q), "constrained"),
                float(c["length_scale_m"]),
            )
        c_soft, c_rigid, length = by_config[i]
        w = np.asarray(c["wrench"], dtype=float)
        err = _rel_err(c_soft @ w, c_rigid @ w, length)  # ‖Δ_soft − Δ_rigid‖ / ‖Δ_rigid‖
        values.append(err)
    return _stats(values)[0]


def _with_stiffness(braced: BracedRobot, k_env: float | None) -> BracedRobot:
    """The same robot with every brace's surface of stiffness k_env (None: rigid)."""
    return BracedRobot(braced.robot, [replace(b, environment_stiffness=k_env) for b in braced.braces])


def run_environment_validation(
    scenario: Scenario | str | os.PathLike[str],
    configs: int | Sequence[ArrayLike] = 3,
    *,
    stiffnesses: Sequence[float] = DEFAULT_STIFFNESSES,
    force: float = 0.5,
    preload: float = 1.0,
    max_steps: int = 100_000,
    progress: Callable[[int], None] | None = None,
) -> EnvironmentValidationReport:
    """The constrained compliance with each k_env against MuJoCo's soft contact and the penalty static solve.

    Args:
        scenario: a Scenario, a shipped name or a TOML path (one brace or several, of contact types MuJoCo
            models; every brace's own k_env, if any, is replaced by each of ``stiffnesses``).
        configs: number of configurations (:func:`~bracekit.validate.runner.validation_configurations`) or
            the configurations themselves.
        stiffnesses: the k_env values, N/m (each > 0).
        force: magnitude of each load (the pure-force directions of the rigid block), N.
        preload: contact force P before loading, N (both references press the soft surface in by P/k_env).
        max_steps: MuJoCo step budget per case.
        progress: called with 1 after each case.

    Raises:
        InputError: bad scenario, configs, stiffnesses or loads.
    """
    sc = _scenario(scenario)
    ks = [_positive(k, "each environment stiffness", "N/m") for k in stiffnesses]
    qs = _configurations(sc, configs)
    rigid = _with_stiffness(sc.braced, None)
    report = EnvironmentValidationReport(
        scenario=sc.name,
        configurations=[np.asarray(q, dtype=float).tolist() for q in qs],
        settings={"stiffnesses_N_per_m": ks, "force_N": force, "preload_N": preload, "directions": "pure forces"},
    )
    for k in ks:
        soft = _with_stiffness(sc.braced, k)
        rep = check_compliance(
            soft,
            qs,
            name=sc.name,
            force=force,
            moment=force,  # unused: pure-force directions
            preload=preload,
            directions=FORCE_DIRECTIONS,
            max_steps=max_steps,
            progress=progress,
        )
        report.rows.append(EnvironmentRow(k_env=k, report=rep, softening=_softening(soft, rigid, rep)))
    return report
