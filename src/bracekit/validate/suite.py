"""Every check of ``bracekit validate`` on one scenario, one brace or several: what runs, what is skipped and why.

:func:`run_checks` runs the blocks that apply to the scenario, in the order of the report:

* ``compliance`` (:func:`~bracekit.validate.runner.run_validation`): the first-order models against MuJoCo and
  the nonlinear static solve (every brace);
* ``preloaded`` (:func:`~bracekit.validate.runner.run_preloaded_validation`): with gravity and preloads;
* ``holding`` and ``capacity``: the contact forces, lift-off and slip of every brace in MuJoCo, with the
  scenario's holding statics, or for a scenario without any with the checks' own
  (:func:`~bracekit.validate.holding_report.default_holding`);
* ``tracking`` (:func:`~bracekit.validate.tracking.run_tracking_validation`): the strategies' runs in MuJoCo;
* ``environment_stiffness`` (:func:`~bracekit.validate.environment_check.run_environment_validation`).

A block whose MuJoCo check does not model the scenario (a brace on a compliant surface, braces with different
μ) is listed in ``skipped`` with the reason; the capacity block needs a preload and tool wrenches.
:func:`~bracekit.validate.verdict.validation_verdict` judges the result.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from bracekit.errors import InputError
from bracekit.simulation.scenario_model import Scenario
from bracekit.validate.capacity_report import CapacityValidationReport, run_capacity_validation
from bracekit.validate.compliance_check import ValidationReport, run_validation
from bracekit.validate.environment_check import EnvironmentValidationReport, run_environment_validation
from bracekit.validate.holding_check import check_determinate, check_mujoco_contacts
from bracekit.validate.holding_report import HoldingValidationReport, default_holding, run_holding_validation
from bracekit.validate.inputs import _scenario, path_samples
from bracekit.validate.preloaded_check import PreloadedValidationReport, run_preloaded_validation
from bracekit.validate.tracking import TrackingReport, run_tracking_validation
from bracekit.validate.verdict import Verdict, validation_verdict

__all__ = ["ValidationSuite", "run_checks"]


@dataclass
class ValidationSuite:
    """The reports of the checks that ran (None: not run) and the blocks skipped, with the reason."""

    compliance: ValidationReport
    preloaded: PreloadedValidationReport
    holding: HoldingValidationReport | None = None
    capacity: CapacityValidationReport | None = None
    tracking: TrackingReport | None = None
    environment: EnvironmentValidationReport | None = None
    skipped: dict[str, str] = field(default_factory=dict)

    def to_json(self) -> dict[str, Any]:
        """validation.json: the compliance block's keys, then one key per further block, and ``skipped``."""
        data = self.compliance.to_json()
        data["preloaded"] = self.preloaded.to_json()
        for key, block in (
            ("holding", self.holding),
            ("tracking", self.tracking),
            ("capacity", self.capacity),
            ("environment_stiffness", self.environment),
        ):
            if block is not None:
                data[key] = block.to_json()
        if self.skipped:
            data["skipped"] = dict(self.skipped)
        return data

    def table_text(self) -> str:
        """Every block's table, then the skipped blocks with their reasons."""
        parts = [self.compliance.table_text(), self.preloaded.table_text()]
        for block in (self.holding, self.tracking, self.capacity, self.environment):
            if block is not None:
                parts.append(block.table_text())
        parts.extend(f"{name}: not checked ({why})" for name, why in self.skipped.items())
        return "\n".join(parts)

    def verdict(self) -> Verdict:
        """The pass/fail rule (:func:`~bracekit.validate.verdict.validation_verdict`)."""
        return validation_verdict(
            self.compliance,
            self.preloaded,
            holding=self.holding,
            capacity=self.capacity,
            tracking=self.tracking,
            environment=self.environment,
        )


def run_checks(
    scenario: Scenario | str | os.PathLike[str],
    configs: int = 3,
    *,
    tracking_points: int = 5,
    progress: Callable[[int], None] | None = None,
) -> ValidationSuite:
    """Run every check that applies to the scenario (module docstring).

    Args:
        scenario: a Scenario, a shipped name or a TOML path (one brace or several).
        configs: configurations along the path (≥ 1, at most the path's samples).
        tracking_points: check points per strategy of the tracking check (0: skip it).
        progress: called with 1 after each case of the compliance block (for a progress bar).

    Raises:
        InputError: bad scenario or counts.
    """
    sc = _scenario(scenario)
    if isinstance(configs, bool) or not isinstance(configs, int) or configs < 1:
        raise InputError(f"--configs must be at least 1, got {configs}")
    if isinstance(tracking_points, bool) or not isinstance(tracking_points, int) or tracking_points < 0:
        raise InputError(f"--tracking-points must be 0 (skip) or more, got {tracking_points}")
    if configs > path_samples(sc):
        raise InputError(
            f"--configs {configs} is more than the {path_samples(sc)} samples of the path of scenario "
            f"'{sc.name}'; give at most {path_samples(sc)}"
        )
    report = run_validation(sc, configs=configs, progress=progress)
    qs = report.configurations
    suite = ValidationSuite(compliance=report, preloaded=run_preloaded_validation(sc, configs=qs))
    h = sc.holding if sc.holding.active else default_holding(sc)
    own = None if sc.holding.active else h
    try:
        check_mujoco_contacts(sc.braced, h, "holding and capacity checks")
        check_determinate(sc.braced, qs, h, "holding and capacity checks")
    except InputError as exc:
        suite.skipped["holding"] = suite.skipped["capacity"] = str(exc)
    else:
        suite.holding = run_holding_validation(sc, configs=qs, holding=own)
        if max(h.brace_preloads(len(sc.braced.braces))) > 0.0 and h.wrenches is not None:
            suite.capacity = run_capacity_validation(sc, configs=qs, holding=own)
    if tracking_points > 0:
        rigid = all(b.environment_stiffness is None for b in sc.braced.braces)
        if rigid:
            suite.tracking = run_tracking_validation(sc, points=tracking_points)
        else:
            suite.skipped["tracking"] = "the MuJoCo tracking check models rigid surfaces; a brace has a k_env"
    suite.environment = run_environment_validation(sc, configs=qs)
    return suite
