"""Physics references for the compliance models (``bracekit validate``; needs ``pip install bracekit[validate]``).

The first-order Lagrange (KKT) compliance, the nonlinear static equilibrium of N ≥ 1 contacts (Pinocchio), a
MuJoCo model of the braced chain, the checks that compare bracekit's models with both (one module each), and
:func:`~bracekit.validate.suite.run_checks`, which runs every check that applies to a scenario.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from bracekit.validate.capacity_check import CapacityRamp, mujoco_capacity_ramp, static_capacity_scale
    from bracekit.validate.environment_check import EnvironmentValidationReport, run_environment_validation
    from bracekit.validate.holding_check import HoldingCase, HoldingCheck, mujoco_holding_check
    from bracekit.validate.mujoco_check import (
        MujocoResult,
        MujocoValidationError,
        build_mujoco_model,
        mujoco_static_deflection,
    )
    from bracekit.validate.plane_contact import PlaneContact
    from bracekit.validate.preload_series import preload_study
    from bracekit.validate.runner import (
        CapacityValidationReport,
        HoldingValidationReport,
        PreloadedValidationReport,
        ValidationReport,
        check_compliance,
        run_capacity_validation,
        run_holding_validation,
        run_preloaded_validation,
        run_validation,
        validation_configurations,
    )
    from bracekit.validate.statics import (
        StaticResult,
        StaticSolveError,
        frame_jacobian_derivative,
        lagrange_compliance,
        preload_rest_configuration,
        solve_static_equilibrium,
        solve_statics,
    )
    from bracekit.validate.suite import ValidationSuite, run_checks
    from bracekit.validate.tracking import TrackingPoint, TrackingReport, TrackingStrategy, run_tracking_validation
    from bracekit.validate.verdict import Verdict, validation_verdict

#: Each exported name → the module that defines it, imported when the name is first used (PEP 562): importing
#: one module of the package (``bracekit.validate.mujoco_check``) no longer imports every check.
_EXPORTS = {
    "CapacityRamp": "bracekit.validate.capacity_check",
    "mujoco_capacity_ramp": "bracekit.validate.capacity_check",
    "static_capacity_scale": "bracekit.validate.capacity_check",
    "EnvironmentValidationReport": "bracekit.validate.environment_check",
    "run_environment_validation": "bracekit.validate.environment_check",
    "HoldingCase": "bracekit.validate.holding_check",
    "HoldingCheck": "bracekit.validate.holding_check",
    "mujoco_holding_check": "bracekit.validate.holding_check",
    "MujocoResult": "bracekit.validate.mujoco_check",
    "MujocoValidationError": "bracekit.validate.mujoco_check",
    "build_mujoco_model": "bracekit.validate.mujoco_check",
    "mujoco_static_deflection": "bracekit.validate.mujoco_check",
    "PlaneContact": "bracekit.validate.plane_contact",
    "CapacityValidationReport": "bracekit.validate.runner",
    "HoldingValidationReport": "bracekit.validate.runner",
    "PreloadedValidationReport": "bracekit.validate.runner",
    "ValidationReport": "bracekit.validate.runner",
    "check_compliance": "bracekit.validate.runner",
    "preload_study": "bracekit.validate.preload_series",
    "run_capacity_validation": "bracekit.validate.runner",
    "run_holding_validation": "bracekit.validate.runner",
    "run_preloaded_validation": "bracekit.validate.runner",
    "run_validation": "bracekit.validate.runner",
    "validation_configurations": "bracekit.validate.runner",
    "StaticResult": "bracekit.validate.statics",
    "StaticSolveError": "bracekit.validate.statics",
    "frame_jacobian_derivative": "bracekit.validate.statics",
    "lagrange_compliance": "bracekit.validate.statics",
    "preload_rest_configuration": "bracekit.validate.statics",
    "solve_static_equilibrium": "bracekit.validate.statics",
    "solve_statics": "bracekit.validate.statics",
    "ValidationSuite": "bracekit.validate.suite",
    "run_checks": "bracekit.validate.suite",
    "TrackingPoint": "bracekit.validate.tracking",
    "TrackingReport": "bracekit.validate.tracking",
    "TrackingStrategy": "bracekit.validate.tracking",
    "run_tracking_validation": "bracekit.validate.tracking",
    "Verdict": "bracekit.validate.verdict",
    "validation_verdict": "bracekit.validate.verdict",
}


__all__ = [
    "CapacityRamp",
    "CapacityValidationReport",
    "EnvironmentValidationReport",
    "HoldingCase",
    "HoldingCheck",
    "HoldingValidationReport",
    "MujocoResult",
    "MujocoValidationError",
    "PlaneContact",
    "PreloadedValidationReport",
    "StaticResult",
    "StaticSolveError",
    "TrackingPoint",
    "TrackingReport",
    "TrackingStrategy",
    "ValidationReport",
    "ValidationSuite",
    "Verdict",
    "build_mujoco_model",
    "check_compliance",
    "frame_jacobian_derivative",
    "lagrange_compliance",
    "mujoco_capacity_ramp",
    "mujoco_holding_check",
    "mujoco_static_deflection",
    "preload_rest_configuration",
    "preload_study",
    "run_capacity_validation",
    "run_checks",
    "run_environment_validation",
    "run_holding_validation",
    "run_preloaded_validation",
    "run_tracking_validation",
    "run_validation",
    "solve_static_equilibrium",
    "solve_statics",
    "static_capacity_scale",
    "validation_configurations",
    "validation_verdict",
]


def __getattr__(name: str) -> Any:
    """The exported `name`, its module imported on first use."""
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'bracekit.validate' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__})
