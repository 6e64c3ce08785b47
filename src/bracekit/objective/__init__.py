"""The objective g of eq:objective: a base class and one file per term, each owning all of its maths.

Adding a term: a new file with a :class:`Term` subclass decorated with ``@register_term`` (its weight key in
scenarios) and its import below (the registration line). The solvers need no change: the fused step and the
numba kernel use the term's fused methods when it has them and its reference ``value``/``gradient`` otherwise.
"""

from bracekit.objective.base import (
    TERMS,
    Objective,
    Term,
    TermContext,
    braced_gradient,
    central_difference,
    finite_difference_gradient,
    register_term,
)

# isort: off
# registration, in the order of eq:objective (α1 k, α2 C_i with c_t beside it, α3 θ_z, α4 d), then further terms
# (joint limits, joint-limit barrier, brace margin, link clearance, braced conditioning): the order of the sum g
from bracekit.objective.condition_number import ConditionNumber
from bracekit.objective.compliance_index import ComplianceIndex
from bracekit.objective.translational_compliance import TranslationalCompliance
from bracekit.objective.brace_angle import BraceAngle
from bracekit.objective.region_barrier import RegionBarrier
from bracekit.objective.joint_limits import JointLimits
from bracekit.objective.joint_limit_barrier import JointLimitBarrier
from bracekit.objective.brace_margin import BraceMargin
from bracekit.objective.clearance import ClearanceBarrier
from bracekit.objective.braced_conditioning import BracedConditioning

# isort: on

__all__ = [
    "TERMS",
    "BraceAngle",
    "BraceMargin",
    "BracedConditioning",
    "ClearanceBarrier",
    "ComplianceIndex",
    "ConditionNumber",
    "JointLimitBarrier",
    "JointLimits",
    "Objective",
    "RegionBarrier",
    "Term",
    "TermContext",
    "TranslationalCompliance",
    "braced_gradient",
    "central_difference",
    "finite_difference_gradient",
    "register_term",
]
