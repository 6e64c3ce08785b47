"""bracekit: kinematics, compliance and redundancy resolution of serial robots under bracing constraints.

Johnston, Orekhov, Simaan, "Kinematic Modeling and Compliance Modulation of Redundant Manipulators
Under Bracing Constraints", ICRA 2020, in Python on Pinocchio. The subpackages follow the paper:
model → contact → kinematics → compliance → objective → resolution → simulation → studies / validate →
report → cli. This module holds what a user calls; everything else is reachable from its subpackage (the
state and the terms from ``bracekit.kinematics`` and ``bracekit.objective``, the fused step from
``bracekit.resolution``, ``Trajectory`` from ``bracekit.simulation``).
"""

from bracekit import _numba_cache  # noqa: F401  (first: numba's cache directory, before numba is imported)
from bracekit._version import __version__
from bracekit.compliance import (
    compliance_ellipsoids,
    compliance_index,
    directional_compliance,
    end_effector_compliance,
    free_space_compliance,
    frobenius_condition,
    preloaded_compliance,
    singular_value_measures,
    theta_z,
)
from bracekit.compliance.batch import evaluate_batch
from bracekit.contact import Brace, Surface, contact_type
from bracekit.errors import BracekitError, BracekitWarning, InputError, NumericalError
from bracekit.kinematics import BracedRobot
from bracekit.model import Robot, load_model
from bracekit.objective import ComplianceIndex, ConditionNumber, Objective, RegionBarrier
from bracekit.resolution import (
    BracedGradientProjection,
    BracedMinNorm,
    FreeSpaceMinNorm,
    TaskSpace,
)
from bracekit.simulation import (
    Circle,
    Holding,
    Line,
    RunResult,
    Scenario,
    Waypoints,
    load_scenario,
    run_scenario,
    simulate,
    solve_start,
)
from bracekit.statics import actuator_relief, capacity_along, contact_response, load_capacity
from bracekit.studies import brace_location_study, evaluate

__all__ = [
    "Brace",
    "BracedGradientProjection",
    "BracedMinNorm",
    "BracedRobot",
    "BracekitError",
    "BracekitWarning",
    "Circle",
    "ComplianceIndex",
    "ConditionNumber",
    "FreeSpaceMinNorm",
    "Holding",
    "InputError",
    "Line",
    "NumericalError",
    "Objective",
    "RegionBarrier",
    "Robot",
    "RunResult",
    "Scenario",
    "Surface",
    "TaskSpace",
    "Waypoints",
    "__version__",
    "actuator_relief",
    "brace_location_study",
    "capacity_along",
    "compliance_ellipsoids",
    "compliance_index",
    "contact_response",
    "contact_type",
    "directional_compliance",
    "end_effector_compliance",
    "evaluate",
    "evaluate_batch",
    "free_space_compliance",
    "frobenius_condition",
    "load_capacity",
    "load_model",
    "load_scenario",
    "preloaded_compliance",
    "run_scenario",
    "simulate",
    "singular_value_measures",
    "solve_start",
    "theta_z",
]
