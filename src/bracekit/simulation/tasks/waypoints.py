"""Piecewise-linear tasks: waypoints reached at given times, and the straight line."""

from __future__ import annotations

from dataclasses import dataclass
from typing import cast

import numpy as np
from numpy.typing import ArrayLike

from bracekit._linalg import as_array, as_number, show
from bracekit.errors import InputError, ScenarioError
from bracekit.simulation.tasks.base import Array, TaskShape, TaskTable, register_task, rotation_matrix, task_time, vec3

__all__ = ["Line", "Waypoints"]


@dataclass(frozen=True, eq=False)
class Waypoints:
    """Piecewise-linear path through `points` (k×3, m) reached at `times` (k,, s, increasing, first 0)."""

    points: Array
    times: Array
    rotation: Array | None = None

    def __post_init__(self) -> None:
        p = as_array(self.points, "waypoints (a list of [x, y, z] points, m)", (-1, 3))
        if p.shape[0] < 2:
            raise InputError(f"waypoints must be at least two [x, y, z] points (m), got {p.shape[0]}")
        with np.errstate(all="ignore"):
            steps = np.diff(p, axis=0)
        if not np.all(np.isfinite(steps)):
            raise InputError("waypoints are too far apart for float64; give points of moderate size (m)")
        t = as_array(self.times, "waypoint times (s)", (-1,))
        if t.size != p.shape[0] or t[0] != 0.0 or np.any(np.diff(t) <= 0):
            raise InputError(
                f"waypoint times must start at 0, increase strictly and match the {p.shape[0]} points, got {show(t)}"
            )
        object.__setattr__(self, "points", p)
        object.__setattr__(self, "times", t)
        object.__setattr__(self, "rotation", rotation_matrix(self.rotation))

    @property
    def duration(self) -> float:
        """Length of the task, s."""
        return float(self.times[-1])

    def _segment(self, t: float) -> int:
        return int(np.clip(np.searchsorted(self.times, t, side="right") - 1, 0, self.times.size - 2))

    def position(self, t: float) -> Array:
        """Desired tip position p_d(t) (3,), m, world frame."""
        t = float(np.clip(task_time(t), 0.0, self.duration))
        i = self._segment(t)
        s = (t - self.times[i]) / (self.times[i + 1] - self.times[i])
        return cast(Array, self.points[i] + s * (self.points[i + 1] - self.points[i]))

    def velocity(self, t: float) -> Array:
        """Desired tip velocity ṗ_d(t) (3,), m/s, world frame."""
        t = task_time(t)
        if t < 0.0 or t > self.duration:
            return np.zeros(3)
        i = self._segment(t)
        return cast(Array, (self.points[i + 1] - self.points[i]) / (self.times[i + 1] - self.times[i]))


def Line(start: ArrayLike, end: ArrayLike, duration: float, rotation: ArrayLike | None = None) -> Waypoints:
    """A straight line from `start` to `end` (m) at constant speed over `duration` s."""
    length = as_number(duration, "line duration", positive=True, unit="s")
    return Waypoints(
        np.vstack([vec3(start, "line start (m)"), vec3(end, "line end (m)")]),
        np.array([0.0, length]),
        None if rotation is None else rotation_matrix(rotation),
    )


@register_task
class WaypointsShape(TaskShape):
    """``type = "waypoints"``: points (k×3, m) and times (k, s)."""

    kind = "waypoints"
    keys = ("points", "times")

    @classmethod
    def from_table(cls, table: TaskTable) -> Waypoints:
        """The waypoints of a scenario's ``[task]``."""
        points = table.points("points")
        times = table.vector("times")
        if times.size != len(points) or times[0] != 0.0 or np.any(np.diff(times) <= 0):
            raise ScenarioError(
                f"'task.times' must start at 0, increase strictly and give one time per point ({len(points)}), "
                f"got {show(times.tolist())}"
            )
        return Waypoints(points, times)


@register_task
class LineShape(TaskShape):
    """``type = "line"``: start, end (m) and duration (s)."""

    kind = "line"
    keys = ("start", "end", "duration")

    @classmethod
    def from_table(cls, table: TaskTable) -> Waypoints:
        """The line of a scenario's ``[task]``."""
        return Line(table.vector("start", 3), table.vector("end", 3), table.number("duration", positive=True))
