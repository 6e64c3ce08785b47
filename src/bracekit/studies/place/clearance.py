"""The link clearances from a surface that moves with the pad, and their derivatives in (q, θ).

The surface passes through the pad point b(q, θ) (:mod:`bracekit.studies.place.inner`), so a link's clearance
c_j(q, b) (:class:`bracekit.kinematics.clearance.Clearance`: capsules against the disk and the cylinder below,
the braced link left out) changes with the posture twice — the links move, and the surface with the pad:

    ∂c_j/∂q = (∂c_j/∂q)_b + (∂c_j/∂b) J_b[:3],     ∂c_j/∂θ = (∂c_j/∂b) ∂b/∂θ.

(∂c_j/∂q)_b is the clearance module's exact gradient; ∂c_j/∂b (1×3) by central differences of the clearance in
the surface's position (step :data:`STEP`), since that module gives no derivative in the surface's point.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from bracekit.kinematics import BracedRobot
from bracekit.kinematics.clearance import Clearance

Array = NDArray[np.float64]

#: Central-difference step of the surface's position (m).
STEP = 1e-6


class MovingClearance(Clearance):
    """The clearance of each link but the braced one from the brace's surface put through a given point."""

    def __init__(self, braced: BracedRobot) -> None:
        super().__init__(braced)
        if self.mesh is not None:
            raise ValueError("a robot with collision meshes: the moving clearance uses capsules")

    def values(self, q: Array, point: Array) -> Array:
        """Each link's clearance (J,), m, with the surface through `point` (no gradients)."""
        self._point = point
        return np.array([d.clearance for d in sorted(self.links(q, gradient=False), key=lambda d: d.joint)])

    def rows(self, q: Array, point: Array) -> tuple[Array, Array, Array]:
        """(Each link's clearance (J,), m; (∂c/∂q)_b (J, n); ∂c/∂b (J, 3)) with the surface through `point`."""
        self._point = point
        found = sorted(self.links(q, gradient=True), key=lambda d: d.joint)
        values = np.array([d.clearance for d in found])
        dq = np.array([d.gradient for d in found]).reshape(len(found), q.size)
        db = np.zeros((values.size, 3))
        for k in range(3):
            step = np.zeros(3)
            step[k] = STEP
            db[:, k] = (self.values(q, point + step) - self.values(q, point - step)) / (2.0 * STEP)
        self._point = point
        return values, dq, db
