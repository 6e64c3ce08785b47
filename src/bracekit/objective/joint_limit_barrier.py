"""A joint-limit barrier: Σ_i [span_i² / (4 (q_max,i − q_i)(q_i − q_min,i)) − 1] over the joints with finite limits.

The criterion of Chan and Dubey (T. F. Chan, R. V. Dubey, "A weighted least-norm solution based scheme for
avoiding joint limits for redundant joint manipulators", IEEE Trans. Robotics and Automation 11(2), 1995), less
its minimum: 0 at the middle of every range and +∞ at a limit, so a gradient-projection run that weights it is
pushed back ever harder as a joint nears a limit (the quadratic :class:`~bracekit.objective.JointLimits` is
only 1/4 there). Its gradient span² (2q − q_max − q_min) / (4 (q_max − q)² (q − q_min)²) needs no kinematics.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bracekit.errors import BarrierError
from bracekit.objective.base import Array, register_term
from bracekit.objective.joint_limits import JointLimits


@register_term
@dataclass(frozen=True)
class JointLimitBarrier(JointLimits):
    """Σ_i [span_i² / (4 (q_max,i − q_i)(q_i − q_min,i)) − 1] over the joints with finite `lower`, `upper` (n,).

    Dimensionless, ≥ 0. BarrierError where a bounded joint is at or beyond a limit. Unbounded joints
    (continuous, ±inf) do not contribute. The reference, fused and scenario methods are the quadratic term's,
    on this value and gradient.
    """

    name: str = "joint_limit_barrier"
    key = "joint_limit_barrier"

    def _gaps(self, q: Array) -> tuple[Array, Array, Array]:
        """(q − q_min, q_max − q, span) on the bounded joints; BarrierError when a gap is not positive."""
        index = self._index  # type: ignore[attr-defined]
        qi = self._check(q)[index]
        below, above = qi - self.lower[index], self.upper[index] - qi
        if np.any(below <= 0.0) or np.any(above <= 0.0):
            j = int(index[int(np.argmin(np.minimum(below, above)))])
            raise BarrierError(
                f"joint {j + 1} is at or beyond its limit ({q[j]:.6g} outside ({self.lower[j]:.6g}, "
                f"{self.upper[j]:.6g})): the joint-limit barrier is infinite there"
            )
        return below, above, self._span  # type: ignore[attr-defined]

    def of_q(self, q: Array) -> float:
        """The term's value at the joint values q (n,)."""
        below, above, span = self._gaps(q)
        return float(np.sum(span * span / (4.0 * below * above) - 1.0))

    def gradient_of_q(self, q: Array) -> Array:
        """∂value/∂q (n,) at q: span² (2q − q_max − q_min) / (4 (q_max − q)² (q − q_min)²), 0 off the bounded."""
        below, above, span = self._gaps(q)
        out = np.zeros(q.size)
        out[self._index] = span * span * (below - above) / (4.0 * (below * above) ** 2)  # type: ignore[attr-defined]
        return out
