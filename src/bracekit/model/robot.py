"""Robot: a serial chain from URDF (Pinocchio model), its tip frame {e} and its joint stiffnesses.

The model is what does not change during a run; everything computed at a configuration lives in
:mod:`bracekit.kinematics`.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from functools import cached_property
from pathlib import Path

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike, NDArray

from bracekit._linalg import as_array, show
from bracekit.errors import FrameNotFoundError, InputError, ModelError
from bracekit.geometry.collision import CollisionElement, read_collision_geometry
from bracekit.model.chain import DATA_JOINT_LIMIT, ChainFK, joint_axis
from bracekit.model.geometry import DEFAULT_LINK_RADIUS, Capsule, collision_capsules, link_capsules, mesh_capsules
from bracekit.model.urdf_loading import load_urdf, urdf_text
from bracekit.model.urdf_numbers import MAX_LENGTH, check_model_numbers

Array = NDArray[np.float64]

#: Accepted joint stiffnesses, N·m/rad (N/m for prismatic joints).
STIFFNESS_RANGE = (1e-6, 1e12)
def _as_stiffness(stiffness: float | Sequence[float] | ArrayLike, names: Sequence[str]) -> Array:
    n = len(names)
    k = as_array(stiffness, "joint stiffness (N·m/rad)", finite=False)
    if k.ndim == 0:
        k = np.full(n, float(k))
    k = k.reshape(-1)
    if k.size != n:
        raise InputError(f"got {k.size} joint stiffnesses for {n} joints ({name_list(names)}); give one value or {n}")
    bad = ~(np.isfinite(k) & (k > 0.0))
    if bad.any():
        i = int(np.argmax(bad))
        raise InputError(f"joint stiffness of '{names[i]}' must be a positive number in N·m/rad, got {k[i]}")
    out = (k < STIFFNESS_RANGE[0]) | (k > STIFFNESS_RANGE[1])
    if out.any():
        i = int(np.argmax(out))
        raise InputError(
            f"joint stiffness of '{names[i]}' is {k[i]:g}; give a value between {STIFFNESS_RANGE[0]:g} and "
            f"{STIFFNESS_RANGE[1]:g} N·m/rad (outside it the compliance under- or overflows)"
        )
    return k


def name_list(names: Sequence[str], limit: int = 12) -> str:
    """Names joined by commas, the middle elided past `limit` names (for one-line messages)."""
    if len(names) <= limit:
        return ", ".join(names)
    return ", ".join([*names[: limit - 2], "…", names[-1]]) + f" ({len(names)} in all)"


def _check_joints(model: pin.Model) -> None:
    """ModelError naming the first joint that is not a usable 1-DoF joint (type, axis, origin, limits)."""
    for j in range(1, model.njoints):
        joint, name = model.joints[j], model.names[j]
        kind = joint_axis(joint) if joint.nq == 1 and joint.nv == 1 else None
        if kind is None:
            raise ModelError(
                f"joint {show(name)} is {joint.shortname()} (nq={joint.nq}, nv={joint.nv}); "
                "bracekit needs revolute or prismatic joints: give it type='revolute' with <limit>"
            )
        if not abs(float(np.linalg.norm(kind[1])) - 1.0) <= 1e-9:
            raise ModelError(
                f"joint {show(name)} has a zero axis ({kind[1].tolist()}); give its <axis xyz> a non-zero direction"
            )
        if not np.all(np.isfinite(model.jointPlacements[j].homogeneous)):
            raise ModelError(f"joint {show(name)} has a non-finite origin (NaN or inf); give its <origin> numbers")
    lower = np.asarray(model.lowerPositionLimit, dtype=float)
    upper = np.asarray(model.upperPositionLimit, dtype=float)
    for bad, why in (
        (np.isnan(lower) | np.isnan(upper), "has a NaN limit; give its <limit> numbers"),
        (lower > upper, "has lower limit {lo:g} > upper limit {hi:g}; give it lower < upper in its <limit>"),
        (
            lower == upper,
            'is locked (lower = upper = {lo:g}) and cannot move; make it type="fixed" or give it a range of motion',
        ),
    ):
        if bad.any():
            i = int(np.argmax(bad))
            raise ModelError(f"joint '{model.names[i + 1]}' " + why.format(lo=lower[i], hi=upper[i]))


@dataclass(frozen=True, eq=False)
class Robot:
    """A serial robot: Pinocchio model of the chain from the base to the tip frame {e}.

    Joints not on the path to the tip are locked at their neutral value when the model is loaded.
    Joint values are given in chain order, base to tip (n values, rad or m).

    Attributes:
        model: Pinocchio model; every joint is 1-DoF (revolute or prismatic), nq == nv == n. A URDF's
            continuous joints are revolute joints here with limits ±inf (q is the angle).
        tip: name of the end-effector frame {e}.
        stiffness: joint stiffnesses K (n,), N·m/rad (N/m for prismatic joints).
        collisions: the capsules of the URDF's collision geometry (:mod:`bracekit.model.geometry`), read at load
            time; () when the URDF has none (every link then gets its default capsule).
        geometry: every collision element (meshes and primitives) as Pinocchio + coal read them
            (:mod:`bracekit.geometry.collision`); with a mesh among them the clearance is coal's.
    """

    model: pin.Model
    tip: str
    stiffness: Array
    off_chain: frozenset[str] = frozenset()
    collisions: tuple[Capsule, ...] = ()
    geometry: tuple[CollisionElement, ...] = ()
    _tip_id: int = field(init=False, repr=False)

    def __post_init__(self) -> None:
        if not isinstance(self.model, pin.Model):
            raise ModelError(
                f"a Robot needs a pinocchio.Model, got {type(self.model).__name__}; use Robot.from_urdf or load_model"
            )
        if self.model.nq != self.model.nv:
            raise ModelError("every joint must be 1-DoF revolute or prismatic (nq == nv)")
        if self.model.nv == 0:
            raise ModelError("the model has no joint; give a chain of revolute or prismatic joints")
        _check_joints(self.model)
        check_model_numbers(self.model)
        for c in self.collisions:
            if not 0.0 <= c.radius <= MAX_LENGTH:
                raise ModelError(
                    f"the collision capsule of link {show(c.link)} has radius {c.radius:g} m, outside "
                    f"[0, {MAX_LENGTH:g}]; fix its collision <geometry> in the URDF"
                )
        object.__setattr__(self, "_tip_id", self.frame_id(self.tip))
        object.__setattr__(self, "stiffness", _as_stiffness(self.stiffness, self.joint_names))
        object.__setattr__(self, "off_chain", frozenset(self.off_chain))

    @classmethod
    def from_urdf(
        cls,
        source: str | os.PathLike[str],
        tip: str,
        stiffness: float | Sequence[float] | ArrayLike = 170.0,
        package_dirs: Sequence[str | os.PathLike[str]] = (),
    ) -> Robot:
        """Load a robot from a URDF file path or an XML string.

        Args:
            source: path of a .urdf file (a str or an os.PathLike), or the URDF text itself (a string starting
                with '<').
            tip: name of the end-effector frame {e} (a link or a fixed joint of the URDF).
                Continuous joints become revolute joints with limits ±inf: q holds their angles.
            stiffness: one joint stiffness for all joints or one per joint of the chain, N·m/rad.
            package_dirs: folders searched for the collision meshes' ``package://`` paths (then
                ``ROS_PACKAGE_PATH``; a file's own folder for relative paths).

        Raises:
            ModelError: the file is missing or not URDF, or a joint of the chain is not a 1-DoF revolute or
                prismatic joint with a non-zero axis and limits lower < upper, or a joint of the chain mimics
                another (mimic joints off the chain are locked like every joint off the chain).
            FrameNotFoundError: `tip` is not a frame of the URDF.
        """
        full, joints = load_urdf(source)
        if not isinstance(tip, str):
            raise ModelError(f"the tip frame must be a frame name (a string), got {show(tip)}")
        if not full.existFrame(tip):
            raise FrameNotFoundError(f"unknown tip frame {show(tip)}; known frames: {name_list(_frame_names(full))}")
        tip_joint = full.frames[full.getFrameId(tip)].parentJoint
        keep = set(full.supports[tip_joint])
        for name, leader in joints.mimic:
            if full.existJointName(name) and full.getJointId(name) in keep:
                raise ModelError(
                    f"joint {show(name)} mimics joint {show(leader)} and moves the tip {show(tip)}; bracekit needs "
                    'independent joints on the chain to the tip: remove its <mimic> or make it type="fixed"'
                )
        lock = [j for j in range(1, full.njoints) if j not in keep]
        model = pin.buildReducedModel(full, lock, pin.neutral(full)) if lock else full
        off_chain = frozenset(f.name for f in full.frames if f.parentJoint not in keep)
        if model.nv == 0:
            raise ModelError(f"no joint moves the tip frame {show(tip)}; choose a frame on a moving link")
        _check_joints(model)
        k = _as_stiffness(stiffness, tuple(model.names[1:]))
        text = urdf_text(source)
        collisions = collision_capsules(text, model)
        here = [] if isinstance(source, str) and source.lstrip().startswith("<") else [Path(source).parent]
        geometry = read_collision_geometry(model, text, [*package_dirs, *here])
        collisions += mesh_capsules(geometry)  # the meshes' capsule fits, for pictures
        return cls(model=model, tip=tip, stiffness=k, off_chain=off_chain, collisions=collisions, geometry=geometry)

    # --- names and sizes -------------------------------------------------------------------------
    @property
    def n(self) -> int:
        """Number of joints of the chain."""
        return int(self.model.nv)

    @property
    def joint_names(self) -> tuple[str, ...]:
        """Joint names in chain order, base to tip."""
        return tuple(self.model.names[1:])

    @property
    def lower(self) -> Array:
        """Lower joint limits (n,); −inf for a continuous joint."""
        return np.asarray(self.model.lowerPositionLimit, dtype=float).copy()

    @property
    def upper(self) -> Array:
        """Upper joint limits (n,); +inf for a continuous joint."""
        return np.asarray(self.model.upperPositionLimit, dtype=float).copy()

    @property
    def tip_id(self) -> int:
        """Pinocchio frame id of {e}."""
        return self._tip_id

    def frame_id(self, name: str) -> int:
        """Pinocchio frame id of a frame or link name; raises FrameNotFoundError."""
        if not isinstance(name, str):
            raise InputError(f"a frame name must be a string, got {show(name)}")
        if not self.model.existFrame(name):
            raise FrameNotFoundError(f"unknown frame {show(name)}; known frames: {name_list(_frame_names(self.model))}")
        return int(self.model.getFrameId(name))

    def frame_joint(self, name: str) -> int:
        """Index (0-based, in chain order) of the last joint that moves frame `name`; −1 if none."""
        return int(self.model.frames[self.frame_id(name)].parentJoint) - 1

    # --- configurations --------------------------------------------------------------------------
    def check_q(self, q: ArrayLike) -> Array:
        """Q as a float array (n,); raises InputError on a wrong length or a non-finite value."""
        a = as_array(q, "joint values", finite=False).reshape(-1)
        if a.size != self.n:
            raise InputError(
                f"got {a.size} joint values for {self.n} joints ({name_list(self.joint_names)}); "
                f"give {self.n} values in chain order"
            )
        if not np.all(np.isfinite(a)):
            raise InputError(f"joint values must be finite numbers, got {show(a)}")
        return a

    def outside_limits(self, q: ArrayLike, tolerance: float = 1e-9) -> str | None:
        """Why `q` (n,) lies outside the URDF joint limits (the first joint, its value and limits), or None."""
        a = self.check_q(q)
        lo, hi = self.lower, self.upper
        bad = (a < lo - tolerance) | (a > hi + tolerance)
        if not bad.any():
            return None
        i = int(np.argmax(bad))
        return f"joint {i + 1} ({self.joint_names[i]}) = {a[i]:g} is outside its limits [{lo[i]:g}, {hi[i]:g}]"

    def neutral(self) -> Array:
        """The neutral configuration (zeros for revolute and prismatic joints)."""
        return np.asarray(pin.neutral(self.model), dtype=float)

    # --- derived robots --------------------------------------------------------------------------
    def with_point_frame(
        self,
        name: str,
        link: str,
        offset: ArrayLike = (0.0, 0.0, 0.0),
        rotation: ArrayLike | None = None,
    ) -> Robot:
        """A copy of this robot with a new frame `name` fixed to `link` at `offset` (m, link axes).

        `rotation` (3×3, link axes) orients the new frame; identity by default. Use it to place a
        bracing frame {b} at a point of a link's body.
        """
        return self.with_point_frames([(name, link, offset, rotation)])

    def with_point_frames(self, frames: Sequence[tuple[str, str, ArrayLike, ArrayLike | None]]) -> Robot:
        """A copy of this robot with several new frames (name, link, offset, rotation), one model copy in all.

        Each entry is as the arguments of :meth:`with_point_frame`; rotation None is the identity.
        """
        if isinstance(frames, str | bytes) or not isinstance(frames, Sequence):
            raise InputError(f"frames must be a list of (name, link, offset, rotation), got {show(frames)}")
        placed = []
        names: set[str] = set()
        for entry in frames:
            if not isinstance(entry, tuple | list) or len(entry) != 4:
                raise InputError(f"a new frame must be (name, link, offset, rotation), got {show(entry)}")
            name, link, offset, rotation = entry
            if not isinstance(name, str) or not name:
                raise InputError(f"a frame name must be a non-empty string, got {show(name)}")
            if self.model.existFrame(name) or name in names:
                raise InputError(f"frame {show(name)} already exists; choose another name for the brace point")
            names.add(name)
            fid = self.frame_id(link)
            if link in self.off_chain:
                raise InputError(f"link {show(link)} is not on the chain to the tip {show(self.tip)}")
            off = as_array(offset, f"the offset of frame {show(name)} (m)").reshape(-1)
            if off.size != 3:
                raise InputError(f"the offset of frame {show(name)} must be 3 numbers (m), got {off.size}")
            if float(np.max(np.abs(off))) > MAX_LENGTH:
                raise InputError(
                    f"the offset of frame {show(name)} is {show(off.tolist())} m, beyond ±{MAX_LENGTH:g} m; give a "
                    "point of the link (m, link axes)"
                )
            rot = np.eye(3) if rotation is None else as_array(rotation, f"the rotation of frame {show(name)}", (3, 3))
            if not (
                float(np.max(np.abs(rot))) <= 1.0 + 1e-9
                and np.allclose(rot.T @ rot, np.eye(3), atol=1e-9)
                and np.linalg.det(rot) > 0
            ):
                raise InputError(f"the rotation of frame {show(name)} must be a rotation matrix (RᵀR = I, det 1)")
            placed.append((name, fid, pin.SE3(rot, off)))
        model = pin.Model(self.model)
        for name, fid, local in placed:
            parent = model.frames[fid]
            model.addFrame(pin.Frame(name, parent.parentJoint, fid, parent.placement * local, pin.FrameType.OP_FRAME))
        return replace(self, model=model)

    def with_stiffness(self, stiffness: float | Sequence[float] | ArrayLike) -> Robot:
        """A copy of this robot with other joint stiffnesses (N·m/rad)."""
        k = _as_stiffness(stiffness, self.joint_names)
        return replace(self, stiffness=k)

    def link_capsules(self, link_radius: float = DEFAULT_LINK_RADIUS) -> tuple[Capsule, ...]:
        """Each moving link as capsules in its joint's frame: the URDF's collision geometry or the default capsule.

        Args:
            link_radius: radius (m) of the default capsule of a link without usable collision geometry (the
                segment between its joint's origin and the next joint's origin, or the tip for the last joint).
        """
        return link_capsules(self.model, self.tip_id, self.collisions, link_radius)

    # --- kinematics ------------------------------------------------------------------------------
    @cached_property
    def chain(self) -> ChainFK:
        """Forward kinematics of the chain without Pinocchio's Data (used beyond DATA_JOINT_LIMIT joints)."""
        return ChainFK(self.model)

    def frame_kinematics(self, q: ArrayLike, frame_ids: Sequence[int]) -> list[tuple[Array, Array]]:
        """(⁰M_f (4×4), LOCAL_WORLD_ALIGNED Jacobian (6×n)) of each frame at q, from one kinematics pass.

        Pinocchio's algorithms up to DATA_JOINT_LIMIT joints, :class:`~bracekit.model.chain.ChainFK` beyond
        (Pinocchio's Data grows as n³).
        """
        qa = self.check_q(q)
        if self.n <= DATA_JOINT_LIMIT:
            model, data = self.model, self.model.createData()
            pin.computeJointJacobians(model, data, qa)
            pin.updateFramePlacements(model, data)
            lwa = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
            return [(data.oMf[f].homogeneous, pin.getFrameJacobian(model, data, f, lwa)) for f in frame_ids]
        fk = self.chain
        pose = fk.pose(qa)
        out = []
        for f in frame_ids:
            m = fk.frame_placement(pose, f)
            out.append((m, fk.frame_jacobian(pose, f, m[:3, 3])))
        return out


def _frame_names(model: pin.Model) -> list[str]:
    body = [f.name for f in model.frames if f.type in (pin.FrameType.BODY, pin.FrameType.OP_FRAME)]
    return body or [f.name for f in model.frames]
