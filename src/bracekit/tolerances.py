"""bracekit's named numerical tolerances, in one place. Dimensionless unless a unit is given."""

from __future__ import annotations

import math

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
#: Residual at which the Gauss–Newton pose/contact correction stops, relative to the robot's reach (lengths)
#: and to 1 rad (angles).
CORRECTION_TOL = 1e-12
#: A correction whose relative residual stops falling (round-off) is accepted below this.
ACCEPT_TOL = 1e-10
#: A correction residual within this many round-offs of its scale (eps · √n · max(1, ‖q‖∞) · ‖Jacobian‖) is converged.
CORRECTION_ROUNDOFF = 16.0
#: σ_min / σ_max of J1 (inverted when n1 = 6), of A or J (pseudo-inverted) or of J̃ below which a run stops at a
#: sample (condition number 1e6: well before the step's own limits, STEP_SINGULAR_RATIO and J1_COND_LIMIT).
PATH_SINGULAR_RATIO = 1e-6
#: σ_min / σ_max below which a run's stop message says that a joint jump passes near a singularity.
NEAR_SINGULAR_RATIO = 1e-3
#: ... or the fraction of its value at the run's start below which it says so (a contact's A can sit at 5e-3).
NEAR_SINGULAR_DROP = 0.1
#: A joint may move at most this many times (velocity limit × dt) between two samples of a run.
JOINT_STEP_SAFETY = 2.0
#: Joint speed (rad/s; m/s for a prismatic joint) assumed where the URDF gives no velocity limit (0 or inf).
DEFAULT_JOINT_SPEED = math.pi
#: Largest joint motion between two samples whatever dt and the limits (rad): a wrist flip (±π) is always caught.
MAX_JOINT_STEP = math.pi / 2
#: Most integration steps one simulated run may take (a task's duration / dt).
MAX_STEPS = 100_000
