"""Pink tasks of a braced robot: :class:`BraceTask` (the contacts) and :class:`ComplianceTask` (C_i along β_x).

Pink's QP is over the displacement Δq = q̇ dt (n,), rad (m for a prismatic joint); a task gives its error e(q) and
Jacobian J(q) = ∂e/∂q, and pink asks J Δq = −gain · e (a hard equality when the task is in ``constraints``, a
weighted least-squares cost when it is in ``tasks``).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike, NDArray
from pink.tasks import Task

from bracekit._linalg import as_number
from bracekit.compliance.first_order import ComplianceModel, unit6
from bracekit.errors import InputError
from bracekit.kinematics import BracedRobot
from bracekit.kinematics.hessian import LWA
from bracekit.objective.compliance_index import ComplianceIndex
from pink import Configuration

Array = NDArray[np.float64]


class BraceFrame(NamedTuple):
    """One brace at the configuration: b_i (3,), m, world; ⁰R_b_i (3×3); J_b_i (6×n, LOCAL_WORLD_ALIGNED); X_i."""

    b: Array
    R_b: Array
    J_b: Array
    X: Array


def brace_frames(braced: BracedRobot, configuration: Configuration) -> list[BraceFrame]:
    """The adapter to bracekit's model: every brace's {b_i}, J_b_i and X_i from pink's Pinocchio data.

    Pink's ``Configuration.update`` has run computeJointJacobians and updateFramePlacements on its data.
    """
    model, data = configuration.model, configuration.data
    out = []
    for brace, fid in zip(braced.braces, braced.brace_ids, strict=True):
        placement = data.oMf[fid]
        jac = pin.getFrameJacobian(model, data, fid, LWA)
        out.append(BraceFrame(placement.translation.copy(), placement.rotation.copy(), jac, brace.X()))
    return out


def compliance_index(braced: BracedRobot, q: Array, beta_x: Array, model: ComplianceModel) -> tuple[float, Array]:
    """The adapter to bracekit's compliance: (C_i (m/N), ∂C_i/∂q (n,)) at q, for any number of braces.

    The analytic gradient through the kinematic Hessians (eq:compliance_index); ``projection`` needs one brace.
    """
    term = ComplianceIndex(beta_x, model)
    state = braced.state(q, hessians=True)
    return term.value(state), term.gradient(state)


class BraceTask(Task):
    """Keep every brace on its surface: e_i = X_iᵀ [b_i − a_i; θ_i] (eq:constraint), J_i = X_iᵀ J_b_i.

    a_i is the anchor of brace i (its point when the task is made or :meth:`set_anchors` is called) moved onto the
    brace's plane along the normal, θ_i = ⁰R_a_i log(⁰R_a_iᵀ ⁰R_b_i) the rotation from the anchor's orientation
    (rad, world axes). A frictionless
    point contact (X = [n̂; 0]) constrains only the signed distance n̂ᵀ(b_i − p_i) to the plane; a contact with
    friction also holds b_i at a_i along the plane, a soft finger its spin about n̂.

    Pink ≥ 4.4 takes it as a hard equality: ``solve_ik(..., constraints=[brace_task])`` gives
    X_iᵀ J_b_i Δq = −gain · e_i exactly (gain 1: the offset is closed in one step). In ``tasks`` it is a cost of
    weight ``cost`` (1/m) instead.
    """

    def __init__(self, braced: BracedRobot, configuration: Configuration, cost: float = 1.0, gain: float = 1.0):
        super().__init__(cost=as_number(cost, "the brace task's cost", positive=True), gain=gain)
        if not isinstance(braced, BracedRobot):
            raise InputError(f"a BraceTask needs a bracekit BracedRobot, got {type(braced).__name__}")
        self.braced = braced
        self.anchors: list[tuple[Array, Array]] = []
        self._cache: tuple[bytes, list[BraceFrame]] | None = None
        self.set_anchors(configuration)

    def _frames(self, configuration: Configuration) -> list[BraceFrame]:
        """brace_frames at the configuration, once per q (pink asks for the error, then the Jacobian)."""
        key = np.asarray(configuration.q, dtype=float).tobytes()
        if self._cache is None or self._cache[0] != key:
            self._cache = (key, brace_frames(self.braced, configuration))
        return self._cache[1]

    def set_anchors(self, configuration: Configuration) -> None:
        """Anchor every brace at its current point (moved onto its plane) and orientation."""
        self.anchors = []
        for brace, frame in zip(self.braced.braces, self._frames(configuration), strict=True):
            n = brace.surface.normal
            self.anchors.append((frame.b - n * brace.surface.signed_distance(frame.b), frame.R_b))

    def compute_error(self, configuration: Configuration) -> Array:
        """E = [X_iᵀ [b_i − a_i; θ_i]] stacked over the braces (m for a force row, rad for a moment row)."""
        parts = []
        for frame, (a, r_a) in zip(self._frames(configuration), self.anchors, strict=True):
            twist = np.concatenate([frame.b - a, r_a @ pin.log3(r_a.T @ frame.R_b)])
            parts.append(frame.X.T @ twist)
        return np.concatenate(parts)

    def compute_jacobian(self, configuration: Configuration) -> Array:
        """J = ∂e/∂q stacked over the braces (rows × n): X_iᵀ J_b_i on the surface (θ_i = 0), exact off it.

        θ_i = ⁰R_a log(⁰R_aᵀ ⁰R_b) (world axes) moves as ⁰R_a Jlog3(⁰R_aᵀ ⁰R_b) ⁰R_bᵀ J_ω,b.
        """
        rows = []
        for frame, (_, r_a) in zip(self._frames(configuration), self.anchors, strict=True):
            rel = r_a.T @ frame.R_b
            j_rot = r_a @ pin.Jlog3(rel) @ frame.R_b.T @ frame.J_b[3:]
            rows.append(frame.X.T @ np.vstack([frame.J_b[:3], j_rot]))
        return np.vstack(rows)

    def __repr__(self) -> str:
        """The braces it holds."""
        return f"BraceTask(braces={[b.frame for b in self.braced.braces]}, cost={self.cost}, gain={self.gain})"


class ComplianceTask(Task):
    """Lower C_i = ‖β_xᵀ C_e‖ (eq:compliance_index, m/N): cost ½ μ ‖Δq‖² + w (∂C_i/∂q)ᵀ Δq in pink's QP.

    Without other tasks the step is Δq = −(w/μ) ∂C_i/∂q, a gradient step on C_i; beside a FrameTask and a
    BraceTask it acts in what they leave free, as the objective's gradient of eq:grad_proj does. w is ``cost``
    (N/m per rad: it makes w C_i a cost), μ ``regularization`` (per rad²).

    Args:
        braced: the braced robot (its Pinocchio model is the configuration's).
        beta_x: the unit twist (6,) along which C_i is measured; normalised.
        cost: w > 0.
        regularization: μ > 0.
        model: the compliance model of C_e (``constrained`` for any number of braces, ``projection`` for one).
    """

    cost: float  # w: always a number here (pink allows a vector or None)

    def __init__(
        self,
        braced: BracedRobot,
        beta_x: ArrayLike,
        cost: float = 1.0,
        regularization: float = 1.0,
        model: ComplianceModel = "constrained",
    ):
        super().__init__(cost=as_number(cost, "the compliance task's cost", positive=True))
        self.braced = braced
        self.beta_x = unit6(beta_x, "beta_x")
        self.regularization = as_number(regularization, "the compliance task's regularization", positive=True)
        self.model: ComplianceModel = model

    def value(self, configuration: Configuration) -> float:
        """C_i (m/N) at the configuration."""
        return compliance_index(self.braced, configuration.q, self.beta_x, self.model)[0]

    def compute_error(self, configuration: Configuration) -> Array:
        """[C_i] (m/N): what the task lowers (it has no target: a linear cost, not J Δq = −e)."""
        return np.array([self.value(configuration)])

    def compute_jacobian(self, configuration: Configuration) -> Array:
        """∂C_i/∂q (1×n), analytic for one brace."""
        return compliance_index(self.braced, configuration.q, self.beta_x, self.model)[1][None, :]

    def compute_qp_objective(self, configuration: Configuration) -> tuple[Array, Array]:
        """(μ I, w ∂C_i/∂q): the task's Hessian and linear term in Δq."""
        grad = compliance_index(self.braced, configuration.q, self.beta_x, self.model)[1]
        n = grad.size
        return self.regularization * np.eye(n), float(self.cost) * grad

    def __repr__(self) -> str:
        """Its β_x and weights."""
        return f"ComplianceTask(beta_x={self.beta_x.tolist()}, cost={self.cost}, regularization={self.regularization})"
