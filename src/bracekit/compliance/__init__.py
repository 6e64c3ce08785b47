"""Compliance of the braced robot (Section IV) and the kinematic measures of Section V.

``first_order``: C1, C2, C̃1 (constrained | projection), C_e, the free-space compliance, directional compliance,
C_i and ellipsoids. ``directional``: c_t (translational, m/N) and β_xᵀCβ_w beside the paper's C_i.
``stiffness``: the tool's 6×6 stiffness, first order or preloaded, in a chosen frame. ``preloaded``: the
constrained model with the preload's geometric stiffness. ``measures``:
k, Πσ, σ_min, θ_z and the region barrier d. ``batch``: C_e, C_i and k over arrays of configurations.
"""

from bracekit.compliance.directional import DirectionalCompliances, directional_compliances, translational_compliance
from bracekit.compliance.first_order import (
    C1,
    C2,
    COMPLIANCE_MODELS,
    ComplianceEllipsoids,
    ComplianceModel,
    Ellipsoid,
    braced_C1,
    compliance_ellipsoids,
    compliance_index,
    directional_compliance,
    end_effector_compliance,
    free_space_compliance,
)
from bracekit.compliance.measures import (
    SingularValues,
    frobenius_condition,
    region_barrier,
    singular_value_measures,
    theta_z,
)
from bracekit.compliance.preloaded import preloaded_compliance
from bracekit.compliance.stiffness import ToolStiffness, tool_stiffness

__all__ = [
    "C1",
    "C2",
    "COMPLIANCE_MODELS",
    "ComplianceEllipsoids",
    "ComplianceModel",
    "DirectionalCompliances",
    "Ellipsoid",
    "SingularValues",
    "ToolStiffness",
    "braced_C1",
    "compliance_ellipsoids",
    "compliance_index",
    "directional_compliance",
    "directional_compliances",
    "end_effector_compliance",
    "free_space_compliance",
    "frobenius_condition",
    "preloaded_compliance",
    "region_barrier",
    "singular_value_measures",
    "theta_z",
    "tool_stiffness",
    "translational_compliance",
]
