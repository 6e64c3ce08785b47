"""Physical validation of the first-order compliance models (``bracekit validate``): the checks' public names.

The checks live one per module (compliance_check, preloaded_check, holding_report, capacity_report,
preload_study; inputs and table hold what they share); this module gathers their entry points.

For a few configurations of a scenario's braced path and a set of small tip wrenches w, the tip deflection
predicted by each first-order model, Δx_pred = C w, is compared with two independent references:

* MuJoCo (:func:`~bracekit.validate.mujoco_check.mujoco_static_deflection`): spring-jointed chain, unilateral
  frictionless sphere contact, the contact preloaded with a force P, settled quasi-statically;
* the nonlinear static equilibrium (:func:`~bracekit.validate.statics.solve_static_equilibrium`) with the
  same preload and a unilateral contact (``bilateral=False``).

Models: ``constrained`` (C_e with the Lagrange-multiplier C̃1), ``projection`` (C_e with the paper's
(I − P) C1 (I − P)) and ``free_space`` (J K⁻¹ Jᵀ, the unbraced robot).

Error measure. Δx = [Δp; Δθ] mixes metres and radians, so both deflections are compared in the weighted
norm ‖Δx‖_L = ‖[Δp; L·Δθ]‖ (m), L = ‖e − b‖ the lever from the brace point to the tip at the configuration
(a rotation of the tip by Δθ about the brace moves the tip by about L·Δθ). The relative error is
‖Δx_pred − Δx_ref‖_L / ‖Δx_ref‖_L. Units: wrench [f; m] in N and N·m, deflections in m and rad, world axes.

:func:`run_preloaded_validation` compares the preloaded compliance (tangent stiffness of gravity and the
preload) and the ``constrained`` model with both references loaded about the gravity-loaded, preloaded
equilibrium; :func:`run_capacity_validation` compares bracekit's lift-off and slip scales with those MuJoCo
shows under a slow load ramp and with the nonlinear statics' scales.

A case whose contact opens under the load (either reference ends with no contact force) is reported with
status ``contact_opened`` and kept out of the error statistics: the first-order braced models assume a
closed contact. A case where MuJoCo or the static solve fails is reported with status ``failed`` and the
message, and the run goes on. Statistics are ``None`` (never NaN) when no case contributes.
"""

from __future__ import annotations

from bracekit.validate.capacity_report import CapacityValidationReport, run_capacity_validation
from bracekit.validate.compliance_check import ValidationReport, check_compliance, first_order_state, run_validation
from bracekit.validate.holding_report import HoldingValidationReport, run_holding_validation
from bracekit.validate.inputs import (
    DEFAULT_DIRECTIONS,
    FORCE_DIRECTIONS,
    MODELS,
    MUJOCO_SETTINGS,
    path_samples,
    validation_configurations,
)
from bracekit.validate.preload_series import preload_study
from bracekit.validate.preloaded_check import (
    PRELOADED_MODELS,
    PreloadedValidationReport,
    preloaded_tip_compliance,
    run_preloaded_validation,
)
from bracekit.validate.table import fmt_rel

__all__ = [
    "DEFAULT_DIRECTIONS",
    "FORCE_DIRECTIONS",
    "MODELS",
    "MUJOCO_SETTINGS",
    "PRELOADED_MODELS",
    "CapacityValidationReport",
    "HoldingValidationReport",
    "PreloadedValidationReport",
    "ValidationReport",
    "check_compliance",
    "first_order_state",
    "fmt_rel",
    "path_samples",
    "preload_study",
    "preloaded_tip_compliance",
    "run_capacity_validation",
    "run_holding_validation",
    "run_preloaded_validation",
    "run_validation",
    "validation_configurations",
]
