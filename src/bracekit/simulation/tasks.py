"""End-effector tasks: desired pose (position, rotation) and twist [v; ω] at time t (s)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from bracekit._linalg import as_array, as_number, show
from bracekit.errors import InputError, NumericalError
from bracekit.spatial import unit

Array = NDArray[np.float64]


class Task(Protocol):
    """A time-parameterised end-effector path; the orientation is held at ``rotation``.

    ``rotation`` None means: hold the orientation the tip has at the start configuration.
    """

    @property
    def duration(self) -> float:
        """Time of the whole task, s."""
        ...

    @property
    def rotation(self) -> Array | None:
        """Tip orientation held along the task (3×3, world), or None."""
        ...

    def position(self, t: float) -> Array:
        """Desired tip position at t (3,), m, world."""
        ...

    def velocity(self, t: float) -> Array:
        """Desired tip velocity at t (3,), m/s, world."""
        ...


def _vec3(v: ArrayLike, what: str) -> Array:
    a = as_array(v, what).reshape(-1)
    if a.size != 3:
        raise InputError(f"{what} must be 3 finite numbers, got {a.size}")
    return a


def _rotation(r: ArrayLike | None) -> Array | None:
    if r is None:
        return None
    m = as_array(r, "the task rotation", (3, 3))
    if not (float(np.max(np.abs(m))) <= 1.0 + 1e-8 and np.allclose(m.T @ m, np.eye(3), atol=1e-8)) or (
        np.linalg.det(m) < 0
    ):
        raise InputError("the task rotation must be a proper 3×3 rotation matrix (RᵀR = I, det 1)")
    return m


def in_plane(n: Array, s: Array) -> Array | None:
    """The unit part of `s` orthogonal to the unit normal `n`; None when `s` is (nearly) parallel to `n`.

    `s` of extreme size (beyond 1e±100) is scaled first, so that its norm stays in float64.
    """
    big = float(np.max(np.abs(s)))
    if big > 0.0 and not 1e-100 <= big <= 1e100:
        s = s / big
    u = s - n * (n @ s)
    size = np.linalg.norm(u)
    return None if size < 1e-9 else u / size


def _time(t: float) -> float:
    """A time (s) as a float; InputError unless it is a finite number."""
    return t if type(t) is float and math.isfinite(t) else as_number(t, "the time t", unit="s")


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
        object.__setattr__(self, "centre", _vec3(self.centre, "circle centre (m)"))
        for name, unit_name in (("radius", "m"), ("period", "s"), ("turns", "")):
            as_number(getattr(self, name), f"circle {name}", positive=True, unit=unit_name)
        speed = 2.0 * math.pi * float(self.radius) / float(self.period)
        if not (math.isfinite(speed) and math.isfinite(float(self.period) * float(self.turns))):
            raise InputError(f"circle of radius {self.radius:g} m and period {self.period:g} s is beyond float64 range")
        n = unit(_vec3(self.normal, "circle normal"), "circle normal")
        u = in_plane(n, _vec3(self.start_direction, "circle start direction"))
        if u is None:
            raise InputError("circle start direction is parallel to its normal; give a direction in the plane")
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
        a = 2.0 * np.pi * _time(t) / self.period
        if not math.isfinite(a):
            raise NumericalError(f"the circle's angle at t = {t:g} s overflows float64")
        return a

    def position(self, t: float) -> Array:
        """Desired tip position p_d(t) (3,), m, world frame."""
        a = self.angle(t)
        return self.centre + self.radius * (np.cos(a) * self._u + np.sin(a) * self._w)

    def velocity(self, t: float) -> Array:
        """Desired tip velocity ṗ_d(t) (3,), m/s, world frame."""
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
        object.__setattr__(self, "rotation", _rotation(self.rotation))

    @property
    def duration(self) -> float:
        """Length of the task, s."""
        return float(self.times[-1])

    def _segment(self, t: float) -> int:
        return int(np.clip(np.searchsorted(self.times, t, side="right") - 1, 0, self.times.size - 2))

    def position(self, t: float) -> Array:
        """Desired tip position p_d(t) (3,), m, world frame."""
        t = float(np.clip(_time(t), 0.0, self.duration))
        i = self._segment(t)
        s = (t - self.times[i]) / (self.times[i + 1] - self.times[i])
        return self.points[i] + s * (self.points[i + 1] - self.points[i])

    def velocity(self, t: float) -> Array:
        """Desired tip velocity ṗ_d(t) (3,), m/s, world frame."""
        t = _time(t)
        if t < 0.0 or t > self.duration:
            return np.zeros(3)
        i = self._segment(t)
        return (self.points[i + 1] - self.points[i]) / (self.times[i + 1] - self.times[i])


def Line(start: ArrayLike, end: ArrayLike, duration: float, rotation: ArrayLike | None = None) -> Waypoints:
    """A straight line from `start` to `end` (m) at constant speed over `duration` s."""
    length = as_number(duration, "line duration", positive=True, unit="s")
    return Waypoints(
        np.vstack([_vec3(start, "line start (m)"), _vec3(end, "line end (m)")]),
        np.array([0.0, length]),
        None if rotation is None else _rotation(rotation),
    )
