"""Forward kinematics and frame Jacobians of a chain of 1-DoF joints, without Pinocchio's Data.

Pinocchio's ``Data`` holds second-order derivative tensors of n³ entries (32·n³ bytes: 0.9 GB at n = 300),
so creating one costs seconds on long chains. :class:`ChainFK` computes what the first-order model needs,
joint and frame placements and LOCAL_WORLD_ALIGNED frame Jacobians, from the model's joint placements and
axes alone, in O(n) per configuration. bracekit uses it on chains longer than :data:`DATA_JOINT_LIMIT`
and Pinocchio's own algorithms on shorter ones (tests compare the two to 1e-12).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import cast

import numpy as np
import pinocchio as pin
from numpy.typing import NDArray

Array = NDArray[np.float64]

#: Longest chain evaluated with Pinocchio's Data (about 8 MB there); longer ones use :class:`ChainFK`.
DATA_JOINT_LIMIT = 64

_AXES = {"X": (1.0, 0.0, 0.0), "Y": (0.0, 1.0, 0.0), "Z": (0.0, 0.0, 1.0)}


def joint_axis(joint: pin.JointModel) -> tuple[bool, Array] | None:
    """(revolute?, axis in the joint frame) of a 1-DoF revolute or prismatic joint; None for other joints.

    The axis is Pinocchio's (normalised when the model was built; zero if the URDF gave a zero axis).
    """
    name = joint.shortname()
    for prefix, revolute in (("JointModelR", True), ("JointModelP", False)):
        if name.startswith(prefix):
            rest = name[len(prefix) :]
            if rest in _AXES:
                return revolute, np.array(_AXES[rest])
            if rest in ("evoluteUnaligned", "rismaticUnaligned"):
                return revolute, np.array(joint.extract().axis, dtype=float)
    return None


def _rotation(axis: Array, angle: float, aligned: bool) -> Array:
    """The rotation by `angle` (rad) about the unit `axis` (Rodrigues; exact entries for a coordinate axis)."""
    c, s = np.cos(angle), np.sin(angle)
    if aligned:
        i = int(np.argmax(np.abs(axis)))
        j, k = (i + 1) % 3, (i + 2) % 3
        r = np.eye(3)
        r[j, j] = r[k, k] = c
        r[k, j], r[j, k] = s, -s
        return r
    x, y, z = axis
    cross = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    return cast(Array, c * np.eye(3) + s * cross + (1.0 - c) * np.outer(axis, axis))


@dataclass(frozen=True)
class ChainPose:
    """Joint placements at a configuration: ⁰R_i (njoints, 3, 3), origins (njoints, 3) and joint axes (n, 3).

    Index 0 is the universe (the base); ``axes[c]`` is the world axis of the joint of velocity column c and
    ``points[c]`` a point on it (its origin), m.
    """

    rotations: Array
    origins: Array
    axes: Array
    points: Array


class ChainFK:
    """Placements and LOCAL_WORLD_ALIGNED frame Jacobians of a model whose joints are all 1-DoF R or P joints.

    Raises ValueError on another joint type (``Robot`` refuses such models before building one).
    """

    def __init__(self, model: pin.Model) -> None:
        self.model = model
        self.n = int(model.nv)
        self._parent = [int(p) for p in model.parents]
        self._col: list[int] = [-1]
        self._place: list[tuple[Array, Array]] = [(np.eye(3), np.zeros(3))]
        self._axis: list[Array] = [np.zeros(3)]
        self._revolute: list[bool] = [False]
        self._aligned: list[bool] = [True]
        for j in range(1, model.njoints):
            joint = model.joints[j]
            kind = joint_axis(joint)
            if kind is None or joint.nv != 1:
                raise ValueError(f"joint '{model.names[j]}' is {joint.shortname()}, not a 1-DoF revolute or prismatic")
            pl = model.jointPlacements[j]
            self._col.append(int(joint.idx_v))
            self._place.append((np.array(pl.rotation), np.array(pl.translation)))
            self._axis.append(kind[1])
            self._revolute.append(kind[0])
            self._aligned.append(int(np.count_nonzero(kind[1])) == 1 and float(np.max(np.abs(kind[1]))) == 1.0)
        self._support_cols: dict[int, NDArray[np.intp]] = {}
        self._rev_by_col = np.zeros(self.n, dtype=bool)
        for j in range(1, model.njoints):
            self._rev_by_col[self._col[j]] = self._revolute[j]
        self._all_revolute = bool(np.all(self._rev_by_col))

    def pose(self, q: Array) -> ChainPose:
        """Joint placements at q (n,), validated by the caller."""
        nj = len(self._parent)
        rot, org = np.empty((nj, 3, 3)), np.empty((nj, 3))
        rot[0], org[0] = np.eye(3), np.zeros(3)
        axes, points = np.empty((self.n, 3)), np.empty((self.n, 3))
        for j in range(1, nj):
            p = self._parent[j]
            r0, t0 = self._place[j]
            r_in = rot[p] @ r0  # the joint frame before its own motion
            t = org[p] + rot[p] @ t0
            a, col = self._axis[j], self._col[j]
            axis = r_in @ a
            if self._revolute[j]:
                rot[j] = r_in @ _rotation(a, float(q[col]), self._aligned[j])
            else:
                rot[j] = r_in
                t = t + axis * float(q[col])
            org[j] = t
            axes[col], points[col] = axis, t
        return ChainPose(rot, org, axes, points)

    def frame_placement(self, pose: ChainPose, frame_id: int) -> Array:
        """⁰M_f (4×4 homogeneous) of a frame at the pose."""
        frame = self.model.frames[frame_id]
        j = int(frame.parentJoint)
        m = np.eye(4)
        m[:3, :3] = pose.rotations[j] @ np.array(frame.placement.rotation)
        m[:3, 3] = pose.origins[j] + pose.rotations[j] @ np.array(frame.placement.translation)
        return m

    def frame_jacobian(self, pose: ChainPose, frame_id: int, point: Array) -> Array:
        """The LOCAL_WORLD_ALIGNED Jacobian (6×n) of the frame whose origin is `point` (world, m)."""
        j = int(self.model.frames[frame_id].parentJoint)
        cols = self._support_cols.get(j)
        if cols is None:
            cols = self._support_cols[j] = np.array([self._col[k] for k in self.model.supports[j][1:]], dtype=int)
        out = np.zeros((6, self.n))
        if cols.size:
            a = pose.axes[cols]
            lin = np.cross(a, point - pose.points[cols])  # revolute: ω × (p − o); prismatic: the axis
            if self._all_revolute:
                out[:3, cols], out[3:, cols] = lin.T, a.T
            else:
                rev = self._rev_by_col[cols][:, None]
                out[:3, cols] = np.where(rev, lin, a).T
                out[3:, cols] = np.where(rev, a, 0.0).T
        return out
