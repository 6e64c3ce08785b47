"""Physics references for the compliance models (``bracekit validate``; needs ``pip install bracekit[validate]``).

The first-order Lagrange (KKT) compliance, the nonlinear static equilibrium (Pinocchio), a MuJoCo model of the
braced chain, and the runner that compares the first-order models with both.
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
from bracekit.validate.runner import (
    CapacityValidationReport,
    HoldingValidationReport,
    PreloadedValidationReport,
    ValidationReport,
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
)
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
    "PreloadedValidationReport",
    "StaticResult",
    "StaticSolveError",
    "TrackingPoint",
    "TrackingReport",
    "TrackingStrategy",
    "ValidationReport",
    "Verdict",
    "build_mujoco_model",
    "frame_jacobian_derivative",
    "lagrange_compliance",
    "mujoco_capacity_ramp",
    "mujoco_holding_check",
    "mujoco_static_deflection",
    "preload_rest_configuration",
    "preload_study",
    "run_capacity_validation",
    "run_environment_validation",
    "run_holding_validation",
    "run_preloaded_validation",
    "run_tracking_validation",
    "run_validation",
    "solve_static_equilibrium",
    "static_capacity_scale",
    "validation_configurations",
    "validation_verdict",
]
