"""α3's term: θ_z = acos(ẑ_tᵀ ẑ_b) (eq:theta), the angle between the surface normal and the pad axis, rad."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from bracekit._linalg import angle_between, cross3, cross3_list
from bracekit.compliance.measures import theta_z
from bracekit.errors import InputError
from bracekit.kinematics import BracedRobot, BracedState
from bracekit.objective.base import Array, BraceTerm, TermContext, register_term
from bracekit.objective.fused import FusedGradient, FusedKinematics


@register_term
@dataclass(frozen=True)
class BraceAngle(BraceTerm):
    """θ_z (eq:theta), rad. Its gradient is 0 where θ_z = 0 (a cone point).

    Defined only for a brace with a pad axis (``Brace.pad_axis``); InputError otherwise.
    """

    name: str = "theta_z"
    brace: int = 0
    key = "theta_z"

    def value(self, state: BracedState) -> float:
        """The term's value at the state (the class docstring gives its units)."""
        _check_pad_axis(state.braced, self.brace)
        return theta_z(state.braced.braces[self.brace].surface.normal, state.contacts[self.brace].z_b)

    def gradient(self, state: BracedState) -> Array:
        """∂value/∂q (n,), exact through the state's kinematic Hessians."""
        _check_pad_axis(state.braced, self.brace)
        c = state.contacts[self.brace]
        u = cross3(state.braced.braces[self.brace].surface.normal, c.z_b)
        s = float(np.linalg.norm(u))
        if s < 1e-12:
            return np.zeros(state.q.size)
        return c.J_b[3:].T @ (u / s)

    def fused_value(self, kin: FusedKinematics) -> float | None:
        """The value from the fused step's kinematics (the same as :meth:`value`)."""
        if self.brace != 0:  # the fused step holds one brace
            return None
        return angle_between(np.asarray(kin.normal), kin.mb[:3, 2])

    def fused_gradient(self, kin: FusedKinematics, weight: float, out: FusedGradient) -> bool:
        """Add weight · ∂value/∂q to the fused step's accumulator; True when done here."""
        if self.brace != 0:  # the fused step holds one brace
            return False
        u = cross3_list(kin.normal, kin.mb[:3, 2].tolist())
        s = math.sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2])
        if s >= 1e-12:
            for i in range(3):
                out.y[3 + i] += weight * u[i] / s
        return True

    def numba_params(self, braced: BracedRobot, weight: float) -> tuple[str, list[float]] | None:
        """(kind, parameters) of the numba kernel's compiled copy of this term (the fused step's one brace)."""
        _check_pad_axis(braced, self.brace)
        return ("theta_z", [weight]) if self.brace == 0 else None

    @classmethod
    def terms_from_scenario(cls, context: TermContext) -> tuple[BraceAngle, ...]:
        """One term per brace with a pad axis (``theta_z``; with several braces ``theta_z_<i>``)."""
        braces = context.braced.braces
        if len(braces) == 1:
            _check_pad_axis(context.braced, 0)
            return (cls(),)
        out = tuple(cls(name=f"theta_z_{i}", brace=i) for i, b in enumerate(braces) if b.pad_axis)
        if not out:
            _check_pad_axis(context.braced, 0)
        return out


def _check_pad_axis(braced: BracedRobot, i: int) -> None:
    """InputError if brace i has no pad axis (θ_z is then undefined)."""
    if not 0 <= i < len(braced.braces):
        raise InputError(f"θ_z is asked of braces[{i}]; the robot has {len(braced.braces)} brace(s)")
    brace = braced.braces[i]
    if not brace.pad_axis:
        raise InputError(
            f"θ_z needs a pad axis, and the brace at {brace.frame!r} (a link point) has none; give the brace a pad "
            "axis (a frame, or a link point with a pad direction) or drop the θ_z term"
        )
