"""End-effector tasks: desired pose (position, rotation) and twist [v; ω] at time t (s)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from bracekit.errors import InputError
from bracekit.spatial import unit

Array = NDArray[np.float64]


class Task(Protocol):
    """A time-parameterised end-effector path; the orientation is held at ``rotation``.

    ``rotation`` None means: hold the orientation the tip has at the start configuration.
    """

    duration: float
    rotation: Array | None

    def position(self, t: float) -> Array:
        """Desired tip position at t (3,), m, world."""
        ...

    def velocity(self, t: float) -> Array:
        """Desired tip velocity at t (3,), m/s, world."""
        ...


def _vec3(v: ArrayLike, what: str) -> Array:
    a = np.asarray(v, dtype=float).reshape(-1)
    if a.size != 3 or not np.all(np.isfinite(a)):
        raise InputError(f"{what} must be 3 finite numbers, got {a.tolist()}")
    return a


def _rotation(r: ArrayLike | None) -> Array | None:
    if r is None:
        return None
    m = np.asarray(r, dtype=float).reshape(3, 3)
    if not np.allclose(m.T @ m, np.eye(3), atol=1e-8) or np.linalg.det(m) < 0:
        raise InputError("task rotation must be a proper 3×3 rotation matrix")
    return m


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

    def __post_init__(self) -> None:
        object.__setattr__(self, "centre", _vec3(self.centre, "circle centre"))
        for name in ("radius", "period", "turns"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise InputError(f"circle {name} must be a positive number, got {value}")
        try:
            n = unit(_vec3(self.normal, "circle normal"), "circle normal")
            s = _vec3(self.start_direction, "circle start direction")
        except ValueError as exc:
            raise InputError(str(exc)) from exc
        u = s - n * (n @ s)
        if np.linalg.norm(u) < 1e-9:
            raise InputError("circle start direction is parallel to its normal; give a direction in the plane")
        u /= np.linalg.norm(u)
        object.__setattr__(self, "normal", n)
        object.__setattr__(self, "start_direction", u)
        object.__setattr__(self, "rotation", _rotation(self.rotation))
        object.__setattr__(self, "_u", u)
        object.__setattr__(self, "_w", np.cross(n, u))

    @property
    def duration(self) -> float:
        """Time of the whole task, s."""
        return self.period * self.turns

    def angle(self, t: float) -> float:
        """Angle along the circle at t, rad."""
        return 2.0 * np.pi * t / self.period

    def position(self, t: float) -> Array:
        a = self.angle(t)
        return self.centre + self.radius * (np.cos(a) * self._u + np.sin(a) * self._w)

    def velocity(self, t: float) -> Array:
        a, om = self.angle(t), 2.0 * np.pi / self.period
        return self.radius * om * (-np.sin(a) * self._u + np.cos(a) * self._w)

    def radial(self, t: float) -> Array:
        """Unit vector from the centre to the desired point at t (3,)."""
        a = self.angle(t)
        return np.cos(a) * self._u + np.sin(a) * self._w


@dataclass(frozen=True, eq=False)
class Waypoints:
    """Piecewise-linear path through `points` (k×3, m) reached at `times` (k,, s, increasing, first 0)."""

    points: Array
    times: Array
    rotation: Array | None = None

    def __post_init__(self) -> None:
        p = np.asarray(self.points, dtype=float)
        t = np.asarray(self.times, dtype=float).reshape(-1)
        if p.ndim != 2 or p.shape[1] != 3 or p.shape[0] < 2 or not np.all(np.isfinite(p)):
            raise InputError("waypoints must be a list of at least two [x, y, z] points (m)")
        if t.size != p.shape[0] or t[0] != 0.0 or np.any(np.diff(t) <= 0) or not np.all(np.isfinite(t)):
            raise InputError("waypoint times must start at 0, increase strictly and match the points")
        object.__setattr__(self, "points", p)
        object.__setattr__(self, "times", t)
        object.__setattr__(self, "rotation", _rotation(self.rotation))

    @property
    def duration(self) -> float:
        return float(self.times[-1])

    def _segment(self, t: float) -> int:
        return int(np.clip(np.searchsorted(self.times, t, side="right") - 1, 0, self.times.size - 2))

    def position(self, t: float) -> Array:
        t = float(np.clip(t, 0.0, self.duration))
        i = self._segment(t)
        s = (t - self.times[i]) / (self.times[i + 1] - self.times[i])
        return self.points[i] + s * (self.points[i + 1] - self.points[i])

    def velocity(self, t: float) -> Array:
        if t < 0.0 or t > self.duration:
            return np.zeros(3)
        i = self._segment(t)
        return (self.points[i + 1] - self.points[i]) / (self.times[i + 1] - self.times[i])


def Line(start: ArrayLike, end: ArrayLike, duration: float, rotation: ArrayLike | None = None) -> Waypoints:
    """A straight line from `start` to `end` (m) at constant speed over `duration` s."""
    if not (np.isfinite(duration) and duration > 0):
        raise InputError(f"line duration must be a positive number of seconds, got {duration}")
    return Waypoints(
        np.vstack([_vec3(start, "line start"), _vec3(end, "line end")]),
        np.array([0.0, float(duration)]),
        None if rotation is None else np.asarray(rotation, dtype=float),
    )
