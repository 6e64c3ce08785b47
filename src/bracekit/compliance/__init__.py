"""Compliance of the braced robot (Section IV) and the kinematic measures of Section V.

``first_order``: C1, C2, C̃1 (constrained | projection), C_e, the free-space compliance, directional compliance,
C_i and ellipsoids. ``preloaded``: the constrained model with the preload's geometric stiffness. ``measures``:
k, Πσ, σ_min, θ_z and the region barrier d. ``batch``: C_e, C_i and k over arrays of configurations.
"""

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

__all__ = [
    "C1",
    "C2",
    "COMPLIANCE_MODELS",
    "ComplianceEllipsoids",
    "ComplianceModel",
    "Ellipsoid",
    "SingularValues",
    "braced_C1",
    "compliance_ellipsoids",
    "compliance_index",
    "directional_compliance",
    "end_effector_compliance",
    "free_space_compliance",
    "frobenius_condition",
    "preloaded_compliance",
    "region_barrier",
    "singular_value_measures",
    "theta_z",
]
