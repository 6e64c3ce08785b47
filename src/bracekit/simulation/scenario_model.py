"""The validated scenario: the braced robot, the task, the compliance model and the strategies' settings."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import cast

import numpy as np
from numpy.typing import NDArray

from bracekit._linalg import show
from bracekit.compliance.first_order import ComplianceModel
from bracekit.compliance.preloaded import simulated_model
from bracekit.errors import InputError
from bracekit.kinematics import BracedRobot
from bracekit.model.robot import Robot
from bracekit.objective import TERMS, Objective, TermContext
from bracekit.resolution.qp import BracedQP
from bracekit.resolution.strategies import (
    BracedGradientProjection,
    BracedMinNorm,
    FreeSpaceMinNorm,
    GradientMode,
    Strategy,
)
from bracekit.resolution.task_space import POSE, TaskSpace
from bracekit.simulation.holding import Holding
from bracekit.simulation.tasks import Task

Array = NDArray[np.float64]
STRATEGIES = ("free_space_min_norm", "braced_min_norm", "braced_gradient_projection", "braced_qp")
#: The strategies a scenario runs when it names none.
DEFAULT_STRATEGIES = STRATEGIES[:3]
#: The strategies that descend the objective (run once per compliance model).
OPTIMISING = ("braced_gradient_projection", "braced_qp")

__all__ = ["DEFAULT_STRATEGIES", "OPTIMISING", "STRATEGIES", "Scenario", "weight_keys"]


def weight_keys() -> tuple[str, ...]:
    """The weight keys of ``[gradient_projection.weights]``: one per registered objective term, now."""
    return tuple(TERMS)


@dataclass(frozen=True, eq=False)
class Scenario:
    """A validated scenario. Lengths in m, times in s, stiffness in N·m/rad.

    ``start_theta_weight`` is the start solve's θ_z weight ('[start] theta_weight'; 0 without a pad axis).
    """

    name: str
    braced: BracedRobot
    task: Task
    guess: Array
    compliance_model: str
    beta_x: Callable[[float], Array]
    beta_x_spec: str
    alpha: float
    weights: dict[str, float]
    gradient: GradientMode
    dt: float
    strategies: tuple[str, ...]
    feedback_gain: float = 1.0
    description: str = ""
    source: Path | None = None
    task_space: TaskSpace = POSE
    start_theta_weight: float = 0.0
    holding: Holding = field(default_factory=Holding)

    @property
    def robot(self) -> Robot:
        """The robot."""
        return self.braced.robot

    def objective(self, model: ComplianceModel | None = None, beta_x: Array | None = None) -> Objective:
        """G of eq:objective with this scenario's weights (β_x at t = 0 unless given), for any number of braces.

        A per-brace term (d, θ_z, clearance) stands for one term per brace it applies to, each with the weight.
        """
        beta = self.beta_x(0.0) if beta_x is None else beta_x
        context = TermContext(
            self.braced, beta, model or simulated_model(self.compliance_model), self.holding, self.task_space
        )
        keys = [k for k in weight_keys() if self.weights.get(k, 0.0) > 0]
        kept = [(t, self.weights[k]) for k in keys for t in TERMS[k].terms_from_scenario(context)]
        return Objective([t for t, _ in kept], [w for _, w in kept])

    def strategy(
        self, name: str, *, gradient: GradientMode | None = None, model: ComplianceModel | None = None
    ) -> Strategy:
        """One of the strategies (STRATEGIES) with this scenario's gains, task space and, for braced_qp, its dt."""
        if name not in STRATEGIES:
            raise InputError(f"unknown strategy {show(name)}; choose one of {', '.join(STRATEGIES)}")
        if name == "free_space_min_norm":
            return cast(Strategy, FreeSpaceMinNorm(space=self.task_space))
        if name == "braced_min_norm":
            return cast(Strategy, BracedMinNorm(space=self.task_space))
        if name == "braced_qp":
            mode = gradient or self.gradient
            qp = BracedQP(self.objective(model), alpha=self.alpha, gradient=mode, dt=self.dt, space=self.task_space)
            return cast(Strategy, qp)
        strategy = BracedGradientProjection(
            self.objective(model), alpha=self.alpha, gradient=gradient or self.gradient, space=self.task_space
        )
        return cast(Strategy, strategy)
