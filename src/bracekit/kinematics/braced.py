"""Braced kinematics at a configuration (Section III): J1, J2, S_t1, S_t2, A, J, J̃ and Hessians.

:class:`BracedRobot` is the model (robot + brace, where the chain splits); :class:`BracedState` is
everything one Pinocchio evaluation gives at q. A robot with several braces gives its per-brace kinematics
and the stacked contact constraint through :meth:`BracedRobot.stacked_state` (:mod:`bracekit.kinematics.multi`).
Jacobians are geometric, twists [v; ω]; Pinocchio's LOCAL_WORLD_ALIGNED frame Jacobian is the paper's J
(reference point = frame origin, world axes).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike, NDArray

from bracekit._linalg import show
from bracekit.contact import Brace
from bracekit.errors import ContactError, InputError, ModelError, SingularityError
from bracekit.kinematics.hessian import LWA, ensure_hessian_layout, frame_hessian
from bracekit.model.chain import DATA_JOINT_LIMIT
from bracekit.model.robot import Robot
from bracekit.spatial import twist_rotate, twist_shift
from bracekit.tolerances import J1_COND_LIMIT, NULL_SPACE_RTOL

if TYPE_CHECKING:
    from bracekit.kinematics.multi import MultiBracedState

Array = NDArray[np.float64]

#: Most joints for the kinematic Hessians: they need Pinocchio's Data, of 32·n³ bytes (0.5 GB at 250 joints).
MAX_HESSIAN_JOINTS = 250


@dataclass(frozen=True, eq=False, init=False)
class BracedRobot:
    """A robot with one or several bracing contacts.

    ``BracedRobot(robot, brace)`` (or a list of one Brace) is the paper's model: it splits the chain at {b}
    into chain 1 (n1 joints, every joint that moves {b}) and chain 2 (n2, the joints from {b} to {e}); the
    brace's surface and contact are fixed, so H, X and the projector P are constants of the model.

    ``BracedRobot(robot, [brace_1, brace_2, ...])`` braces several frames at once (any links, the same link
    twice too); the chain does not split: use :meth:`stacked_state` and the stacked constraint
    G = [X_1ᵀ J_b1; X_2ᵀ J_b2; …] (docs/model.md, "Several braces"). The one-brace attributes (brace,
    brace_id, n1, n2, H, X, P, :meth:`state`, :meth:`placements`) then raise ContactError.

    Attributes:
        robot: the robot.
        braces: the braces, in the order given (one for the paper's model).
        brace_ids: Pinocchio frame id of each brace's {b}.
    """

    robot: Robot
    braces: tuple[Brace, ...]
    brace_ids: tuple[int, ...]
    _n1: int | None = field(repr=False)

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
        ids, lasts = [], []
        for item in items:
            fid, last = _brace_frame(robot, item.frame)
            ids.append(fid)
            lasts.append(last)
        object.__setattr__(self, "robot", robot)
        object.__setattr__(self, "braces", items)
        object.__setattr__(self, "brace_ids", tuple(ids))
        object.__setattr__(self, "_n1", lasts[0] + 1 if len(items) == 1 else None)

    def _several(self, what: str, use: str) -> ContactError:
        """The error for a one-brace attribute `what` asked of a robot with several braces."""
        return ContactError(f"{what} is defined for one brace; this robot has {len(self.braces)} braces: use {use}")

    @property
    def brace(self) -> Brace:
        """The brace (one-brace model); ContactError with several braces (use ``braces``)."""
        if len(self.braces) != 1:
            raise self._several("BracedRobot.brace", "braced.braces[i]")
        return self.braces[0]

    @property
    def brace_id(self) -> int:
        """Pinocchio frame id of {b} (one-brace model); ContactError with several braces (use ``brace_ids``)."""
        if len(self.braces) != 1:
            raise self._several("BracedRobot.brace_id", "braced.brace_ids[i]")
        return self.brace_ids[0]

    @property
    def n1(self) -> int:
        """Number of joints of chain 1, base to {b} (one-brace model); ContactError with several braces."""
        if self._n1 is None:
            raise self._several("the chain split n1 at {b}", "the stacked constraint of braced.stacked_state(q)")
        return self._n1

    @property
    def n(self) -> int:
        """Number of joints."""
        return self.robot.n

    @property
    def n2(self) -> int:
        """Number of joints of chain 2, from {b} to {e} (one-brace model)."""
        return self.robot.n - self.n1

    @cached_property
    def H(self) -> Array:
        """Allowable twists of {b} (6×l), eq:constraint (one-brace model)."""
        return self.brace.H()

    @cached_property
    def X(self) -> Array:
        """Constraint wrench basis (6×(6−l)), Hᵀ X = 0 (one-brace model)."""
        return self.brace.X()

    @cached_property
    def P(self) -> Array:
        """The paper's projector onto the constraint directions, P = X (XᵀX)⁻¹ Xᵀ (6×6) (one-brace model)."""
        x = self.X
        return x @ np.linalg.solve(x.T @ x, x.T)

    @cached_property
    def _data(self) -> pin.Data:
        return self.robot.model.createData()

    def state(self, q: ArrayLike, *, hessians: bool = False) -> BracedState:
        """Evaluate the kinematics at q (n,) with one Pinocchio pass; Hessians only when asked.

        Beyond DATA_JOINT_LIMIT joints the first-order kinematics come from the robot's
        :class:`~bracekit.model.chain.ChainFK` (Pinocchio's Data grows as n³); the Hessians need that Data
        and are refused beyond MAX_HESSIAN_JOINTS joints.
        """
        if len(self.braces) != 1:
            raise self._several("BracedRobot.state (J1, J2, A, J̃ of the chain split at {b})", "braced.stacked_state(q)")
        qa = self.robot.check_q(q)
        if not isinstance(hessians, bool):
            raise InputError(f"hessians must be True or False, got {show(hessians)}")
        tip_id = self.robot.tip_id
        if not hessians and self.robot.n > DATA_JOINT_LIMIT:
            (tip, j_e), (brace, j_b) = self.robot.frame_kinematics(qa, (tip_id, self.brace_id))
            return self.state_from_kinematics(qa, tip, j_e, brace, j_b)
        if hessians and self.robot.n > MAX_HESSIAN_JOINTS:
            raise ModelError(
                f"kinematic Hessians (analytic gradients) support up to {MAX_HESSIAN_JOINTS} joints, the robot has "
                f"{self.robot.n}: Pinocchio's data for them needs 32·n³ bytes; use a shorter chain"
            )
        model, data = self.robot.model, self._data
        if hessians:  # the first time: check Pinocchio's Hessian layout with this data (before it is filled at q)
            ensure_hessian_layout(model, data, (tip_id, self.brace_id))
        pin.computeJointJacobians(model, data, qa)
        pin.updateFramePlacements(model, data)
        tip, brace = data.oMf[tip_id].homogeneous, data.oMf[self.brace_id].homogeneous  # fresh arrays
        j_e = pin.getFrameJacobian(model, data, tip_id, LWA)  # fresh arrays too
        j_b = pin.getFrameJacobian(model, data, self.brace_id, LWA)
        d_je = d_jb = None
        if hessians:
            pin.computeJointKinematicHessians(model, data)
            d_je = frame_hessian(model, data, tip_id)
            d_jb = frame_hessian(model, data, self.brace_id)
        return self.state_from_kinematics(qa, tip, j_e, brace, j_b, d_je, d_jb)

    def state_from_kinematics(
        self,
        q: Array,
        tip: Array,
        j_e: Array,
        brace: Array,
        j_b: Array,
        d_je: Array | None = None,
        d_jb: Array | None = None,
    ) -> BracedState:
        """The state at q (checked by the caller) from placements ⁰M_e, ⁰M_b (4×4) and Jacobians J_e, J_b (6×n).

        For callers that evaluate many frames in one pass (:meth:`Robot.frame_kinematics`).
        """
        if len(self.braces) != 1:
            raise self._several("BracedRobot.state_from_kinematics", "braced.stacked_state(q)")
        return BracedState(
            braced=self,
            q=q,
            b=brace[:3, 3],
            e=tip[:3, 3],
            R_b=brace[:3, :3],
            R_e=tip[:3, :3],
            J_e=j_e,
            J_b=j_b,
            dJ_e=d_je,
            dJ_b=d_jb,
        )

    def placements(self, q: ArrayLike) -> tuple[Array, Array, Array, Array]:
        """b, e (3,), ⁰R_b, ⁰R_e (3×3) at q by forward kinematics alone: the values of ``state(q)``, cheaper."""
        if len(self.braces) != 1:
            raise self._several("BracedRobot.placements", "braced.stacked_state(q) (its b_i, R_b_i)")
        qa = self.robot.check_q(q)
        if self.robot.n > DATA_JOINT_LIMIT:
            fk = self.robot.chain
            pose = fk.pose(qa)
            tip, brace = fk.frame_placement(pose, self.robot.tip_id), fk.frame_placement(pose, self.brace_id)
            return brace[:3, 3], tip[:3, 3], brace[:3, :3], tip[:3, :3]
        model, data = self.robot.model, self._data
        pin.forwardKinematics(model, data, qa)
        pin.updateFramePlacements(model, data)
        tip, brace = data.oMf[self.robot.tip_id].homogeneous, data.oMf[self.brace_id].homogeneous
        return brace[:3, 3], tip[:3, 3], brace[:3, :3], tip[:3, :3]

    def stacked_state(self, q: ArrayLike) -> MultiBracedState:
        """The kinematics of every brace and of the tip at q (n,), from one kinematics pass (any number of braces).

        Gives b_i, ⁰R_b_i and J_b_i (LOCAL_WORLD_ALIGNED, 6×n) of each brace, in the order of ``braces``, and
        the stacked contact constraint G (:class:`~bracekit.kinematics.multi.MultiBracedState`). First order
        only (no kinematic Hessians).
        """
        qa = self.robot.check_q(q)
        ids = (self.robot.tip_id, *self.brace_ids)
        if self.robot.n > DATA_JOINT_LIMIT:
            kin = self.robot.frame_kinematics(qa, ids)
        else:
            model, data = self.robot.model, self._data
            pin.computeJointJacobians(model, data, qa)
            pin.updateFramePlacements(model, data)
            kin = [(data.oMf[f].homogeneous, pin.getFrameJacobian(model, data, f, LWA)) for f in ids]
        return self.stacked_state_from_kinematics(qa, kin)

    def stacked_state_from_kinematics(self, q: Array, kinematics: list[tuple[Array, Array]]) -> MultiBracedState:
        """The stacked state at q (checked by the caller) from (⁰M (4×4), J (6×n)) of the tip, then each brace."""
        from bracekit.kinematics.multi import MultiBracedState  # multi.py builds on this module

        (tip, j_e), frames = kinematics[0], kinematics[1:]
        return MultiBracedState(
            braced=self,
            q=q,
            e=tip[:3, 3],
            R_e=tip[:3, :3],
            J_e=j_e,
            b_i=tuple(m[:3, 3] for m, _ in frames),
            R_b_i=tuple(m[:3, :3] for m, _ in frames),
            J_b_i=tuple(j for _, j in frames),
        )


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


def contact_null_space(xt_j1: Array) -> Array:
    """Orthonormal basis (n1×l') of the null space of Xᵀ J1: the chain-1 motions that keep the contact."""
    _, s, vt = np.linalg.svd(xt_j1)
    rank = int(np.sum(s > NULL_SPACE_RTOL * max(1.0, s[0] if s.size else 1.0)))
    return np.ascontiguousarray(vt[rank:].T, dtype=np.float64)


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
class BracedState:
    """The braced robot at a configuration q. Positions in m, world frame; Jacobians 6×·, [v; ω].

    Attributes:
        q: joint values (n,).
        b, e: positions of {b} and {e} (3,).
        R_b, R_e: orientations ⁰R_b, ⁰R_e (3×3).
        J_e: geometric Jacobian of the whole robot at e, world axes (6×n).
        J_b: geometric Jacobian at b, world axes (6×n); its chain-2 columns are zero.
        dJ_e, dJ_b: their derivatives (6, n, n), [:, i, k] = ∂J[:, i]/∂q_k, if asked for.
    """

    braced: BracedRobot
    q: Array
    b: Array
    e: Array
    R_b: Array
    R_e: Array
    J_e: Array
    J_b: Array
    dJ_e: Array | None = None
    dJ_b: Array | None = None

    @property
    def n1(self) -> int:
        """Joints of chain 1."""
        return self.braced.n1

    @property
    def K(self) -> Array:
        """Joint stiffnesses (n,), N·m/rad."""
        return self.braced.robot.stiffness

    @property
    def H(self) -> Array:
        """Allowable twists of {b} (6×l), eq:constraint / eq:H_point."""
        return self.braced.H

    @property
    def X(self) -> Array:
        """Constraint wrenches (6×(6−l))."""
        return self.braced.X

    @property
    def P(self) -> Array:
        """X (XᵀX)⁻¹ Xᵀ (6×6)."""
        return self.braced.P

    @cached_property
    def J1(self) -> Array:
        """Twist of b per q̇1, at b, world axes (6×n1), eq:J1."""
        return self.J_b[:, : self.n1].copy()

    @cached_property
    def J2(self) -> Array:
        """Twist of e relative to {b} per q̇2, at e, in {b}'s axes (6×n2), eq:J2."""
        return twist_rotate(self.R_b.T) @ self.J_e[:, self.n1 :]

    @cached_property
    def S_t1(self) -> Array:
        """[[I, [b − e]×], [0, I]] (6×6), eq:twists."""
        return twist_shift(self.b, self.e)

    @cached_property
    def S_t2(self) -> Array:
        """diag(⁰R_b, ⁰R_b) (6×6), eq:twists."""
        return twist_rotate(self.R_b)

    @cached_property
    def J(self) -> Array:
        """Free-space Jacobian [S_t1 J1, S_t2 J2] (6×n), eq:J; equals J_e."""
        return np.hstack([self.S_t1 @ self.J1, self.S_t2 @ self.J2])

    @cached_property
    def J_braced(self) -> Array:
        """J̃ = [S_t1 (I − P) J1, S_t2 J2] (6×n), eq:J_wave."""
        return np.hstack([self.S_t1 @ (np.eye(6) - self.P) @ self.J1, self.S_t2 @ self.J2])

    @cached_property
    def chain1_map(self) -> Array:
        """dq1/db̃ (n1×l'): joint velocities of chain 1 per coordinate of the braced motion of {b}.

        With n1 = 6 this is J1⁻¹ H (eq:q1, eq:dq_dh2). Otherwise it is an orthonormal basis of the null
        space of Xᵀ J1 (the chain-1 motions that keep the contact), so any n1 works.
        Raises SingularityError when J1 (n1 = 6) is singular.
        """
        j1 = self.J1
        if self.n1 == 6:
            s = np.linalg.svd(j1, compute_uv=False)
            if s[-1] <= s[0] / J1_COND_LIMIT:
                raise SingularityError(
                    f"J1 is singular at this configuration (cond = {s[0] / max(s[-1], 1e-300):.3g}); "
                    "chain 1 cannot realise the bracing motion"
                )
            return np.asarray(np.linalg.solve(j1, self.H), dtype=np.float64)
        return contact_null_space(self.X.T @ j1)

    @cached_property
    def A(self) -> Array:
        """Braced Jacobian [S_t1 H, S_t2 J2] (6×(l+n2)), eq:braced_kin (S_t1 J1 G with G = chain1_map)."""
        first = self.S_t1 @ self.H if self.n1 == 6 else self.S_t1 @ self.J1 @ self.chain1_map
        return np.hstack([first, self.S_t2 @ self.J2])

    @cached_property
    def z_b(self) -> Array:
        """ẑ_b, world axes (3,)."""
        return self.R_b[:, 2].copy()
