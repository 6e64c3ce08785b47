"""The admittance law of a hand-guided tool: a virtual mass–damper per task axis driven by the worker's wrench.

Per axis j of the selected task rows: M_j ẍ_j + D_j ẋ_j = w_j, with w the worker's wrench at the force/torque
sensor (N, N·m, world axes) less a deadband (|w_j| ≤ δ_j gives 0, else w_j − sign(w_j) δ_j), and ẋ the commanded
tool twist (m/s, rad/s). The update over one control period h is exact for a wrench held over the period
(zero-order hold):

    ẋ⁺ = a ẋ + (1 − a) w / D,   a = exp(−h D / M),

so the discrete velocity equals the closed form ẋ(t) = (w/D)(1 − exp(−D t / M)) at every tick under a step
force. Axes outside the selection (``axes``) give 0.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from bracekit._linalg import as_number
from bracekit.errors import InputError

Array = NDArray[np.float64]

__all__ = ["Admittance", "AdmittanceState"]


class AdmittanceState(NamedTuple):
    """The commanded tool twist ẋ (6,), m/s and rad/s, and the filtered wrench that drove it (6,)."""

    xdot: Array
    wrench: Array


def _six(value: ArrayLike, what: str, positive: bool) -> Array:
    a = np.asarray(value, dtype=float)
    a = np.full(6, float(a)) if a.ndim == 0 else a.reshape(-1)
    if a.size != 6 or not np.all(np.isfinite(a)) or np.any(a <= 0.0 if positive else a < 0.0):
        rule = "> 0" if positive else "≥ 0"
        raise InputError(f"the admittance {what} must be one number or 6 numbers {rule}, got {value!r}")
    return a


class Admittance:
    """M ẍ + D ẋ = w per axis, exact zero-order-hold update at period h (module docstring).

    Args:
        mass: M (6,) or one number: kg for the forces' axes, kg·m² for the moments'.
        damping: D (6,) or one number: N·s/m, N·m·s/rad.
        dt: the control period h (s).
        deadband: δ (6,) or one number ≥ 0: N, N·m.
        axes: 6 booleans, the task axes the worker may move (default all).
    """

    def __init__(
        self,
        mass: ArrayLike,
        damping: ArrayLike,
        dt: float = 1e-3,
        *,
        deadband: ArrayLike = 0.0,
        axes: ArrayLike | None = None,
    ) -> None:
        self.mass = _six(mass, "mass", True)
        self.damping = _six(damping, "damping", True)
        self.deadband = _six(deadband, "deadband", False)
        self.dt = as_number(dt, "the control period dt", positive=True, unit="s")
        sel = np.ones(6, dtype=bool) if axes is None else np.asarray(axes, dtype=bool).reshape(-1)
        if sel.size != 6:
            raise InputError(f"the admittance axes must be 6 booleans, got {axes!r}")
        self.axes = sel
        self.decay = np.exp(-self.dt * self.damping / self.mass)
        self.xdot = np.zeros(6)

    def reset(self) -> None:
        """Stop: ẋ = 0."""
        self.xdot = np.zeros(6)

    def filtered(self, wrench: ArrayLike) -> Array:
        """The wrench past the deadband on the selected axes (6,)."""
        w = np.asarray(wrench, dtype=float).reshape(6)
        out = np.sign(w) * np.maximum(np.abs(w) - self.deadband, 0.0)
        return np.where(self.axes, out, 0.0)

    def __call__(self, wrench: ArrayLike) -> AdmittanceState:
        """Advance one period under the worker's wrench (6,) held over it; the new commanded twist."""
        w = self.filtered(wrench)
        self.xdot = self.decay * self.xdot + (1.0 - self.decay) * w / self.damping
        return AdmittanceState(self.xdot.copy(), w)
