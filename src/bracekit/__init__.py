"""bracekit: kinematics, compliance and redundancy resolution of serial robots under bracing constraints.

Johnston, Orekhov, Simaan, "Kinematic Modeling and Compliance Modulation of Redundant Manipulators
Under Bracing Constraints", ICRA 2020, in Python on Pinocchio. Walk the package in the paper's order:
robot → contact → kinematics → compliance → measures → objective → resolution → simulate → run.
"""

from .batch import BatchEvaluation, BatchEvaluator, evaluate_batch
from .compliance import (
    C1,
    C2,
    braced_C1,
    compliance_ellipsoids,
    compliance_index,
    directional_compliance,
    end_effector_compliance,
    free_space_compliance,
)
from .contact import FRICTIONLESS_POINT, POINT_WITH_FRICTION, SOFT_FINGER, Brace, Contact, Surface
from .errors import (
    BarrierError,
    BracekitError,
    BracekitWarning,
    ContactError,
    ConvergenceError,
    FrameNotFoundError,
    InputError,
    JointLimitWarning,
    ModelError,
    NumericalError,
    RegionWarning,
    ScenarioError,
    SingularityError,
    UnloadedContactWarning,
)
from .fast import GradientProjectionStep
from .kinematics import BracedRobot, BracedState
from .measures import frobenius_condition, region_barrier, singular_value_measures, theta_z
from .models import load_model
from .objective import (
    BraceAngle,
    ComplianceIndex,
    ConditionNumber,
    Objective,
    RegionBarrier,
    braced_gradient,
    finite_difference_gradient,
)
from .resolution import BracedGradientProjection, BracedMinNorm, FreeSpaceMinNorm
from .robot import Robot
from .run import RunResult, run_scenario
from .scenario import Scenario, load_scenario
from .simulate import Trajectory, simulate, solve_start
from .study import BraceCandidate, brace_location_study
from .tasks import Circle, Line, Waypoints

__version__ = "0.1.0"

__all__ = [
    "C1",
    "C2",
    "FRICTIONLESS_POINT",
    "POINT_WITH_FRICTION",
    "SOFT_FINGER",
    "BarrierError",
    "BatchEvaluation",
    "BatchEvaluator",
    "Brace",
    "BraceAngle",
    "BraceCandidate",
    "BracedGradientProjection",
    "BracedMinNorm",
    "BracedRobot",
    "BracedState",
    "BracekitError",
    "BracekitWarning",
    "Circle",
    "ComplianceIndex",
    "ConditionNumber",
    "Contact",
    "ContactError",
    "ConvergenceError",
    "FrameNotFoundError",
    "FreeSpaceMinNorm",
    "GradientProjectionStep",
    "InputError",
    "JointLimitWarning",
    "Line",
    "ModelError",
    "NumericalError",
    "Objective",
    "RegionBarrier",
    "RegionWarning",
    "Robot",
    "RunResult",
    "Scenario",
    "ScenarioError",
    "SingularityError",
    "Surface",
    "Trajectory",
    "UnloadedContactWarning",
    "Waypoints",
    "brace_location_study",
    "braced_C1",
    "braced_gradient",
    "compliance_ellipsoids",
    "compliance_index",
    "directional_compliance",
    "end_effector_compliance",
    "evaluate_batch",
    "finite_difference_gradient",
    "free_space_compliance",
    "frobenius_condition",
    "load_model",
    "load_scenario",
    "region_barrier",
    "run_scenario",
    "simulate",
    "singular_value_measures",
    "solve_start",
    "theta_z",
]
