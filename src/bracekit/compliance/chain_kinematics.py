"""Vectorised forward kinematics of a chain over many configurations: the product of exponentials.

Mᵢ = M_parent · placementᵢ · exp(Sᵢ qᵢ) from the Pinocchio model's joint placements and motion subspaces,
checked against Pinocchio when it is built; placements and LOCAL_WORLD_ALIGNED Jacobians of chosen frames
over N configurations at once (:mod:`bracekit.compliance.batch` uses it).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike, NDArray

from bracekit._linalg import as_array
from bracekit.errors import InputError
from bracekit.kinematics import LWA
from bracekit.model.chain import DATA_JOINT_LIMIT, joint_axis
from bracekit.model.robot import Robot

Array = NDArray[np.float64]

__all__ = ["ChainKinematics", "FramesBatch"]


def _frame_with_z(axis: Array) -> Array:
    """A rotation U with U e_z = axis (unit): the identity for the z axis, so z-joints stay exact."""
    if np.allclose(axis, (0.0, 0.0, 1.0), rtol=0.0, atol=1e-15):
        return np.eye(3)
    seed = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(seed, axis)
    x /= np.linalg.norm(x)
    return np.column_stack((x, np.cross(axis, x), axis))


@dataclass(frozen=True)
class FramesBatch:
    """Placements and LOCAL_WORLD_ALIGNED Jacobians of some frames over N configurations.

    Attributes:
        position: (F, N, 3) frame origins, m, world. rotation: (F, N, 3, 3) ⁰R_f.
        jacobian: (F, N, 6, n) geometric Jacobians at the frame origins, world axes, [v; ω].
    """

    position: Array
    rotation: Array
    jacobian: Array


class ChainKinematics:
    """Vectorised forward kinematics and frame Jacobians of a robot's chain (product of exponentials).

    Every joint must be 1-DoF with a constant motion subspace S = [v; ω] in its own frame whose linear
    part is along ω (revolute, prismatic, helical): then exp(S q) is a rotation about ω̂ by |ω| q and a
    translation v q. The construction checks this and compares with Pinocchio at random configurations;
    ``exact`` is False (and :meth:`frames` uses Pinocchio) when it does not hold to 1e-12.
    """

    def __init__(self, robot: Robot, frame_ids: Sequence[int]) -> None:
        model = robot.model
        self.robot = robot
        self.frame_ids = tuple(int(f) for f in frame_ids)
        self.n = robot.n
        njoints = model.njoints
        self._parent = [int(model.parents[j]) for j in range(njoints)]
        self._col = [int(model.joints[j].idx_v) for j in range(njoints)]
        # Joint j turns about (slides along) its unit axis a_j = U_j e_z. Storing S_j = R_j U_j instead of R_j
        # makes every joint a z-joint: S_j = S_parent (U_parentᵀ R0_j U_j) Rz(|ω| q_j), whose update only
        # mixes two columns, and the axis in world axes is S_j's third column.
        u = [np.eye(3)]
        motion: list[tuple[float, float]] = [(0.0, 0.0)]  # (|ω|, signed speed along a_j) per unit q
        exact = True
        for s in self._motion_subspaces(model):
            v, w = s[:3], s[3:]
            nw, nv = float(np.linalg.norm(w)), float(np.linalg.norm(v))
            axis = w / nw if nw > 0 else (v / nv if nv > 0 else np.array([0.0, 0.0, 1.0]))
            along = float(v @ axis)
            if np.linalg.norm(v - along * axis) > 1e-12 * max(1.0, nv):
                exact = False  # a screw whose axis misses the joint origin: not handled here
            u.append(_frame_with_z(axis))
            motion.append((nw, along))
        self._motion = motion
        self._place = []
        for j in range(1, njoints):
            pl, up = model.jointPlacements[j], u[self._parent[j]]
            self._place.append((up.T @ np.array(pl.rotation) @ u[j], up.T @ np.array(pl.translation)))
        self._frames = []
        for f in self.frame_ids:
            fr = model.frames[f]
            uj = u[int(fr.parentJoint)]
            self._frames.append(
                (int(fr.parentJoint), uj.T @ np.array(fr.placement.rotation), uj.T @ np.array(fr.placement.translation))
            )
        self._supports = [[self._col[j] for j in model.supports[p][1:]] for p, _, _ in self._frames]
        self.exact = exact and self._check()

    def _motion_subspaces(self, model: pin.Model) -> list[Array]:
        """Each joint's motion subspace S = [v; ω] in its own frame (Pinocchio's, or from its axis on long chains)."""
        if self.n > DATA_JOINT_LIMIT:  # Pinocchio's Data is n³ in size: read the axes from the joint models
            out = []
            for j in range(1, model.njoints):
                kind = joint_axis(model.joints[j])
                if kind is None:
                    raise InputError(f"joint '{model.names[j]}' is not a revolute or prismatic joint")
                out.append(np.concatenate([np.zeros(3), kind[1]] if kind[0] else [kind[1], np.zeros(3)]))
            return out
        data = model.createData()
        pin.computeJointJacobians(model, data, pin.neutral(model))
        return [
            pin.getJointJacobian(model, data, j, pin.ReferenceFrame.LOCAL)[:, self._col[j]]
            for j in range(1, model.njoints)
        ]

    def _check(self) -> bool:
        rng = np.random.default_rng(0)
        lo, hi = self.robot.lower, self.robot.upper
        lo = np.where(np.isfinite(lo), lo, -np.pi)
        hi = np.where(np.isfinite(hi), hi, np.pi)
        q = rng.uniform(lo, hi, size=(4, self.n))
        ours, ref = self._poe(q), self._reference(q)
        return all(
            np.allclose(a, b, rtol=0.0, atol=1e-12)
            for a, b in zip(
                (ours.position, ours.rotation, ours.jacobian), (ref.position, ref.rotation, ref.jacobian), strict=True
            )
        )

    def frames(self, Q: ArrayLike) -> FramesBatch:
        """Placements and Jacobians of the frames at each row of Q (N×n)."""
        q = as_array(Q, "the configurations", (-1, self.n))
        return self._poe(q) if self.exact else self._reference(q)

    def _poe(self, q: Array) -> FramesBatch:
        N, n = q.shape
        # a rotation is stored by columns, shape (3, N, 3): r[c] = its column c for every configuration
        rot: list[Array] = [np.broadcast_to(np.eye(3)[:, None, :], (3, N, 3))]
        pos: list[Array] = [np.zeros((N, 3))]
        axes = np.empty((n, N, 3))  # joint axes (world) × |ω|, or the prismatic direction
        origins = np.empty((n, N, 3))
        revolute = np.zeros(n, dtype=bool)
        speed = np.array([self._motion[j][0] for j in range(1, len(self._parent))])
        angle = np.ascontiguousarray(q.T[[self._col[j] for j in range(1, len(self._parent))]])
        if np.any(speed != 1.0):
            angle *= speed[:, None]
        cos, sin = np.cos(angle), np.sin(angle)  # (joints, N)
        for j in range(1, len(self._parent)):
            rp, pp = rot[self._parent[j]], pos[self._parent[j]]
            r0, t0 = self._place[j - 1]
            flat = rp.reshape(3, 3 * N)
            rj = (r0.T @ flat).reshape(3, N, 3)  # S_parent A_j
            pj = pp + (t0 @ flat).reshape(N, 3)
            nw, along = self._motion[j]
            col = self._col[j]
            origins[col] = pj
            if along:
                pj = pj + rj[2] * (along * q[:, col])[:, None]
            if nw:
                c, s = cos[j - 1][:, None], sin[j - 1][:, None]
                x, y = rj[0], rj[1]
                new = np.empty_like(rj)
                np.multiply(c, x, out=new[0])
                new[0] += s * y
                np.multiply(c, y, out=new[1])
                new[1] -= s * x
                new[2] = rj[2]
                rj = new
                axes[col] = rj[2] if nw == 1.0 else rj[2] * nw
                revolute[col] = True
            else:
                axes[col] = rj[2] * along
            rot.append(rj)
            pos.append(pj)
        F = len(self._frames)
        positions, rotations, jacobians = np.empty((F, N, 3)), np.empty((F, N, 3, 3)), np.zeros((F, N, 6, n))
        for f, ((parent, r_f, t_f), cols) in enumerate(zip(self._frames, self._supports, strict=True)):
            rj, pj = rot[parent], pos[parent]
            flat = rj.reshape(3, 3 * N)
            p_f = pj + (t_f @ flat).reshape(N, 3)
            rotations[f] = (r_f.T @ flat).reshape(3, N, 3).transpose(1, 2, 0)  # (N, 3, 3) rows × columns
            positions[f] = p_f
            jac = jacobians[f]
            rev = [c for c in cols if revolute[c]]
            if rev:
                z = axes[rev]  # (k, N, 3)
                r = p_f[None] - origins[rev]
                jac[:, :3, rev] = np.stack(
                    (
                        z[..., 1] * r[..., 2] - z[..., 2] * r[..., 1],
                        z[..., 2] * r[..., 0] - z[..., 0] * r[..., 2],
                        z[..., 0] * r[..., 1] - z[..., 1] * r[..., 0],
                    )
                ).transpose(2, 0, 1)
                jac[:, 3:, rev] = z.transpose(1, 2, 0)
            pri = [c for c in cols if not revolute[c]]
            if pri:
                jac[:, :3, pri] = axes[pri].transpose(1, 2, 0)
        return FramesBatch(positions, rotations, jacobians)

    def _reference(self, q: Array) -> FramesBatch:
        """The frames one configuration at a time: Pinocchio, or ChainFK beyond DATA_JOINT_LIMIT joints."""
        if self.n <= DATA_JOINT_LIMIT:
            return self._pinocchio(q)
        F, N = len(self.frame_ids), q.shape[0]
        positions, rotations = np.empty((F, N, 3)), np.empty((F, N, 3, 3))
        jacobians = np.empty((F, N, 6, self.n))
        for i in range(N):
            for f, (m, jac) in enumerate(self.robot.frame_kinematics(q[i], self.frame_ids)):
                positions[f, i], rotations[f, i], jacobians[f, i] = m[:3, 3], m[:3, :3], jac
        return FramesBatch(positions, rotations, jacobians)

    def _pinocchio(self, q: Array) -> FramesBatch:
        model = self.robot.model
        data = model.createData()
        F, N = len(self.frame_ids), q.shape[0]
        positions, rotations = np.empty((F, N, 3)), np.empty((F, N, 3, 3))
        jacobians = np.empty((F, N, 6, self.n))
        for i in range(N):
            pin.computeJointJacobians(model, data, q[i])
            pin.updateFramePlacements(model, data)
            for f, fid in enumerate(self.frame_ids):
                m = data.oMf[fid].homogeneous
                positions[f, i], rotations[f, i] = m[:3, 3], m[:3, :3]
                jacobians[f, i] = pin.getFrameJacobian(model, data, fid, LWA)
        return FramesBatch(positions, rotations, jacobians)
