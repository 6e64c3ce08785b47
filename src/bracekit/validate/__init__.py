"""Physics references for validating the compliance models: first-order Lagrange compliance,
nonlinear static equilibrium (Pinocchio), a MuJoCo simulation of the braced chain, and the validation
runner that compares the first-order models with both (``bracekit validate``)."""

from .mujoco_check import (
    MujocoResult,
    MujocoValidationError,
    build_mujoco_model,
    mujoco_static_deflection,
)
from .runner import (
    ValidationReport,
    figure_preload,
    figure_validation,
    preload_study,
    preloaded_compliance,
    run_validation,
    validation_configurations,
)
from .statics import (
    StaticResult,
    StaticSolveError,
    frame_jacobian_derivative,
    lagrange_compliance,
    preload_rest_configuration,
    solve_static_equilibrium,
)

__all__ = [
    "MujocoResult",
    "MujocoValidationError",
    "StaticResult",
    "StaticSolveError",
    "ValidationReport",
    "build_mujoco_model",
    "figure_preload",
    "figure_validation",
    "frame_jacobian_derivative",
    "lagrange_compliance",
    "mujoco_static_deflection",
    "preload_rest_configuration",
    "preload_study",
    "preloaded_compliance",
    "run_validation",
    "solve_static_equilibrium",
    "validation_configurations",
]
