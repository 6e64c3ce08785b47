"""α3's term: θ_z = acos(ẑ_tᵀ ẑ_b) (eq:theta), the angle between the surface normal and the pad axis, rad."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from bracekit._linalg import angle_between, cross3, cross3_list
from bracekit.compliance.measures import theta_z
from bracekit.errors import InputError
from bracekit.kinematics import BracedRobot, BracedState
from bracekit.objective.base import Array, Term, TermContext, register_term
from bracekit.objective.fused import FusedGradient, FusedKinematics


@register_term
@dataclass(frozen=True)
class BraceAngle(Term):
    """θ_z (eq:theta), rad. Its gradient is 0 where θ_z = 0 (a cone point).

    Defined only for a brace with a pad axis (``Brace.pad_axis``); InputError otherwise.
    """

    name: str = "theta_z"
    key = "theta_z"

    def value(self, state: BracedState) -> float:
        """The term's value at the state (the class docstring gives its units)."""
        _check_pad_axis(state.braced)
        return theta_z(state.braced.split.brace.surface.normal, state.split.z_b)

    def gradient(self, state: BracedState) -> Array:
        """∂value/∂q (n,), exact through the state's kinematic Hessians."""
        _check_pad_axis(state.braced)
        u = cross3(state.braced.split.brace.surface.normal, state.split.z_b)
        s = float(np.linalg.norm(u))
        if s < 1e-12:
            return np.zeros(state.q.size)
        return state.split.J_b[3:].T @ (u / s)

    def fused_value(self, kin: FusedKinematics) -> float:
        """The value from the fused step's kinematics (the same as :meth:`value`)."""
        return angle_between(np.asarray(kin.normal), kin.mb[:3, 2])

    def fused_gradient(self, kin: FusedKinematics, weight: float, out: FusedGradient) -> bool:
        """Add weight · ∂value/∂q to the fused step's accumulator; True when done here."""
        u = cross3_list(kin.normal, kin.mb[:3, 2].tolist())
        s = math.sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2])
        if s >= 1e-12:
            for i in range(3):
                out.y[3 + i] += weight * u[i] / s
        return True

    def numba_params(self, braced: BracedRobot, weight: float) -> tuple[str, list[float]]:
        """(kind, parameters) of the numba kernel's compiled copy of this term."""
        _check_pad_axis(braced)
        return "theta_z", [weight]

    @classmethod
    def from_scenario(cls, context: TermContext) -> BraceAngle:
        """The term as a scenario configures it (its weight key is ``key``)."""
        _check_pad_axis(context.braced)
        return cls()


def _check_pad_axis(braced: BracedRobot) -> None:
    """InputError if the brace has no pad axis (θ_z is then undefined)."""
    if not braced.split.brace.pad_axis:
        raise InputError(
            f"θ_z needs a pad axis, and the brace at {braced.split.brace.frame!r} (a link point) has none; give the "
            "brace "
            "a pad axis (a frame, or a link point with a pad direction) or drop the θ_z term"
        )
