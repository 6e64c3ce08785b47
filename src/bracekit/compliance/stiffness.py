"""The 6×6 stiffness of the braced robot at the tool, first order or preloaded, in a chosen frame.

docs/model.md, section 12 derives it. In short: hold the tool displaced by a small δx = [δp; δθ] (m, rad; the
tip point e, the frame's axes) with every brace closed; the wrench w = [f; m] (N, N·m) on the robot at e needed
to hold it is w = K_x δx. It comes from one bordered (KKT) system over the joints, every kept contact row and
the six tool rows,

    [K_t, −Gᵀ, −J_eᵀ; −G, −D, 0; −J_e, 0, 0] [δq; δλ; w] = [0; 0; −δx],

with G = [X_1ᵀ J_b1; X_2ᵀ J_b2; …] the stacked constraint (one brace is one row block), D = diag(1/k_env) per
row (0 for a rigid surface) and K_t the tangent joint stiffness: K plus the geometric stiffness of gravity, of a
dead tool wrench w0 and of each brace's preload f_c0,i = P_i [n̂_i; 0]. The preload's term is the constraint
curvature λᵀ∇²φ of every brace, Σ_r f_c0,i,r ∂J_b_i[r]/∂q (S.-F. Chen and I. Kao, IJRR 2000). Where the tip
compliance C is invertible, K_x = C⁻¹; the bordered form needs no inverse of C and says why it fails (a tool
direction the braces lock, or an unstable equilibrium).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike, NDArray

from bracekit._linalg import as_array, finite_math, show
from bracekit.compliance.first_order import end_effector_compliance
from bracekit.compliance.preloaded import preloaded_compliance
from bracekit.errors import InputError, ModelError, SingularityError, UnstableEquilibriumError
from bracekit.kinematics import BracedRobot, BracedState, contact_null_space
from bracekit.kinematics.braced import MAX_HESSIAN_JOINTS
from bracekit.kinematics.hessian import ensure_hessian_layout, frame_hessian
from bracekit.spatial import twist_rotate

Array = NDArray[np.float64]

__all__ = ["ToolStiffness", "frame_axes", "stacked_tangent_stiffness", "stiffness_report", "tool_stiffness"]

#: σ_min/σ_max of J_e N (the tool motions the rigid braces allow) at or below which a tool direction is locked.
LOCKED_RATIO = 1e-10

UNITS = (
    "w = K δx: the wrench [f; m] (N, N·m) on the robot at the tool point e that holds a small tool displacement "
    "δx = [δp; δθ] (m, rad), both in the frame's axes; blocks N/m, N/rad, N·m/m, N·m/rad"
)


@dataclass(frozen=True)
class ToolStiffness:
    """The tool stiffness K_x (6×6) of the braced robot and how it was obtained.

    Attributes:
        K: K_x as computed: w = K δx (the frame's axes, reference point e). Not symmetric when a dead tool
            moment acts (it is not conservative); otherwise symmetric to round-off.
        frame: "world", "tool" (the axes of {e} at q, held fixed) or "given".
        R: the frame's axes in world coordinates (3×3, columns x̂, ŷ, ẑ).
        point: the reference point e (world, m).
        model: "first_order" (K_t = K) or "preloaded" (geometric stiffness of the loads).
        preload: P_i of each brace, N.
        gravity: whether gravity's geometric stiffness ∂g/∂q is in K_t.
        wrench: the dead tool wrench w0 [f; m] on the robot at e (world axes; N, N·m).
    """

    K: Array
    frame: str
    R: Array
    point: Array
    model: str
    preload: tuple[float, ...]
    gravity: bool
    wrench: Array

    @property
    def K_sym(self) -> Array:
        """The symmetric part ½(K + Kᵀ): the conservative stiffness a controller can realise (section 12)."""
        return 0.5 * (self.K + self.K.T)

    @property
    def asymmetry(self) -> float:
        """‖K − Kᵀ‖_F / ‖K‖_F (0 for a conservative load; the same in every frame)."""
        return float(np.linalg.norm(self.K - self.K.T) / max(float(np.linalg.norm(self.K)), 1e-300))

    def in_frame(self, frame: str | ArrayLike, tool_axes: ArrayLike | None = None) -> ToolStiffness:
        """The same stiffness in another frame's axes (reference point e unchanged): K_f = Tᵀ K_w T, T = diag(R, R).

        `frame` is "world", a 3×3 rotation, or "tool" with `tool_axes` = ⁰R_e (the frame "tool" needs it unless
        this stiffness is already in the tool frame).
        """
        if isinstance(frame, str) and frame == "tool" and tool_axes is None:
            if self.frame != "tool":
                raise InputError("in_frame('tool') needs tool_axes = ⁰R_e (3×3), or use tool_stiffness(frame='tool')")
            return self
        name, r = frame_axes(frame, tool_axes)
        t_old, t_new = twist_rotate(self.R), twist_rotate(r)
        k_world = t_old @ self.K @ t_old.T
        return replace(self, K=t_new.T @ k_world @ t_new, frame=name, R=r)

    def as_dict(self) -> dict[str, Any]:
        """A JSON-able description (SI; matrices row-major)."""
        return {
            "frame": self.frame,
            "R": self.R,
            "reference_point": self.point,
            "model": self.model,
            "preload_N": list(self.preload),
            "gravity": self.gravity,
            "tool_wrench": self.wrench,
            "K": self.K,
            "K_sym": self.K_sym,
            "asymmetry": self.asymmetry,
            "units": UNITS,
        }


def frame_axes(frame: str | ArrayLike, tool_axes: ArrayLike | None = None) -> tuple[str, Array]:
    """(name, R) of a frame: "world" (I), "tool" (`tool_axes`, ⁰R_e) or a rotation matrix (3×3, "given").

    InputError for another name or a matrix that is not a rotation (RᵀR = I to 1e-9, det R = +1).
    """
    if isinstance(frame, str):
        if frame == "world":
            return "world", np.eye(3)
        if frame == "tool" and tool_axes is not None:
            return "tool", _rotation(tool_axes, "the tool axes ⁰R_e")
        raise InputError(f"unknown stiffness frame {show(frame)}; choose world, tool or a 3×3 rotation matrix")
    return "given", _rotation(frame, "the stiffness frame")


def _rotation(value: ArrayLike, what: str) -> Array:
    r = as_array(value, what, (3, 3))
    if np.linalg.norm(r.T @ r - np.eye(3)) > 1e-9 or np.linalg.det(r) <= 0.0:
        raise InputError(f"{what} must be a rotation matrix (orthonormal columns, det +1), got {show(r)}")
    return r


def _preloads(preload: float | Sequence[float] | ArrayLike, count: int) -> tuple[float, ...]:
    p = as_array(preload, "the preload P (N)").reshape(-1)
    if p.size == 1:
        p = np.full(count, float(p[0]))
    if p.size != count or np.any(p < 0.0):
        raise InputError(f"give one preload P ≥ 0 N for every brace or one per brace ({count}), got {show(preload)}")
    return tuple(float(x) for x in p)


def stacked_tangent_stiffness(
    braced: BracedRobot, q: Array, preload: Sequence[float], *, gravity: bool, wrench: Array
) -> Array:
    """K_t = K + ∂g/∂q − ∂(J_eᵀ w0)/∂q − Σ_i ∂(J_b_iᵀ f_c0,i)/∂q (n×n, N·m/rad), f_c0,i = P_i [n̂_i; 0].

    The last sum is each brace's constraint curvature λ_iᵀ∇²φ_i (φ_i the contact's gap, λ_i its force); one
    kinematics pass with Pinocchio's kinematic Hessians gives every brace's term, for any number of braces.
    K, gravity, the tool force and the preloads are Hessians of potentials and are symmetrised (round-off);
    the tool moment's term is not symmetric (a dead moment is not conservative) and is kept as it is.
    """
    robot = braced.robot
    if robot.n > MAX_HESSIAN_JOINTS:
        raise ModelError(
            f"the preloaded stiffness needs kinematic Hessians, supported up to {MAX_HESSIAN_JOINTS} joints; the "
            f"robot has {robot.n}: use the first-order stiffness (no preload, gravity or tool wrench)"
        )
    model = robot.model
    data = model.createData()
    ids = (robot.tip_id, *braced.brace_ids)
    ensure_hessian_layout(model, data, ids)
    pin.computeJointJacobians(model, data, q)
    pin.updateFramePlacements(model, data)
    pin.computeJointKinematicHessians(model, data)
    d_je = frame_hessian(model, data, robot.tip_id)
    with finite_math("the tangent stiffness"):
        k_sym = np.diag(robot.stiffness) - np.einsum("r,rik->ik", wrench[:3], d_je[:3])
        for brace, fid, p in zip(braced.braces, braced.brace_ids, preload, strict=True):
            if p:
                f_c0 = np.concatenate([p * brace.surface.normal, np.zeros(3)])
                k_sym -= np.einsum("r,rik->ik", f_c0, frame_hessian(model, data, fid))
        if gravity:
            k_sym += pin.computeGeneralizedGravityDerivatives(model, model.createData(), q)
        k_t: Array = 0.5 * (k_sym + k_sym.T) - np.einsum("r,rik->ik", wrench[3:], d_je[3:])
    return k_t


def tool_stiffness(
    state: BracedState,
    frame: str | ArrayLike = "world",
    *,
    preload: float | Sequence[float] = 0.0,
    gravity: bool = False,
    wrench: ArrayLike | None = None,
) -> ToolStiffness:
    """The 6×6 stiffness K_x of the braced robot at the tool point e, w = K_x δx (section 12).

    One path for one brace and several: the state's robot with all its braces (``braced.state(q)`` or
    ``braced.state(q)``; only its robot and q are used), every brace closed (rigid, or a spring of
    stiffness k_env), dependent or unloaded contact rows dropped as in the constrained compliance.

    Args:
        state: the braced robot at q.
        frame: "world", "tool" (the axes of {e} at q) or a 3×3 rotation (the frame's axes in world coordinates).
        preload: P ≥ 0 (N) that each brace presses with along its normal: one number or one per brace.
        gravity: include gravity's geometric stiffness ∂g/∂q (URDF masses, the model's gravity vector).
        wrench: a dead tool wrench w0 = [f; m] (N, N·m, world axes) acting at q; default none.

    Returns:
        :class:`ToolStiffness`; with no preload, gravity or tool wrench it is the first-order stiffness, the
        inverse of the constrained C_e (eq:Ce), else the inverse of the preloaded compliance.

    Raises:
        SingularityError: the rigid braces lock the tool along some direction (J_e N of rank < 6): the stiffness
            is unbounded there (export the compliance instead).
        UnstableEquilibriumError: the loads overcome the joint springs (K_t not positive on the allowed motions).
        InputError: a bad frame, preload or wrench.
    """
    if not isinstance(state, BracedState):
        raise InputError(f"tool_stiffness needs the braced robot's state (braced.state(q)), got {type(state).__name__}")
    if not isinstance(gravity, bool):
        raise InputError(f"gravity must be True or False, got {show(gravity)}")
    braced, q = state.braced, state.q
    stacked = state
    loads = _preloads(preload, len(braced.braces))
    w0 = np.zeros(6) if wrench is None else as_array(wrench, "the tool wrench w0 [f; m] (N, N·m)", (6,))
    name, r = frame_axes(frame, stacked.R_e)
    preloaded = gravity or any(loads) or bool(w0.any())
    k_t = (
        stacked_tangent_stiffness(braced, q, loads, gravity=gravity, wrench=w0)
        if preloaded
        else np.diag(braced.robot.stiffness)
    )
    k_world = _bordered_stiffness(stacked, k_t)
    t = twist_rotate(r)
    return ToolStiffness(
        K=t.T @ k_world @ t,
        frame=name,
        R=r,
        point=stacked.e.copy(),
        model="preloaded" if preloaded else "first_order",
        preload=loads,
        gravity=gravity,
        wrench=w0,
    )


def _bordered_stiffness(state: BracedState, k_t: Array) -> Array:
    """K_x in world axes at e from the bordered system of the module docstring (checks lock and stability)."""
    con = state.constraint
    rows = list(con.independent)
    g, d = con.G[rows], con.compliance[rows]
    j_e = state.J_e
    n, c = k_t.shape[0], len(rows)
    with finite_math("the tool stiffness"):
        rigid, soft = g[d == 0.0], g[d > 0.0]
        z = contact_null_space(rigid) if rigid.size else np.eye(n)
        s = np.linalg.svd(j_e @ z, compute_uv=False)
        free = int(np.sum(s > LOCKED_RATIO * max(float(s[0]) if s.size else 0.0, 1e-300)))
        if free < 6:
            raise SingularityError(
                f"the braces leave the tool {free} of its 6 directions of motion here (J_e N has rank {free}): its "
                "stiffness is unbounded along the others; use the tip compliance C_e instead, or a contact with "
                "fewer constraints or a finite environment stiffness"
            )
        reduced = z.T @ (k_t + soft.T @ (soft / d[d > 0.0][:, None])) @ z
        if not float(np.min(np.linalg.eigvals(reduced).real)) > 0.0:
            raise UnstableEquilibriumError(
                "the loaded equilibrium is unstable here: the tangent stiffness is not positive on the motions the "
                "braces allow (gravity, the tool wrench or the preload overcome the joint springs); reduce them"
            )
        kkt = np.zeros((n + c + 6, n + c + 6))
        kkt[:n, :n] = k_t
        kkt[:n, n : n + c] = -g.T
        kkt[n : n + c, :n] = -g
        kkt[n : n + c, n : n + c] = -np.diag(d)
        kkt[:n, n + c :] = -j_e.T
        kkt[n + c :, :n] = -j_e
        rhs = np.zeros((n + c + 6, 6))
        rhs[n + c :] = -np.eye(6)
        out: Array = np.linalg.solve(kkt, rhs)[n + c :]
    return out


def stiffness_report(state: BracedState, loaded: ToolStiffness) -> dict[str, Any]:
    """What ``bracekit evaluate --stiffness-out`` writes: `loaded` and the first-order stiffness in its frame.

    `loaded` is :func:`tool_stiffness` at `state` with the loads of the export (its preloads, gravity and tool
    wrench; none for the first order). ``first_order`` and, where `loaded` is preloaded, ``preloaded`` (each
    :meth:`ToolStiffness.as_dict`), with ``inverse_check`` = ‖K_x C − I‖_F / √6 against the compliance it must
    invert (the constrained C_e; the preloaded compliance under the same loads).

    Raises:
        InputError: `loaded` was not computed at `state` (another tool point e).
    """
    if not np.array_equal(loaded.point, state.e):
        raise InputError("stiffness_report needs the tool stiffness of the same state (tool_stiffness(state, ...))")
    first = loaded if loaded.model == "first_order" else tool_stiffness(state, _frame_of(loaded))
    t = twist_rotate(first.R)
    out: dict[str, Any] = {"first_order": first.as_dict()}
    c_e = t.T @ end_effector_compliance(state, "constrained") @ t
    out["first_order"]["inverse_check"] = float(np.linalg.norm(first.K @ c_e - np.eye(6)) / np.sqrt(6.0))
    if loaded.model == "preloaded":
        out["preloaded"] = loaded.as_dict()
        c_p = preloaded_compliance(state.braced, state.q, loaded.preload, gravity=loaded.gravity, wrench=loaded.wrench)
        c = t.T @ c_p @ t
        out["preloaded"]["inverse_check"] = float(np.linalg.norm(loaded.K @ c - np.eye(6)) / np.sqrt(6.0))
    return out


def _frame_of(stiffness: ToolStiffness) -> str | Array:
    """The ``frame`` argument of :func:`tool_stiffness` that gives `stiffness`'s axes again."""
    return stiffness.R if stiffness.frame == "given" else stiffness.frame
