"""Braced kinematics at a configuration (Section III): the model :class:`BracedRobot`, the state :class:`BracedState`.

:class:`BracedRobot` is the model (robot + N ≥ 1 braces); :class:`BracedState` is everything one Pinocchio
evaluation gives at q: per contact b_i, ⁰R_b_i, J_b_i (and its Hessian when asked), the stacked constraint G
with its independent rows, the braced motions N and J_e N (:mod:`bracekit.kinematics.constraint`). The
paper's chain split at {b} (J1, J2, S_t1, S_t2, A, J̃, P, dq1/db̃) is the view ``state.split``
(:mod:`bracekit.kinematics.split`), defined for one brace. Jacobians are geometric, twists [v; ω];
Pinocchio's LOCAL_WORLD_ALIGNED frame Jacobian is the paper's J (reference point = frame origin, world axes).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import Any, NamedTuple, TypeVar

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike, NDArray

from bracekit._forward import Forward
from bracekit._linalg import show
from bracekit.contact import Brace
from bracekit.errors import ContactError, InputError, ModelError
from bracekit.kinematics.constraint import StackedConstraint, contact_null_space, stacked_constraint
from bracekit.kinematics.hessian import LWA, ensure_hessian_layout, frame_hessian
from bracekit.kinematics.motions import BracedMotions, NullMotions, SplitMotions
from bracekit.kinematics.split import BraceSplit, ChainSplit, split_refused
from bracekit.model.chain import DATA_JOINT_LIMIT
from bracekit.model.robot import Robot

__all__ = [
    "MAX_HESSIAN_JOINTS",
    "BracedRobot",
    "BracedState",
    "ContactState",
    "FramePlacements",
    "contact_null_space",
    "skeleton",
]

Array = NDArray[np.float64]

#: Most joints for the kinematic Hessians: they need Pinocchio's Data, of 32·n³ bytes (0.5 GB at 250 joints).
MAX_HESSIAN_JOINTS = 250


class FramePlacements(NamedTuple):
    """Placements at q by forward kinematics alone: the tip's e (3,), ⁰R_e, and each brace's b_i, ⁰R_b_i."""

    e: Array
    R_e: Array
    b_i: tuple[Array, ...]
    R_b_i: tuple[Array, ...]


@dataclass(frozen=True, eq=False, init=False)
class BracedRobot:
    """A robot with N ≥ 1 bracing contacts (any links, the same link twice too).

    ``BracedRobot(robot, brace)`` (or a list of one Brace) is the paper's model; its chain splits at {b}
    (``split``: n1, n2, H, X, P). ``BracedRobot(robot, [brace_1, brace_2, ...])`` braces several frames at
    once; the stacked constraint G = [X_1ᵀ J_b1; X_2ᵀ J_b2; …] of :meth:`state` holds for any N
    (docs/model.md, "Several braces").

    Attributes:
        robot: the robot.
        braces: the braces, in the order given.
        brace_ids: Pinocchio frame id of each brace's {b_i}.
        last_joints: index of the last joint that moves each {b_i}.
        obstacles: the environment's further solids (:func:`bracekit.geometry.obstacle_tables.with_obstacles`).
    """

    robot: Robot
    braces: tuple[Brace, ...]
    brace_ids: tuple[int, ...]
    last_joints: tuple[int, ...]
    obstacles: tuple[Any, ...] = ()

    def __init__(
        self, robot: Robot, braces: Brace | Sequence[Brace] | None = None, *, brace: Brace | None = None
    ) -> None:
        """`braces`: one Brace or a sequence of them; the keyword `brace` (one Brace) is the same as `braces`."""
        if not isinstance(robot, Robot):
            raise ModelError(f"a BracedRobot needs a bracekit Robot, got {type(robot).__name__}")
        if (braces is None) == (brace is None):
            raise ContactError("a BracedRobot needs its brace: give BracedRobot(robot, brace) or a list of braces")
        braces = brace if braces is None else braces
        if isinstance(braces, Brace):
            items: tuple[Brace, ...] = (braces,)
        elif isinstance(braces, Sequence) and not isinstance(braces, str | bytes):
            items = tuple(braces)
            if not items:
                raise ContactError("a BracedRobot needs at least one Brace; got an empty list")
        else:
            raise ContactError(f"a BracedRobot needs a bracekit Brace, got {type(braces).__name__}")
        for item in items:
            if not isinstance(item, Brace):
                raise ContactError(f"a BracedRobot needs a bracekit Brace, got {type(item).__name__}")
        frames = [_brace_frame(robot, item.frame) for item in items]
        object.__setattr__(self, "robot", robot)
        object.__setattr__(self, "braces", items)
        object.__setattr__(self, "brace_ids", tuple(fid for fid, _ in frames))
        object.__setattr__(self, "last_joints", tuple(last for _, last in frames))

    @property
    def n(self) -> int:
        """Number of joints."""
        return self.robot.n

    @cached_property
    def H_i(self) -> tuple[Array, ...]:
        """Allowable twists H_i of each brace (6×l_i, world axes), eq:constraint."""
        return tuple(brace.H() for brace in self.braces)

    @cached_property
    def X_i(self) -> tuple[Array, ...]:
        """Constraint wrench basis X_i of each brace (6×(6−l_i), world axes), H_iᵀ X_i = 0."""
        return tuple(brace.X() for brace in self.braces)

    @cached_property
    def wrench_column_norms(self) -> tuple[tuple[Array, Array], ...]:
        """(‖force part‖, ‖moment part‖) of each column of each X_i: the correction's residual scales."""
        return tuple((np.linalg.norm(x[:3], axis=0), np.linalg.norm(x[3:], axis=0)) for x in self.X_i)

    @cached_property
    def split(self) -> BraceSplit:
        """The paper's chain split at {b} (n1, n2, H, X, P): one brace only, ContactError with several."""
        if len(self.braces) != 1:
            raise split_refused(len(self.braces))
        n1 = self.last_joints[0] + 1
        return BraceSplit(brace=self.braces[0], brace_id=self.brace_ids[0], n1=n1, n2=self.robot.n - n1)

    brace = Forward[Brace]("split", "The one brace: ``split.brace`` (ContactError with several braces).")
    brace_id = Forward[int](
        "split", "Pinocchio frame id of the one brace's {b}: ``split.brace_id`` (ContactError with several braces)."
    )

    @cached_property
    def _data(self) -> pin.Data:
        return self.robot.model.createData()

    def state(self, q: ArrayLike, *, hessians: bool = False) -> BracedState:
        """Evaluate the kinematics at q (n,) with one Pinocchio pass; Hessians only when asked.

        Beyond DATA_JOINT_LIMIT joints the first-order kinematics come from the robot's
        :class:`~bracekit.model.chain.ChainFK` (Pinocchio's Data grows as n³); the Hessians need that Data
        and are refused beyond MAX_HESSIAN_JOINTS joints.
        """
        n = self.robot.n
        if type(q) is np.ndarray and q.dtype == np.float64 and q.shape == (n,) and bool(np.isfinite(q).all()):
            qa = q  # what check_q returns for it (a view of it), without the checks' cost
        else:
            qa = self.robot.check_q(q)
        if not isinstance(hessians, bool):
            raise InputError(f"hessians must be True or False, got {show(hessians)}")
        ids = (self.robot.tip_id, *self.brace_ids)
        if not hessians and self.robot.n > DATA_JOINT_LIMIT:
            return self.state_from_kinematics(qa, self.robot.frame_kinematics(qa, ids))
        if hessians and self.robot.n > MAX_HESSIAN_JOINTS:
            raise ModelError(
                f"kinematic Hessians (analytic gradients) support up to {MAX_HESSIAN_JOINTS} joints, the robot has "
                f"{self.robot.n}: Pinocchio's data for them needs 32·n³ bytes; use a shorter chain"
            )
        model, data = self.robot.model, self._data
        if hessians:  # the first time: check Pinocchio's Hessian layout with this data (before it is filled at q)
            ensure_hessian_layout(model, data, ids)
        pin.computeJointJacobians(model, data, qa)
        place, jacobian = pin.updateFramePlacement, pin.getFrameJacobian  # the frames asked for, not all the model's
        kin = [(place(model, data, f).homogeneous, jacobian(model, data, f, LWA)) for f in ids]  # fresh arrays
        if not hessians:
            return self.state_from_kinematics(qa, kin)
        pin.computeJointKinematicHessians(model, data)
        return self.state_from_kinematics(qa, kin, [frame_hessian(model, data, f) for f in ids])

    def state_from_kinematics(
        self, q: Array, kinematics: Sequence[tuple[Array, Array]], hessians: Sequence[Array] | None = None
    ) -> BracedState:
        """The state at q (checked by the caller) from (⁰M (4×4), J (6×n)) of the tip, then of each brace.

        `hessians`: ∂J/∂q (6, n, n) of the same frames, in the same order, or None. For callers that evaluate
        many frames in one pass (:meth:`Robot.frame_kinematics`).
        """
        if len(kinematics) != len(self.braces) + 1 or (hessians is not None and len(hessians) != len(kinematics)):
            raise InputError(
                f"state_from_kinematics needs the tip and {len(self.braces)} brace frame(s), got {len(kinematics)}"
            )
        (tip, j_e), frames = kinematics[0], kinematics[1:]
        d = [None] * len(kinematics) if hessians is None else list(hessians)
        contacts = tuple(
            [
                _built(ContactState, {"brace": brace, "b": m[:3, 3], "R_b": m[:3, :3], "J_b": j, "dJ_b": dj})
                for brace, (m, j), dj in zip(self.braces, frames, d[1:], strict=True)
            ]
        )
        fields = {"braced": self, "q": q, "e": tip[:3, 3], "R_e": tip[:3, :3], "J_e": j_e, "contacts": contacts}
        fields["dJ_e"] = d[0]
        return _built(BracedState, fields)

    def frame_placements(self, q: ArrayLike) -> FramePlacements:
        """e, ⁰R_e and each b_i, ⁰R_b_i at q by forward kinematics alone: the values of ``state(q)``, cheaper."""
        qa = self.robot.check_q(q)
        ids = (self.robot.tip_id, *self.brace_ids)
        if self.robot.n > DATA_JOINT_LIMIT:
            fk = self.robot.chain
            pose = fk.pose(qa)
            ms = [fk.frame_placement(pose, f) for f in ids]
        else:
            model, data = self.robot.model, self._data
            pin.forwardKinematics(model, data, qa)
            pin.updateFramePlacements(model, data)
            ms = [data.oMf[f].homogeneous for f in ids]
        return FramePlacements(
            e=ms[0][:3, 3],
            R_e=ms[0][:3, :3],
            b_i=tuple(m[:3, 3] for m in ms[1:]),
            R_b_i=tuple(m[:3, :3] for m in ms[1:]),
        )


_Built = TypeVar("_Built")


def _built(cls: type[_Built], fields: dict[str, Any]) -> _Built:
    """``cls(**fields)`` of a frozen dataclass whose __init__ only stores its fields (no __post_init__), cheaper.

    Its __dict__ is filled at once instead of one ``object.__setattr__`` a field: the same object (a run builds
    one state a step).
    """
    out = object.__new__(cls)
    out.__dict__.update(fields)
    return out


def _brace_frame(robot: Robot, name: str) -> tuple[int, int]:
    """(Pinocchio frame id, index of the last joint that moves it) of a brace frame; ContactError if unusable."""
    if name in robot.off_chain:
        raise ContactError(
            f"brace frame {show(name)} is not on the chain from the base to the tip {show(robot.tip)}; "
            "brace a frame of a link between them"
        )
    fid = robot.frame_id(name)
    last = robot.frame_joint(name)
    if last < 0:
        raise ContactError(f"brace frame {show(name)} is fixed to the base: no joint moves it; brace a moving link")
    if last >= robot.n - 1:
        raise ContactError(
            f"brace frame {show(name)} is on the last link: no joint lies between {{b}} and the tip; "
            "brace a link nearer the base"
        )
    return fid, last


def skeleton(robot: Robot, q: ArrayLike) -> Array:
    """Points of the robot for drawing (k×3, m, world): base, each joint origin, then the tip."""
    qa = robot.check_q(q)
    if robot.n > DATA_JOINT_LIMIT:
        fk = robot.chain
        pose = fk.pose(qa)
        return np.vstack([pose.origins, fk.frame_placement(pose, robot.tip_id)[None, :3, 3]])
    data = robot.model.createData()
    pin.forwardKinematics(robot.model, data, qa)
    pin.updateFramePlacements(robot.model, data)
    pts = [np.zeros(3)] + [data.oMi[j].translation.copy() for j in range(1, robot.model.njoints)]
    pts.append(data.oMf[robot.tip_id].translation.copy())
    return np.array(pts)


@dataclass(frozen=True, eq=False)
class ContactState:
    """One brace at a configuration. Position in m, world frame; Jacobian 6×n, [v; ω], world axes.

    Attributes:
        brace: the brace.
        b: position of {b_i} (3,).
        R_b: orientation ⁰R_b_i (3×3).
        J_b: geometric Jacobian at b_i (6×n): the columns of the joints beyond {b_i} are zero.
        dJ_b: ∂J_b/∂q (6, n, n), [:, i, k] = ∂J_b[:, i]/∂q_k, if asked for.
    """

    brace: Brace
    b: Array
    R_b: Array
    J_b: Array
    dJ_b: Array | None = None

    @property
    def z_b(self) -> Array:
        """ẑ_b, world axes (3,): the pad axis of a brace that has one."""
        return self.R_b[:, 2].copy()


@dataclass(frozen=True, eq=False)
class BracedState:
    """The braced robot at a configuration q (``BracedRobot.state(q)``), for any number of braces.

    Positions in m, world frame; Jacobians LOCAL_WORLD_ALIGNED (reference point = the frame's origin, world
    axes), 6×n, twists [v; ω].

    Attributes:
        braced: the model.
        q: joint values (n,).
        e, R_e, J_e: position (3,), orientation ⁰R_e (3×3) and Jacobian (6×n) of the tip {e}.
        contacts: each brace's state (b_i, R_b_i, J_b_i, dJ_b_i), in the order of ``braced.braces``.
        dJ_e: ∂J_e/∂q (6, n, n), [:, i, k] = ∂J_e[:, i]/∂q_k, if asked for.
    """

    braced: BracedRobot
    q: Array
    e: Array
    R_e: Array
    J_e: Array
    contacts: tuple[ContactState, ...]
    dJ_e: Array | None = None

    @property
    def K(self) -> Array:
        """Joint stiffnesses (n,), N·m/rad (N/m for a prismatic joint)."""
        return self.braced.robot.stiffness

    @property
    def b_i(self) -> tuple[Array, ...]:
        """Position of each {b_i} (3,), m."""
        return tuple(c.b for c in self.contacts)

    @property
    def R_b_i(self) -> tuple[Array, ...]:
        """Orientation ⁰R_b_i of each brace (3×3)."""
        return tuple(c.R_b for c in self.contacts)

    @property
    def J_b_i(self) -> tuple[Array, ...]:
        """Jacobian J_b_i of each brace (6×n)."""
        return tuple(c.J_b for c in self.contacts)

    @property
    def X_i(self) -> tuple[Array, ...]:
        """Constraint wrench basis X_i of each brace (6×(6−l_i), world axes)."""
        return self.braced.X_i

    @property
    def H_i(self) -> tuple[Array, ...]:
        """Allowable twists H_i of each brace (6×l_i, world axes)."""
        return self.braced.H_i

    @property
    def has_hessians(self) -> bool:
        """Whether the state carries ∂J_e/∂q and every ∂J_b_i/∂q."""
        return self.dJ_e is not None and all(c.dJ_b is not None for c in self.contacts)

    @cached_property
    def constraint(self) -> StackedConstraint:
        """The stacked constraint G, its independent rows and N (warns about dependent rows once)."""
        return stacked_constraint(self)

    G = Forward[Array](
        "constraint", "[X_1ᵀ J_b1; X_2ᵀ J_b2; …] (c×n, c = Σ (6 − l_i)): every contact is kept when G Δq = 0."
    )
    N = Forward[Array]("constraint", "Orthonormal basis of the braced motions, the null space of G (n×(n − rank G)).")

    @cached_property
    def braced_jacobian(self) -> Array:
        """J_e N (6×(n − rank G)): the tip twist per coordinate of the braced motions.

        Its k and Πσ are the measures of the braced task Jacobian for any N (docs/model.md, "Several braces");
        for one brace the paper's measures are those of J̃ (``split.J_braced``).
        """
        return np.asarray(self.J_e @ self.N, dtype=np.float64)

    @cached_property
    def split(self) -> ChainSplit:
        """The paper's chain split at {b} (J1, J2, S_t1, S_t2, A, J̃, P, dq1/db̃): one brace only.

        ContactError with several braces (the chain does not split at one {b}).
        """
        return ChainSplit(state=self, model=self.braced.split)

    @cached_property
    def motions(self) -> BracedMotions:
        """Coordinates of the braced motions the strategies resolve over (:mod:`bracekit.kinematics.motions`).

        One brace: the paper's (b̃, q2) through the chain split; several: y over N, q̇ = N y.
        """
        if len(self.contacts) == 1:
            return SplitMotions(self.split)
        con = self.constraint
        return NullMotions(N=self.N, A=self.braced_jacobian, G=con.G[list(con.independent)], J_e=self.J_e)
