"""Physics references for the compliance models (``bracekit validate``; needs ``pip install bracekit[validate]``).

The first-order Lagrange (KKT) compliance, the nonlinear static equilibrium of N ≥ 1 contacts (Pinocchio), a
MuJoCo model of the braced chain, the checks that compare bracekit's models with both (one module each), and
:func:`~bracekit.validate.suite.run_checks`, which runs every check that applies to a scenario.
"""

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
from bracekit.validate.runner import (
    CapacityValidationReport,
    HoldingValidationReport,
    PreloadedValidationReport,
    ValidationReport,
    check_compliance,
    preload_study,
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
