"""A joint-limit term: Σ_i ((q_i − q̄_i) / (q_max,i − q_min,i))² over the joints with finite limits.

q̄_i = (q_min,i + q_max,i) / 2 is the middle of joint i's range. The term is 1/4 per joint at a limit and
0 at the middle; its gradient 2 (q − q̄) / span² needs no kinematics. Joints whose URDF range is unbounded
(continuous joints, ±inf) are left out.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bracekit._linalg import as_array
from bracekit.errors import InputError
from bracekit.objective.base import Array, JointTerm, TermContext, register_term


@register_term
@dataclass(frozen=True)
class JointLimits(JointTerm):
    """Σ_i ((q_i − q̄_i) / (q_max,i − q_min,i))² over the joints with finite `lower` and `upper` (n,).

    Dimensionless. A joint with an infinite lower or upper limit does not contribute.
    """

    lower: Array
    upper: Array
    name: str = "joint_limits"
    key = "joint_limits"

    def __post_init__(self) -> None:
        super().__post_init__()
        lower = as_array(self.lower, "the lower joint limits", finite=False).reshape(-1)
        upper = as_array(self.upper, "the upper joint limits", finite=False).reshape(-1)
        if lower.shape != upper.shape:
            raise InputError(
                f"the joint limits need one lower and one upper per joint, got {lower.size} and {upper.size}"
            )
        if np.any(np.isnan(lower)) or np.any(np.isnan(upper)):
            raise InputError("the joint limits must be numbers (±inf for an unbounded joint), got NaN")
        finite = np.isfinite(lower) & np.isfinite(upper)
        if np.any(upper[finite] <= lower[finite]):
            j = int(np.flatnonzero(finite & (upper <= lower))[0])
            raise InputError(
                f"joint {j + 1}'s upper limit {upper[j]:g} must exceed its lower limit {lower[j]:g} for the limit term"
            )
        object.__setattr__(self, "lower", lower)
        object.__setattr__(self, "upper", upper)
        index = np.flatnonzero(finite)
        object.__setattr__(self, "_index", index)
        object.__setattr__(self, "_centre", 0.5 * (lower[index] + upper[index]))
        object.__setattr__(self, "_span", upper[index] - lower[index])

    def _check(self, q: Array) -> Array:
        if q.shape != self.lower.shape:
            raise InputError(f"the joint-limit term has {self.lower.size} joints, the configuration {q.size}")
        return q

    def of_q(self, q: Array) -> float:
        """The term's value at the joint values q (n,)."""
        u = (self._check(q)[self._index] - self._centre) / self._span  # type: ignore[attr-defined]
        return float(u @ u)

    def gradient_of_q(self, q: Array) -> Array:
        """∂value/∂q (n,) at q: 2 (q_i − q̄_i) / span_i² on the bounded joints, 0 elsewhere."""
        out = np.zeros(self._check(q).size)
        index, span = self._index, self._span  # type: ignore[attr-defined]
        out[index] = 2.0 * (q[index] - self._centre) / (span * span)  # type: ignore[attr-defined]
        return out

    @classmethod
    def from_scenario(cls, context: TermContext) -> JointLimits:
        """The term with the braced robot's URDF limits (its weight key is ``key``)."""
        robot = context.braced.robot
        return cls(robot.lower, robot.upper)
