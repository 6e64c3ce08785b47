"""α4's term: the bracing-region barrier d = r_max² / (r_max² − r²), r = ‖p_b − p_t‖ (after eq:theta)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from bracekit._linalg import as_array, as_number
from bracekit.compliance.measures import region_barrier
from bracekit.errors import BarrierError, InputError
from bracekit.kinematics import BracedRobot, BracedState
from bracekit.objective.base import Array, BraceTerm, TermContext, register_term
from bracekit.objective.fused import FusedGradient, FusedKinematics


@register_term
@dataclass(frozen=True)
class RegionBarrier(BraceTerm):
    """d of a circular region of radius r_max (m) about `centre` (3,) for brace `brace`; BarrierError at r ≥ r_max.

    With several braces a scenario's weight d stands for one such term per brace with a region (d_i, named
    ``d_<i>``), each of its own {b_i}, r_max_i and centre.
    """

    r_max: float
    centre: Array
    name: str = "d"
    brace: int = 0
    key = "d"

    def __post_init__(self) -> None:
        super().__post_init__()
        if not as_number(self.r_max, "r_max", positive=True, unit="m") < 1e150:  # r_max² must stay in float64
            raise InputError(f"r_max must be a length below 1e150 m, got {self.r_max:g}")
        centre = as_array(self.centre, "the region centre (m)").reshape(-1)
        if centre.size != 3:
            raise InputError(f"the region centre must be 3 numbers (m), got {centre.size}")
        object.__setattr__(self, "centre", centre)
        if isinstance(self.brace, bool) or not isinstance(self.brace, int) or self.brace < 0:
            raise InputError(f"brace must be the index of a brace (an integer ≥ 0), got {self.brace!r}")

    def _b(self, state: BracedState) -> tuple[Array, Array]:
        """b_i (3,) and J_b_i (6×n) of the term's brace."""
        if self.brace >= len(state.contacts):
            raise InputError(f"the region barrier is for braces[{self.brace}]; the robot has {len(state.contacts)}")
        c = state.contacts[self.brace]
        return c.b, c.J_b

    def radius(self, state: BracedState) -> float:
        """r, m."""
        return float(np.linalg.norm(self._b(state)[0] - self.centre))

    def value(self, state: BracedState) -> float:
        """The term's value at the state (the class docstring gives its units)."""
        return region_barrier(self.radius(state), self.r_max)

    def gradient(self, state: BracedState) -> Array:
        """∂value/∂q (n,), exact through the state's kinematic Hessians."""
        b, j_b = self._b(state)
        rel = b - self.centre
        r2 = float(rel @ rel)
        if r2 >= self.r_max**2:
            raise BarrierError(f"the bracing point is outside the bracing region (r = {np.sqrt(r2):.4g} m)")
        return (self.r_max**2 / (self.r_max**2 - r2) ** 2) * 2.0 * (j_b[:3].T @ rel)

    def fused_value(self, kin: FusedKinematics) -> float | None:
        """The value from the fused step's kinematics (the same as :meth:`value`)."""
        if self.brace != 0:  # the fused step holds one brace
            return None
        return region_barrier(float(np.linalg.norm(kin.mb[:3, 3] - self.centre)), self.r_max)

    def fused_gradient(self, kin: FusedKinematics, weight: float, out: FusedGradient) -> bool:
        """Add weight · ∂value/∂q to the fused step's accumulator; True when done here."""
        if self.brace != 0:  # the fused step holds one brace
            return False
        c0, c1, c2 = self.centre.tolist()
        b0, b1, b2 = kin.mb[:3, 3].tolist()
        rel = (b0 - c0, b1 - c1, b2 - c2)
        r2 = rel[0] * rel[0] + rel[1] * rel[1] + rel[2] * rel[2]
        rm2 = self.r_max**2
        if r2 >= rm2:
            raise BarrierError(f"the bracing point is outside the bracing region (r = {math.sqrt(r2):.4g} m)")
        c = weight * 2.0 * rm2 / (rm2 - r2) ** 2
        for i in range(3):
            out.y[i] += c * rel[i]
        return True

    def numba_params(self, braced: BracedRobot, weight: float) -> tuple[str, list[float]] | None:
        """(kind, parameters) of the numba kernel's compiled copy of this term (the fused step's one brace)."""
        if self.brace != 0:
            return None
        return "d", [*self.centre.tolist(), float(self.r_max), weight]

    @classmethod
    def terms_from_scenario(cls, context: TermContext) -> tuple[RegionBarrier, ...]:
        """One term per brace with a region (``d``; with several braces ``d_<i>``)."""
        braces = context.braced.braces
        out = tuple(
            cls(b.region_radius, b.surface.point, name="d" if len(braces) == 1 else f"d_{i}", brace=i)
            for i, b in enumerate(braces)
            if b.region_radius is not None
        )
        if not out:
            raise InputError("the region barrier d needs the brace's region_radius (r_max, m)")
        return out
