"""Redundancy resolution with several braces: the braced motions N of the stacked constraint G.

With several braces the chain does not split at one {b}, so the paper's A, eq:q1 and eq:grad_g have no
meaning. Their counterparts act on the braced motions q̇ = N y (N: orthonormal basis of the null space of
G = [X_1ᵀ J_b1; X_2ᵀ J_b2; …], :mod:`bracekit.kinematics.constraint`), with S the task rows of a
:class:`~bracekit.resolution.task_space.TaskSpace` and B = S J_e N (m×(n − rank G)):

* braced minimum norm (eq:general_inv with η = 0): q̇ = N B⁺ S ẋ. As N is orthonormal, this is the least-norm
  q̇ with G q̇ = 0 and S J_e q̇ = S ẋ.
* braced gradient projection (eq:grad_proj): q̇ = N [B⁺ S ẋ + α (I − B⁺ B) Nᵀ ∇g], α < 0, with ∇g = ∂g/∂q of
  :class:`MultiBraceObjective`: its C_i and d terms by central differences (the stacked state has no kinematic
  Hessians), its joint-limit barrier exactly. Nᵀ ∇g is the gradient of g over the braced coordinates y (the
  counterpart of eq:grad_g).

B must have full row rank (m ≤ n − rank G, σ_min/σ_max > STEP_SINGULAR_RATIO); otherwise the braces leave the
task undoable and SingularityError says so.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from bracekit._linalg import as_number
from bracekit.compliance.first_order import compliance_index, constrained_compliance, unit6
from bracekit.compliance.measures import region_barrier, theta_z
from bracekit.errors import BarrierError, InputError, NumericalError
from bracekit.kinematics.braced import BracedRobot, BracedState
from bracekit.objective.joint_limit_barrier import JointLimitBarrier
from bracekit.resolution.task_space import POSE, TaskSpace, select

Array = NDArray[np.float64]

#: Printed names of the matrices whose conditioning a several-brace run records (``sigma_ratio_<key>``):
#: G over its independent rows, and B = S J_e N.
MULTI_MATRIX_LABELS = {"G": "G (independent rows)", "SJN": "S J_e N"}
#: The objective weights a several-brace objective takes from a one-brace Objective (term keys).
MULTI_TERM_KEYS = ("Ci", "theta_z", "d", "joint_limit_barrier")


@dataclass(frozen=True)
class MultiBraceObjective:
    """g = w_Ci C_i + w_θ Σ_i θ_z,i + w_d Σ_i d_i + w_q h(q): g of eq:objective with several braces.

    C_i = ‖β_xᵀ C_e‖ (eq:compliance_index, m/N) of the stacked constrained C_e (``constrained_compliance``);
    d_i = r_max_i² / (r_max_i² − r_i²) the region barrier of brace i (after eq:theta), r_i = ‖b_i − p_t,i‖ (m)
    with p_t,i the brace's ``surface.point``, for each brace with a ``region_radius`` r_max_i (the others
    have no d_i). BarrierError when a brace is at or beyond its r_max_i. θ_z,i (eq:theta, rad) is the angle
    between brace i's surface normal and the z axis of its {b_i}, for each brace with a pad axis
    (``Brace.pad_axis``; the others have none).
    h(q) = Σ_j [span_j² / (4 (q_max,j − q_j)(q_j − q_min,j)) − 1] is the joint-limit barrier of Chan and Dubey
    (:class:`~bracekit.objective.JointLimitBarrier`) over the robot's URDF limits (dimensionless; BarrierError at
    a limit); it enters only when w_q > 0.

    Args:
        beta_x: the unit twist (6,) along which C_i is measured; normalised.
        ci_weight: w_Ci ≥ 0 (N/m makes g dimensionless; the paper's α2).
        region_weight: w_d ≥ 0, the same for every brace with a region (the paper's α4).
        theta_weight: w_θ ≥ 0, the same for every brace with a pad axis (the paper's α3).
        joint_limit_weight: w_q ≥ 0, the weight of the joint-limit barrier h (0: no such term).
    """

    beta_x: Array
    ci_weight: float = 1.0
    region_weight: float = 0.0
    joint_limit_weight: float = 0.0
    theta_weight: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "beta_x", unit6(self.beta_x, "beta_x"))
        for what in ("ci_weight", "region_weight", "joint_limit_weight", "theta_weight"):
            object.__setattr__(self, what, as_number(getattr(self, what), what, nonnegative=True))

    @classmethod
    def from_objective(cls, objective: Any) -> MultiBraceObjective:
        """The several-brace objective with the weights of a one-brace Objective's C_i, d and joint-limit barrier.

        β_x is that of the objective's C_i term (key ``Ci``; its compliance model is replaced by the stacked
        constrained one). The d term's weight applies to every brace with a region, each with its own r_max_i
        and centre. A joint-limit barrier term (key ``joint_limit_barrier``) gives w_q; the barrier then uses the
        robot's URDF limits, a θ_z term (key ``theta_z``) w_θ. Other terms (k, clearance, …) have no several-brace form
        yet and are left out: see
        :meth:`left_out`. InputError without a C_i term.
        """
        if isinstance(objective, MultiBraceObjective):
            return objective
        ci = [(t, w) for t, w in zip(objective.terms, objective.weights, strict=True) if _key(t) == "Ci"]
        if len(ci) != 1:
            raise InputError(
                "gradient projection with several braces needs exactly one compliance-index term (key 'Ci') in "
                f"its objective, got {len(ci)}"
            )
        pairs = list(zip(objective.terms, objective.weights, strict=True))
        d = sum(float(w) for t, w in pairs if _key(t) == "d")
        theta = sum(float(w) for t, w in pairs if _key(t) == "theta_z")
        limits = sum(float(w) for t, w in pairs if _key(t) == "joint_limit_barrier")
        return cls(
            beta_x=ci[0][0].beta_x,
            ci_weight=float(ci[0][1]),
            region_weight=d,
            joint_limit_weight=limits,
            theta_weight=theta,
        )

    @staticmethod
    def left_out(objective: Any) -> tuple[str, ...]:
        """Names of the weighted terms of a one-brace Objective that :meth:`from_objective` leaves out."""
        if isinstance(objective, MultiBraceObjective):
            return ()
        return tuple(
            str(getattr(t, "name", type(t).__name__))
            for t, w in zip(objective.terms, objective.weights, strict=True)
            if w and _key(t) not in MULTI_TERM_KEYS
        )

    def with_beta_x(self, beta_x: ArrayLike) -> MultiBraceObjective:
        """The objective with β_x replaced by a new twist (6,), normalised."""
        return replace(self, beta_x=np.asarray(beta_x, dtype=float))

    def values(self, state: BracedState) -> dict[str, float]:
        """Each term's unweighted value: ``Ci`` (m/N), ``d_<i>`` and, when w_q > 0, ``joint_limit_barrier``.

        ``d_<i>`` for each brace i with a region; ``joint_limit_barrier`` is h (dimensionless).
        """
        out = self._braced_values(state)
        if self.joint_limit_weight:
            out["joint_limit_barrier"] = _limit_barrier(state).of_q(state.q)
        return out

    def _braced_values(self, state: BracedState) -> dict[str, float]:
        out = {"Ci": compliance_index(constrained_compliance(_stacked(state)), self.beta_x)}
        for i, r in enumerate(region_radii(state)):
            r_max = state.braced.braces[i].region_radius
            if r_max is not None:
                if r >= r_max:
                    raise BarrierError(
                        f"the bracing point of braces[{i}] is outside its bracing region (r = {r:.4g} m ≥ r_max = "
                        f"{r_max:g} m)"
                    )
                out[f"d_{i}"] = region_barrier(r, r_max)
        for i, brace in enumerate(state.braced.braces):
            if brace.pad_axis:
                out[f"theta_z_{i}"] = theta_z(brace.surface.normal, state.R_b_i[i][:, 2])
        return out

    def _braced_value(self, state: BracedState) -> float:
        """w_Ci C_i + w_d Σ_i d_i: the terms that need the stacked kinematics."""
        vals = self._braced_values(state)
        d = sum(v for k, v in vals.items() if k.startswith("d_"))
        theta = sum(v for k, v in vals.items() if k.startswith("theta_z_"))
        out = self.ci_weight * vals["Ci"] + (self.region_weight * d if self.region_weight else 0.0)
        return float(out + (self.theta_weight * theta if self.theta_weight else 0.0))

    def value(self, state: BracedState) -> float:
        """G at the state (the weighted sum of :meth:`values`)."""
        out = self._braced_value(state)
        if self.joint_limit_weight:
            out += self.joint_limit_weight * _limit_barrier(state).of_q(state.q)
        return float(out)

    def gradient(self, braced: BracedRobot, q: ArrayLike, step: float = 1e-5) -> Array:
        """∂g/∂q (n,): C_i and d by central differences, δq = step (rad; m for a prismatic joint), plus w_q ∂h/∂q.

        The differenced part is the paper's ∂g/∂q; the joint-limit barrier's gradient is
        :meth:`JointLimitBarrier.gradient_of_q`, exact (a difference of h would step past a limit close to it).
        """
        x = braced.robot.check_q(q)
        out = np.empty(x.size)
        for i in range(x.size):
            dq = np.zeros(x.size)
            dq[i] = step
            out[i] = (self._braced_value(braced.state(x + dq)) - self._braced_value(braced.state(x - dq))) / (2 * step)
        if self.joint_limit_weight:
            out += self.joint_limit_weight * JointLimitBarrier(braced.robot.lower, braced.robot.upper).gradient_of_q(x)
        if not np.all(np.isfinite(out)):
            raise NumericalError("the gradient of the several-brace objective is not finite")
        return out


def _limit_barrier(state: BracedState) -> JointLimitBarrier:
    """The joint-limit barrier over the URDF limits of the state's robot."""
    robot = state.braced.robot
    return JointLimitBarrier(robot.lower, robot.upper)


def _key(term: object) -> str:
    return str(getattr(term, "key", ""))


def _stacked(state: object) -> BracedState:
    if not isinstance(state, BracedState):
        raise InputError(f"expected a BracedState (from BracedRobot.state(q)), got {type(state).__name__}")
    return state


def region_radii(state: BracedState) -> tuple[float, ...]:
    """r_i = ‖b_i − surface_i.point‖ (m) of each brace, in the order of ``braced.braces``."""
    return tuple(
        float(np.linalg.norm(b - brace.surface.point)) for b, brace in zip(state.b_i, state.braced.braces, strict=True)
    )


def task_rows(state: BracedState, xdot: Array, space: TaskSpace = POSE) -> tuple[Array, Array]:
    """(B = S J_e N (m×(n − rank G)), S ẋ (m,)) at the state."""
    return select(space, _stacked(state).R_e, state.braced_jacobian, xdot)


def sigma_ratios(state: BracedState, space: TaskSpace = POSE) -> dict[str, float]:
    """σ_min/σ_max of G over its independent rows (key ``G``) and of S J_e N (key ``SJN``); 0 when rank deficient.

    A matrix with more rows than columns has rank below its rows: its ratio is 0.
    """
    out = {}
    con = state.constraint
    g = con.G[list(con.independent)]
    b = task_rows(state, np.zeros(6), space)[0]
    for key, m in (("G", g), ("SJN", b)):
        if m.size == 0:
            out[key] = 1.0 if m.shape[0] == 0 else 0.0
            continue
        s = np.linalg.svd(m, compute_uv=False)
        out[key] = float(s[-1] / s[0]) if m.shape[1] >= m.shape[0] and s[0] > 0 else 0.0
    return out
