"""Run a cobot scenario: the braced start, then every strategy's closed loop, and the numbers of each."""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from bracekit.cobot.config import CobotScenario, load_cobot
from bracekit.cobot.loop import CobotRun, run_strategy
from bracekit.cobot.report import summary
from bracekit.simulation.start import solve_start

__all__ = ["CobotResult", "run_cobot"]


@dataclass
class CobotResult:
    """Every strategy's run and its numbers (``summaries``, in the scenario's order)."""

    scenario: CobotScenario
    q0: np.ndarray
    runs: list[CobotRun]
    summaries: list[dict[str, Any]]

    def to_json(self) -> dict[str, Any]:
        """summary.json: the scenario's settings and the numbers per strategy."""
        sc = self.scenario
        return {
            "scenario": sc.name,
            "base_scenario": sc.base.name,
            "seed": sc.seed,
            "control_rate_Hz": sc.rate,
            "physics_dt_s": sc.physics_dt,
            "preload_N": sc.preload,
            "friction": sc.friction,
            "servo_damping_time_s": sc.damping_time,
            "operator": {
                "stiffness_N_per_m": sc.operator.stiffness,
                "damping_Ns_per_m": sc.operator.damping,
                "targets_m": sc.operator.targets.tolist(),
            },
            "process_wrench": sc.process.wrench.tolist(),
            "q0": self.q0.tolist(),
            "strategies": self.summaries,
        }


def run_cobot(
    scenario: CobotScenario | str | os.PathLike[str], progress: Callable[[str], None] | None = None
) -> CobotResult:
    """Solve the braced start of the base scenario and run each strategy's closed loop (deterministic)."""
    sc = scenario if isinstance(scenario, CobotScenario) else load_cobot(scenario)
    b = sc.base
    start = solve_start(
        b.braced, b.task.position(0.0), b.guess, rotation=b.task.rotation, theta_weight=b.start_theta_weight,
        space=b.task_space,
    )  # fmt: skip
    runs, rows = [], []
    for name in sc.strategies:
        if progress is not None:
            progress(name)
        clock = time.perf_counter()
        run = run_strategy(sc, name, start.q)
        runs.append(run)
        rows.append(summary(sc, run, time.perf_counter() - clock))
    return CobotResult(sc, start.q.copy(), runs, rows)
