"""Kinematic simulation along a task (Section VI): tasks, the integrator, scenario files and the whole run."""

from bracekit.simulation.holding import Holding
from bracekit.simulation.run import RunResult, run_scenario
from bracekit.simulation.scenario import load_scenario, shipped_scenarios
from bracekit.simulation.scenario_model import Scenario
from bracekit.simulation.simulate import Trajectory, simulate, solve_start
from bracekit.simulation.tasks import Circle, Line, Task, Waypoints

__all__ = [
    "Circle",
    "Holding",
    "Line",
    "RunResult",
    "Scenario",
    "Task",
    "Trajectory",
    "Waypoints",
    "load_scenario",
    "run_scenario",
    "shipped_scenarios",
    "simulate",
    "solve_start",
]
