"""End-effector tasks: the Task protocol, the registry of task shapes the scenario parser reads, shared helpers.

A task gives the desired tip pose (position, rotation) and twist [v; ω] at time t (s). A task *shape* is one
file of this package: a class with a ``kind`` (the scenario's ``[task] type``), the ``keys`` it reads from
``[task]`` and ``from_table`` (the task from those keys), registered with :func:`register_task`. A shape that
has a radial direction (``radial(t)``, a unit vector) can measure C_i along it (``beta_x = "radial"``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, ClassVar, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from bracekit._linalg import as_array, as_number
from bracekit._registry import Registry
from bracekit.errors import InputError

Array = NDArray[np.float64]

__all__ = ["TASK_SHAPES", "Task", "TaskShape", "TaskTable", "in_plane", "register_task"]


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
        """Desired tip position at t (3,), m, world; may be read-only (a shape keeping its values): copy to change."""
        ...

    def velocity(self, t: float) -> Array:
        """Desired tip velocity at t (3,), m/s, world; may be read-only, as :meth:`position`."""
        ...


class TaskTable(Protocol):
    """What a shape reads its ``[task]`` keys through (the scenario parser's table: typed, with clear errors)."""

    def has(self, name: str) -> bool:
        """Whether the key is given."""
        ...

    def number(self, name: str, default: Any = ..., positive: bool = False) -> float:
        """A number (ScenarioError naming the key otherwise)."""
        ...

    def vector(self, name: str, size: int | None = None, default: Any = ...) -> Array:
        """A list of numbers."""
        ...

    def points(self, name: str, width: int = 3) -> Array:
        """A list of points (k×width)."""
        ...


class TaskShape:
    """A task shape the scenario parser knows: subclass it (one file), set ``kind`` and ``keys``, register it."""

    #: The scenario's ``[task] type`` of this shape.
    kind: ClassVar[str] = ""
    #: The ``[task]`` keys it reads.
    keys: ClassVar[tuple[str, ...]] = ()

    @classmethod
    def from_table(cls, table: TaskTable) -> Task:
        """The task from its ``[task]`` keys."""
        raise NotImplementedError


#: ``[task] type`` → shape, filled by :func:`register_task`.
TASK_SHAPES: Registry[type[TaskShape]] = Registry("task shape", "kind", "kind")
#: Class decorator: make a task shape available to scenarios under its ``kind``.
register_task = TASK_SHAPES.register


def radial_of(task: object) -> Callable[[float], Array] | None:
    """The task's radial direction r̂(t) (3,) if its shape has one (a circle), else None."""
    radial = getattr(task, "radial", None)
    return radial if callable(radial) else None


def vec3(v: ArrayLike, what: str) -> Array:
    a = as_array(v, what).reshape(-1)
    if a.size != 3:
        raise InputError(f"{what} must be 3 finite numbers, got {a.size}")
    return a


def rotation_matrix(r: ArrayLike | None) -> Array | None:
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


def task_time(t: float) -> float:
    """A time (s) as a float; InputError unless it is a finite number."""
    return t if type(t) is float and math.isfinite(t) else as_number(t, "the time t", unit="s")
