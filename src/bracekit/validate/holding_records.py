"""The records of the MuJoCo holding check: the first-order prediction of every brace and what MuJoCo did.

:class:`Prediction` holds each brace's lift-off and slip scale of a tool wrench w and names the first brace to
fail; :class:`HoldingCheck` is one check (one configuration, one wrench), :class:`HoldingCase` one scale s of
it, :class:`BraceForce` one brace's contact force there, MuJoCo against first order (N, world axes, on the robot
at b_i). Built by :func:`~bracekit.validate.holding_check.mujoco_holding_check`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Literal, NamedTuple

import numpy as np

from bracekit._forward import Forward
from bracekit.statics import ContactResponse, ContactResponses
from bracekit.validate.inputs import Array

__all__ = ["BraceForce", "HoldingCase", "HoldingCheck", "Outcome", "Prediction"]

Outcome = Literal["held", "slipped", "lifted_off"]


@dataclass(frozen=True, eq=False)
class BraceForce:
    """One brace's contact force in MuJoCo against the first-order prediction for one scaled wrench s·w.

    Attributes:
        predicted_force: force part of f_c0,i + s δf_c,i (3,), N, world axes, on the robot at b_i.
        mujoco_force: MuJoCo's force of plane i on its sphere (3,), N, world axes (zeros if the contact opened).
        predicted_normal, mujoco_normal: n̂_iᵀ f (N, > 0 pressing).
        predicted_tangential, mujoco_tangential: ‖(I − n̂_i n̂_iᵀ) f‖ (N).
        cone_ratio: ‖f_t‖ / (μ f_n) in MuJoCo (None without μ or with the contact open).
        slip_displacement: tangential displacement of the material point b_i, settled loaded − unloaded (m).
        outcome: what MuJoCo did at this brace: ``held``, ``slipped`` or ``lifted_off``.
    """

    predicted_force: Array
    mujoco_force: Array
    predicted_normal: float
    mujoco_normal: float
    predicted_tangential: float
    mujoco_tangential: float
    cone_ratio: float | None
    slip_displacement: float
    outcome: Outcome

    def to_json(self) -> dict[str, Any]:
        """JSON-able dict."""
        return {
            "predicted_force_N": self.predicted_force.tolist(),
            "mujoco_force_N": self.mujoco_force.tolist(),
            "predicted_normal_N": self.predicted_normal,
            "mujoco_normal_N": self.mujoco_normal,
            "predicted_tangential_N": self.predicted_tangential,
            "mujoco_tangential_N": self.mujoco_tangential,
            "cone_ratio": self.cone_ratio,
            "slip_displacement_m": self.slip_displacement,
            "outcome": self.outcome,
        }


@dataclass(frozen=True, eq=False)
class HoldingCase:
    """MuJoCo against the first-order prediction for one scaled wrench s·w, every brace.

    Attributes:
        scale: s (dimensionless multiplier of the wrench).
        fraction: s / predicted margin (None when the margin is infinite).
        wrench: s·w (6,), [f; m] at the tip, world axes (N, N·m).
        braces: one :class:`BraceForce` per brace, in order.
        focus: the brace predicted to fail first (the one the check's margin is of).
        rel_err: ‖F_mujoco − F_pred‖ / ‖F_pred‖ over the stacked contact forces of every brace, where MuJoCo
            held every brace and bracekit predicts holding, else None.
        rel_err_change: ‖F_mujoco − F_pred‖ / ‖s δF_c(w)‖, the error of the load's effect (same cases).
        torque_rel_err: ‖τ_mujoco − τ_pred‖ / ‖τ_pred‖, τ_mujoco = K (q_s − q), on the same cases, else None.
        outcome: what MuJoCo did: ``lifted_off`` when a brace lifted off, else ``slipped`` when one slipped,
            else ``held``.
        failed_braces: the braces that lifted off or slipped in MuJoCo.
        expected: what the prediction requires at this fraction (``held`` below HOLD_BELOW; above FAIL_ABOVE the
            first-order state of the brace predicted to fail first), None in between.
        agrees: below HOLD_BELOW every brace held; above FAIL_ABOVE the brace predicted to fail first failed the
            way its own lift-off band allows (either failure near its lift-off scale); None in between.
        settled: the loaded state met the settling tolerance (a slipping contact may keep sliding).
        steps: MuJoCo steps of the loaded phase.
    """

    scale: float
    fraction: float | None
    wrench: Array
    braces: tuple[BraceForce, ...]
    focus: int
    rel_err: float | None
    rel_err_change: float | None
    torque_rel_err: float | None
    outcome: Outcome
    failed_braces: tuple[int, ...]
    expected: Outcome | None
    agrees: bool | None
    settled: bool
    steps: int

    def to_json(self) -> dict[str, Any]:
        """JSON-able dict (no NaN: missing numbers are None): the focus brace's forces, then every brace's."""
        return {
            "scale": self.scale,
            "fraction_of_margin": self.fraction,
            "wrench": self.wrench.tolist(),
            **self.braces[self.focus].to_json(),
            "brace": self.focus,
            "rel_err": self.rel_err,
            "rel_err_change": self.rel_err_change,
            "torque_rel_err": self.torque_rel_err,
            "outcome": self.outcome,
            "failed_braces": list(self.failed_braces),
            "expected": self.expected,
            "agrees": self.agrees,
            "settled": self.settled,
            "steps": self.steps,
            "braces": [b.to_json() for b in self.braces],
        }


@dataclass(frozen=True, eq=False)
class HoldingCheck:
    """Result of :func:`mujoco_holding_check` at one configuration for one tool wrench w, every brace.

    Attributes:
        q: the commanded configuration (n,), rad.
        wrench: w (6,), N and N·m, world axes, at the tip.
        preloads: P_i of each brace (N). friction: μ or None. gravity: whether gravity was on.
        prediction: the first-order limits of every brace (:class:`Prediction`).
        unloaded_forces: MuJoCo's settled contact force of each brace without load (B×3), N, world axes.
        cases: one :class:`HoldingCase` per scale.
        settle_time: the damping time constant τ (s of simulated time); timestep: s.
    """

    q: Array
    wrench: Array
    preloads: tuple[float, ...]
    friction: float | None
    gravity: bool
    prediction: Prediction
    unloaded_forces: Array
    settle_time: float
    timestep: float
    cases: list[HoldingCase] = field(default_factory=list)

    brace = Forward[int]("prediction", "The brace predicted to fail first.")
    margin = Forward[float]("prediction", "The predicted scale of w at which the first brace fails (inf: never).")
    mode = Forward[Outcome | None]("prediction", "The predicted failure, ``lifted_off`` or ``slipped`` (None: never).")

    @property
    def liftoff_margin(self) -> float:
        """The predicted scale of w at which the first brace lifts off (inf: never)."""
        return float(np.min(self.prediction.liftoff))

    @property
    def slip_margin(self) -> float | None:
        """The predicted scale of w at which the first brace slips (inf: never; None without μ)."""
        return None if self.prediction.slip is None else float(np.min(self.prediction.slip))

    @property
    def unloaded_normal_rel_err(self) -> float | None:
        """The largest |f_n,i − P_i| / P_i over the preloaded braces without load (None: no preload)."""
        n = self.prediction.responses.normals
        errs = [
            abs(float(f @ ni) - p) / p for f, ni, p in zip(self.unloaded_forces, n, self.preloads, strict=True) if p
        ]
        return max(errs) if errs else None

    @property
    def unloaded_tangential(self) -> float:
        """The largest ‖f_t,i‖ without load in MuJoCo (N; the prediction is 0)."""
        n = self.prediction.responses.normals
        return max(float(np.linalg.norm(f - (f @ ni) * ni)) for f, ni in zip(self.unloaded_forces, n, strict=True))

    @property
    def creep(self) -> float:
        """Largest tangential displacement of a b_i over the cases MuJoCo held (m): the soft contact's creep."""
        held = [b.slip_displacement for c in self.cases if c.outcome == "held" for b in c.braces]
        return max(held) if held else 0.0

    def to_json(self) -> dict[str, Any]:
        """JSON-able dict (infinite margins as None): the focus brace's margins, then every brace's."""
        pred, i = self.prediction, self.brace
        return {
            "q": self.q.tolist(),
            "wrench": self.wrench.tolist(),
            "preload_N": self.preloads[i],
            "preloads_N": list(self.preloads),
            "friction": self.friction,
            "gravity": self.gravity,
            "brace": i,
            "liftoff_margin": _finite(self.liftoff_margin),
            "slip_margin": None if self.slip_margin is None else _finite(self.slip_margin),
            "margin": _finite(self.margin),
            "mode": self.mode,
            "brace_liftoff_margins": [_finite(float(x)) for x in pred.liftoff],
            "brace_slip_margins": None if pred.slip is None else [_finite(float(x)) for x in pred.slip],
            "unloaded_force_N": self.unloaded_forces[i].tolist(),
            "unloaded_forces_N": self.unloaded_forces.tolist(),
            "unloaded_normal_rel_err": self.unloaded_normal_rel_err,
            "unloaded_tangential_N": self.unloaded_tangential,
            "creep_m": self.creep,
            "settle_time_s": self.settle_time,
            "timestep_s": self.timestep,
            "cases": [c.to_json() for c in self.cases],
        }


class Prediction(NamedTuple):
    """The first-order limits of every brace at q under a tool wrench w (scales of w, dimensionless).

    Attributes:
        responses: the preloaded equilibrium of every brace at q and its load response (one configuration).
        liftoff: the scale at which brace i lifts off (B,), inf: never.
        slip: the scale at which brace i slips (B,), inf for a brace without μ; None when no brace has μ.
    """

    responses: ContactResponses
    liftoff: Array
    slip: Array | None

    @property
    def limits(self) -> Array:
        """The first failure scale of each brace (B,): the lesser of lift-off and slip."""
        return self.liftoff if self.slip is None else np.minimum(self.liftoff, self.slip)

    @property
    def brace(self) -> int:
        """The brace that fails first (the one with the least limit)."""
        return int(np.argmin(self.limits))

    @property
    def margin(self) -> float:
        """The scale at which the first brace lifts off or slips (inf: none does)."""
        return float(np.min(self.limits))

    @property
    def mode(self) -> Outcome | None:
        """How the first brace fails (None: no brace fails at any scale)."""
        if not np.isfinite(self.margin):
            return None
        return "lifted_off" if self.liftoff[self.brace] <= self.margin else "slipped"

    def response(self, brace: int) -> ContactResponse:
        """Brace ``brace``'s view of the response."""
        return self.responses.at(0, brace)


def _finite(x: float) -> float | None:
    return float(x) if np.isfinite(x) else None
