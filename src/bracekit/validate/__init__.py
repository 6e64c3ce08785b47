"""Physics references for validating the compliance models: first-order Lagrange compliance,
nonlinear static equilibrium (Pinocchio) and a MuJoCo simulation of the braced chain."""

from .mujoco_check import (
    MujocoResult,
    MujocoValidationError,
    build_mujoco_model,
    mujoco_static_deflection,
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
    "build_mujoco_model",
    "frame_jacobian_derivative",
    "lagrange_compliance",
    "mujoco_static_deflection",
    "preload_rest_configuration",
    "solve_static_equilibrium",
]
