"""bracekit's named numerical tolerances, in one place. Dimensionless unless a unit is given."""

from __future__ import annotations

#: σ_min / σ_max below which a Jacobian is treated as singular by the measures (k of eq:manip is unbounded).
MEASURE_SINGULAR_RATIO = 1e-12
#: σ_min / σ_max of A (or J) below which a resolution step is reported as singular (eq:general_inv).
STEP_SINGULAR_RATIO = 1e-9
#: Condition number of J1 beyond which eq:q1 (J1⁻¹ H) is not used: chain 1 is singular.
J1_COND_LIMIT = 1e8
#: Relative singular value of Xᵀ J1 below which a chain-1 motion is counted in its null space.
NULL_SPACE_RTOL = 1e-10
#: Relative eigenvalue of Xᵀ C1 X (against tr C1) below which the contact carries no load in that direction.
UNLOADED_TOL = 1e-10
#: Largest condition number for which the fused step's and the batch's shortcuts are used (else the reference).
CERTIFIED_COND = 1e3
#: Residual (m, rad) at which the Gauss–Newton pose/contact correction stops.
CORRECTION_TOL = 1e-12
#: A correction whose residual stops falling (round-off) is accepted below this (m, rad).
ACCEPT_TOL = 1e-10
