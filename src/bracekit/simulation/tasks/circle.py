"""A circle task: the paper's shape (Section VI), with a radial direction for β_x = "radial"."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import cast

import numpy as np

from bracekit._linalg import as_number
from bracekit.errors import InputError, NumericalError, ScenarioError
from bracekit.simulation.tasks.base import (
    Array,
    TaskShape,
    TaskTable,
    in_plane,
    register_task,
    rotation_matrix,
    task_time,
    vec3,
)
from bracekit.spatial import unit

__all__ = ["MEMO_SIZE", "Circle"]

#: Times a circle keeps p_d, ṗ_d or r̂ of before it forgets that one's (about 7 MB at most for the three).
MEMO_SIZE = 12_000


@dataclass(frozen=True, eq=False)
class Circle:
    """A circle of `radius` (m) about `centre` in the plane with unit normal `normal`, one turn per `period` s.

    The start point is centre + radius·û where û is `start_direction` projected into the plane.
    Runs for `turns` turns; counter-clockwise about `normal`.
    """

    centre: Array
    radius: float
    normal: Array
    period: float
    start_direction: Array
    rotation: Array | None = None
    turns: float = 1.0
    _u: Array = field(init=False, repr=False)
    _w: Array = field(init=False, repr=False)
    #: p_d, ṗ_d and r̂ by float time t (read-only arrays; float keys, so the garbage collector does not track
    #: them): the runs of one scenario take them at the same times; each cleared past MEMO_SIZE entries
    _memo: tuple[dict[float, Array], ...] = field(init=False, repr=False, default_factory=lambda: ({}, {}, {}))

    def __post_init__(self) -> None:
        object.__setattr__(self, "centre", vec3(self.centre, "circle centre (m)"))
        for name, unit_name in (("radius", "m"), ("period", "s"), ("turns", "")):
            as_number(getattr(self, name), f"circle {name}", positive=True, unit=unit_name)
        speed = 2.0 * math.pi * float(self.radius) / float(self.period)
        if not (math.isfinite(speed) and math.isfinite(float(self.period) * float(self.turns))):
            raise InputError(f"circle of radius {self.radius:g} m and period {self.period:g} s is beyond float64 range")
        n = unit(vec3(self.normal, "circle normal"), "circle normal")
        u = in_plane(n, vec3(self.start_direction, "circle start direction"))
        if u is None:
            raise InputError("circle start direction is parallel to its normal; give a direction in the plane")
        object.__setattr__(self, "normal", n)
        object.__setattr__(self, "start_direction", u)
        object.__setattr__(self, "rotation", rotation_matrix(self.rotation))
        object.__setattr__(self, "_u", u)
        object.__setattr__(self, "_w", np.cross(n, u))
        for name in ("centre", "normal", "start_direction", "rotation", "_u", "_w"):  # what the kept values are of
            value = getattr(self, name)
            if isinstance(value, np.ndarray):
                value = value.copy()
                value.flags.writeable = False
                object.__setattr__(self, name, value)

    def __getstate__(self) -> dict[str, object]:
        """The fields without what the circle kept (a pickled circle, e.g. sent to a worker, starts empty)."""
        return {**self.__dict__, "_memo": ({}, {}, {})}

    def __setstate__(self, state: dict[str, object]) -> None:
        self.__dict__.update(state)

    @property
    def duration(self) -> float:
        """Time of the whole task, s."""
        return self.period * self.turns

    def angle(self, t: float) -> float:
        """Angle along the circle at t, rad."""
        a = 2.0 * np.pi * task_time(t) / self.period
        if not math.isfinite(a):
            raise NumericalError(f"the circle's angle at t = {t:g} s overflows float64")
        return a

    def _kept(self, what: int, t: float, compute: Callable[[float], Array]) -> Array:
        """compute(t), kept in memo `what` where t is a float (a read-only array: every caller gets the same one)."""
        if type(t) is not float:
            return compute(t)
        memo = self._memo[what]
        found = memo.get(t)
        if found is None:
            if len(memo) >= MEMO_SIZE:
                memo.clear()
            found = memo[t] = compute(t)
            found.flags.writeable = False
        return found

    def position(self, t: float) -> Array:
        """Desired tip position p_d(t) (3,), m, world frame (read-only)."""
        return self._kept(0, t, self._position)

    def velocity(self, t: float) -> Array:
        """Desired tip velocity ṗ_d(t) (3,), m/s, world frame (read-only)."""
        return self._kept(1, t, self._velocity)

    def radial(self, t: float) -> Array:
        """Unit vector from the centre to the desired point at t (3,) (read-only)."""
        return self._kept(2, t, self._radial)

    def _position(self, t: float) -> Array:
        a = self.angle(t)
        return cast(Array, self.centre + self.radius * (np.cos(a) * self._u + np.sin(a) * self._w))

    def _velocity(self, t: float) -> Array:
        a, om = self.angle(t), 2.0 * np.pi / self.period
        return cast(Array, self.radius * om * (-np.sin(a) * self._u + np.cos(a) * self._w))

    def _radial(self, t: float) -> Array:
        a = self.angle(t)
        return cast(Array, np.cos(a) * self._u + np.sin(a) * self._w)


@register_task
class CircleShape(TaskShape):
    """``type = "circle"``: centre, radius, normal, start_direction, period, turns."""

    kind = "circle"
    keys = ("centre", "radius", "normal", "start_direction", "period", "turns")

    @classmethod
    def from_table(cls, table: TaskTable) -> Circle:
        """The circle of a scenario's ``[task]``."""
        normal = unit(table.vector("normal", 3), "'task.normal'", ScenarioError)
        start = table.vector("start_direction", 3)
        if in_plane(normal, start) is None:
            raise ScenarioError(
                "'task.start_direction' is parallel to 'task.normal'; give a direction in the circle's plane"
            )
        return Circle(
            centre=table.vector("centre", 3),
            radius=table.number("radius", positive=True),
            normal=table.vector("normal", 3),
            period=table.number("period", positive=True),
            start_direction=start,
            turns=table.number("turns", 1.0, positive=True),
        )
