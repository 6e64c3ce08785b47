"""The kinematic simulation's public names in one place (Section VI): run, start, correction, trajectory.

The code lives by job: :mod:`bracekit.simulation.loop` (the step loop), :mod:`~bracekit.simulation.start`,
:mod:`~bracekit.simulation.correction`, :mod:`~bracekit.simulation.guards`, :mod:`~bracekit.simulation.samples`
(the per-sample measures), :mod:`~bracekit.simulation.notes` and :mod:`~bracekit.simulation.trajectory`.
"""

from bracekit.simulation.correction import contact_jacobian, contact_residual, correct, pose_error, reach, task_error
from bracekit.simulation.guards import joint_step_bound
from bracekit.simulation.loop import simulate
from bracekit.simulation.samples import Sample, Samples, measure
from bracekit.simulation.start import START_THETA_WEIGHT, solve_start
from bracekit.simulation.trajectory import Trajectory

__all__ = [
    "START_THETA_WEIGHT",
    "Sample",
    "Samples",
    "Trajectory",
    "contact_jacobian",
    "contact_residual",
    "correct",
    "joint_step_bound",
    "measure",
    "pose_error",
    "reach",
    "simulate",
    "solve_start",
    "task_error",
]
