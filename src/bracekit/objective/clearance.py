"""The clearance barrier: Σ over links of φ(c) = (δ − c)² / (δ c) for 0 < c < δ, 0 for c ≥ δ.

c is a link's clearance from the bracing surface (m, :mod:`bracekit.kinematics.clearance`: the distance of its
capsule segments from the obstacle, the disk of radius ``Brace.obstacle_radius`` and the cylinder below it or
else the half-space below the plane, minus the capsule radius, negative by the depth below the top when a link
passes into it; the link carrying {b} excepted) and δ the margin (m). φ and φ' vanish at c = δ, φ grows without
bound as c → 0, and c ≤ 0 raises BarrierError (as the region barrier d does outside the region).
φ'(c) = (c² − δ²) / (δ c²), so ∂/∂q = Σ φ'(c) ∂c/∂q, exact through the point Jacobians at the least points
(no Hessian needed). Links whose clearance is δ or more are not searched exactly. The fused step adds it as an
extra gradient at its q.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from bracekit._linalg import as_number
from bracekit.errors import BarrierError, InputError
from bracekit.kinematics import BracedRobot
from bracekit.kinematics.clearance import Clearance, LinkDistance
from bracekit.model.geometry import DEFAULT_LINK_RADIUS
from bracekit.objective.base import Array, JointTerm, TermContext, register_term

#: Margin δ of the barrier (m): links farther than this from the obstacle add nothing.
DEFAULT_MARGIN = 0.10


@register_term
@dataclass(frozen=True, eq=False)
class ClearanceBarrier(JointTerm):
    """Σ_links φ(c_link), φ(c) = (δ − c)² / (δ c) below the margin δ (m), 0 above; dimensionless.

    The obstacle is the surface of brace `brace` (a solid below its plane, of its obstacle radius); the links
    are measured against it, the link that carries that brace excepted. With several braces a scenario's
    weight stands for one term per brace (``clearance_<i>``).

    Attributes:
        braced: the braced robot (its capsules, and the brace's plane, obstacle radius and link).
        margin: δ, m.
        link_radius: radius of the default link capsules, m.
        brace: index of the brace whose surface is the obstacle.
    """

    braced: BracedRobot
    margin: float = DEFAULT_MARGIN
    link_radius: float = DEFAULT_LINK_RADIUS
    name: str = "clearance"
    brace: int = 0
    key = "clearance"
    _clearance: Clearance = field(init=False, repr=False)

    def __post_init__(self) -> None:
        super().__post_init__()
        if not isinstance(self.braced, BracedRobot):
            raise InputError(f"the clearance barrier needs a BracedRobot, got {type(self.braced).__name__}")
        margin = as_number(self.margin, "the clearance margin", positive=True, unit="m")
        if not margin < 1e150:
            raise InputError(f"the clearance margin must be a length below 1e150 m, got {margin:g}")
        radius = as_number(self.link_radius, "the link radius", nonnegative=True, unit="m")
        count = len(self.braced.braces)
        if isinstance(self.brace, bool) or not isinstance(self.brace, int) or not 0 <= self.brace < count:
            raise InputError(f"brace must index one of the robot's {count} braces, got {self.brace!r}")
        object.__setattr__(self, "margin", margin)
        one = BracedRobot(self.braced.robot, self.braced.braces[self.brace])  # that surface as the obstacle
        object.__setattr__(self, "_clearance", Clearance(one, radius))

    def _links(self, q: Array, gradient: bool) -> list[LinkDistance]:
        """The links within the margin; BarrierError if one touches or passes into the obstacle."""
        found = self._clearance.links(q, gradient, below=self.margin)
        for d in found:
            if not d.clearance > 0.0:
                raise BarrierError(
                    f"link {self.braced.robot.joint_names[d.joint]!r} reaches the bracing plane's obstacle "
                    f"(the surface's top, rim or side; clearance {d.clearance:.4g} m)"
                )
        return found

    def of_q(self, q: Array) -> float:
        """Σ (δ − d)² / (δ d) over the links within the margin δ at q (n,)."""
        delta = self.margin
        return float(sum((delta - d.clearance) ** 2 / (delta * d.clearance) for d in self._links(q, False)))

    def gradient_of_q(self, q: Array) -> Array:
        """∂value/∂q (n,), exact (point Jacobians at the capsules' least points)."""
        delta = self.margin
        out = np.zeros(q.size)
        for d in self._links(q, True):
            out += (d.clearance**2 - delta**2) / (delta * d.clearance**2) * d.gradient
        return out

    @classmethod
    def from_scenario(cls, context: TermContext) -> ClearanceBarrier:
        """The term as a scenario configures it (its weight key is ``key``): default margin and link radius."""
        return cls(context.braced)

    @classmethod
    def terms_from_scenario(cls, context: TermContext) -> tuple[ClearanceBarrier, ...]:
        """One term per brace's surface (``clearance``; with several braces ``clearance_<i>``)."""
        count = len(context.braced.braces)
        if count == 1:
            return (cls(context.braced),)
        return tuple(cls(context.braced, name=f"clearance_{i}", brace=i) for i in range(count))
