"""Task spaces: which rows of the tip twist [v; ω] a task prescribes, the rest left free for the objective.

* ``"pose"`` (6-D): position and orientation, S = I (the paper's task).
* ``"position"`` (3-D): the position only, S = [I₃ 0]; the orientation is free.
* ``"position+axis"`` (5-D): the position and the direction of a tool axis a = ⁰R_e a_tip; the rotation
  about a is free. S = [I₃ 0; 0 u₁ᵀ; 0 u₂ᵀ] with u₁, u₂ an orthonormal basis of the plane perpendicular
  to a at the current configuration.

A strategy resolves the selected rows: q̇ = (S J)⁺ S ẋ, [ḃ; q̇2] = (S A)⁺ S ẋ (+ the null space of S A for
gradient projection). (S A)⁺ S and the null-space projector do not depend on the basis (u₁, u₂) chosen.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from bracekit._linalg import show
from bracekit.errors import InputError
from bracekit.spatial import unit

Array = NDArray[np.float64]
SpaceKind = Literal["pose", "position", "position+axis"]
#: The task spaces, as in scenario files (``[task] space``).
TASK_SPACES: tuple[str, ...] = ("pose", "position", "position+axis")


def perpendicular_basis(a: Array) -> Array:
    """Two orthonormal rows (2×3) spanning the plane perpendicular to the unit vector `a`, right-handed with a."""
    helper = np.zeros(3)
    helper[int(np.argmin(np.abs(a)))] = 1.0
    u1 = np.cross(a, helper)
    u1 /= np.linalg.norm(u1)
    return np.vstack([u1, np.cross(a, u1)])


@dataclass(frozen=True, eq=False)
class TaskSpace:
    """The rows of the tip twist a task prescribes.

    Args:
        kind: ``"pose"`` (default), ``"position"`` or ``"position+axis"``.
        axis: the tool axis in tip coordinates (3,), only for ``"position+axis"``; the tip frame's z
            when not given. Normalised.
    """

    kind: SpaceKind = "pose"
    axis: Array | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.kind, str) or self.kind not in TASK_SPACES:
            raise InputError(f"unknown task space {show(self.kind)}; choose one of {', '.join(TASK_SPACES)}")
        if self.kind != "position+axis":
            if self.axis is not None:
                raise InputError(f"a tool axis is given only with the task space 'position+axis', not {self.kind!r}")
            return
        raw: ArrayLike = [0.0, 0.0, 1.0] if self.axis is None else self.axis
        try:
            a = np.asarray(raw, dtype=float).reshape(-1)
        except (TypeError, ValueError):
            raise InputError(f"the tool axis must be 3 numbers (tip coordinates), got {show(raw)}") from None
        big = float(np.max(np.abs(a), initial=0.0)) if a.size == 3 and np.all(np.isfinite(a)) else 0.0
        if not big > 0.0:
            raise InputError(f"the tool axis must be 3 finite numbers, not all zero (tip coordinates), got {show(raw)}")
        object.__setattr__(self, "axis", unit(a, "the tool axis (tip coordinates)"))

    @property
    def is_pose(self) -> bool:
        """Whether every row is selected (S = I)."""
        return self.kind == "pose"

    @property
    def rows(self) -> int:
        """m, the number of selected rows."""
        return {"pose": 6, "position": 3, "position+axis": 5}[self.kind]

    def world_axis(self, rotation: Array) -> Array:
        """The tool axis in world coordinates, ⁰R_e a_tip (3,), for a tip orientation `rotation` (3×3)."""
        assert self.axis is not None, "only the space 'position+axis' has a tool axis"
        return np.asarray(rotation, dtype=float) @ self.axis

    def selection(self, rotation: Array) -> Array:
        """S(⁰R_e) (m×6) at the tip orientation `rotation` (3×3); read-only and shared for the pose and position."""
        constant = _CONSTANT_SELECTION.get(self.kind)
        if constant is not None:
            return constant
        s = np.zeros((self.rows, 6))
        s[:3, :3] = np.eye(3)
        if self.kind == "pose":
            s[3:, 3:] = np.eye(3)
        elif self.kind == "position+axis":
            s[3:, 3:] = perpendicular_basis(self.world_axis(rotation))
        return s

    def error(self, position_error: Array, rotation: Array, target: Array) -> Array:
        """The task error (6,) [p_d − e; ω] of the selected rows for a desired orientation `target` (3×3).

        ``"position"``: ω = 0. ``"position+axis"``: ω = θ k̂, the rotation taking the tool axis a to the
        desired a_d = target a_tip about k̂ = a × a_d / |a × a_d| (θ = ∠(a, a_d)); its component along a is 0.
        Not used for ``"pose"`` (the pose error of the simulation is used there).
        """
        omega = np.zeros(3)
        if self.kind == "position+axis":
            a, a_d = self.world_axis(rotation), self.world_axis(target)
            k = np.cross(a, a_d)
            s = float(np.linalg.norm(k))
            if s > 0.0:
                omega = k * (np.arctan2(s, float(a @ a_d)) / s)
        return np.concatenate([position_error, omega])

    def __repr__(self) -> str:
        axis = "" if self.axis is None else f", axis={np.round(self.axis, 6).tolist()}"
        return f"TaskSpace({self.kind!r}{axis})"

    def describe(self) -> str:
        """The space as a short string: its kind, and the tool axis (tip coordinates) for 'position+axis'."""
        if self.axis is None:
            return self.kind
        return f"{self.kind} {np.round(self.axis, 6).tolist()}"


#: The full 6-D pose (the default of every strategy).
POSE = TaskSpace()


def select(space: TaskSpace, rotation: Array, m: Array, xdot: Array) -> tuple[Array, Array]:
    """(S m, S ẋ) for a Jacobian m (6×k) and a twist ẋ (6,); m and ẋ themselves for the pose space."""
    if space.is_pose:
        return m, xdot
    s = space.selection(rotation)
    return s @ m, s @ xdot


def redundancy(space: TaskSpace, rotation: Array, m: Array) -> int:
    """Dimension of the null space left by the selected rows: columns of m (6×k) − rank(S m)."""
    sm = select(space, rotation, m, np.zeros(6))[0]
    return int(m.shape[1] - np.linalg.matrix_rank(sm))


def _constant_selection(rows: int) -> Array:
    """[I_m 0] (m×6) of the pose (m = 6) or the position (m = 3), read-only."""
    s = np.eye(rows, 6)
    s.setflags(write=False)
    return s


#: S of the task spaces whose rows do not turn with the tool: one read-only array each.
_CONSTANT_SELECTION: dict[str, Array] = {"pose": _constant_selection(6), "position": _constant_selection(3)}
