"""Physics references for the compliance models (``bracekit validate``; needs ``pip install bracekit[validate]``).

The first-order Lagrange (KKT) compliance, the nonlinear static equilibrium (Pinocchio), a MuJoCo model of the
braced chain, and the runner that compares the first-order models with both.
"""

from bracekit.validate.holding_check import HoldingCase, HoldingCheck, mujoco_holding_check
from bracekit.validate.mujoco_check import (
    MujocoResult,
    MujocoValidationError,
    build_mujoco_model,
    mujoco_static_deflection,
)
from bracekit.validate.runner import (
    HoldingValidationReport,
    ValidationReport,
    preload_study,
    run_holding_validation,
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

__all__ = [
    "HoldingCase",
    "HoldingCheck",
    "HoldingValidationReport",
    "MujocoResult",
    "MujocoValidationError",
    "StaticResult",
    "StaticSolveError",
    "ValidationReport",
    "build_mujoco_model",
    "frame_jacobian_derivative",
    "lagrange_compliance",
    "mujoco_holding_check",
    "mujoco_static_deflection",
    "preload_rest_configuration",
    "preload_study",
    "run_holding_validation",
    "run_validation",
    "solve_static_equilibrium",
    "validation_configurations",
]
