"""bracekit inside pink: tasks and barriers for ``pink.solve_ik`` (extra ``[pink]``: pin-pink ≥ 4.4).

* :class:`BraceTask`: keeps every brace point on its surface, X_iᵀ J_b_i Δq = −X_iᵀ ρ_i (eq:constraint); give it
  to ``solve_ik(..., constraints=[...])`` for a hard equality (pink ≥ 4.4), or to ``tasks`` for a weighted one.
* :class:`ComplianceTask`: lowers the compliance index C_i along β_x (eq:compliance_index) through its
  analytic gradient, a linear cost of the QP.
* :class:`BraceRegionBarrier`: keeps each brace point inside its bracing region (r_i < r_max,i).
* :class:`LinkClearanceBarrier`: keeps the links clear of the bracing surfaces (kinematics.clearance).
* :class:`BraceMarginBarrier`: keeps the brace holding each listed tool wrench (the BraceMargin term's residuals).

The configuration is pink's ``Configuration`` over the braced robot's Pinocchio model
(``braced.robot.model``, revolute and prismatic joints: q and Δq have the same size).
"""

from __future__ import annotations

try:
    import pink as _pink  # noqa: F401
except ImportError as exc:  # pragma: no cover - the extra is missing
    from bracekit.errors import MissingDependencyError

    raise MissingDependencyError("bracekit.pink needs pin-pink: pip install 'bracekit[pink]'") from exc

from bracekit.pink.barriers import BraceMarginBarrier, BraceRegionBarrier, LinkClearanceBarrier
from bracekit.pink.tasks import BraceTask, ComplianceTask

__all__ = ["BraceMarginBarrier", "BraceRegionBarrier", "BraceTask", "ComplianceTask", "LinkClearanceBarrier"]
