"""End-effector tasks (one file per shape) and their registry: circle, line, waypoints."""

from bracekit.simulation.tasks.base import TASK_SHAPES, Task, TaskShape, TaskTable, in_plane, radial_of, register_task

# isort: off
# registration: the order of the scenario's [task] type choices
from bracekit.simulation.tasks.circle import Circle
from bracekit.simulation.tasks.waypoints import Line, Waypoints

# isort: on

__all__ = [
    "TASK_SHAPES",
    "Circle",
    "Line",
    "Task",
    "TaskShape",
    "TaskTable",
    "Waypoints",
    "in_plane",
    "radial_of",
    "register_task",
]
