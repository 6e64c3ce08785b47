"""The link clearances from a surface that moves with the pad, and their derivatives in (q, θ).

The surface passes through the pad point b(q, θ) (:mod:`bracekit.studies.place.inner`), so a link's clearance
c_j(q, b) (:class:`bracekit.kinematics.clearance.Clearance`, the braced link left out) changes with the posture
twice — the links move, and the surface with the pad:

    ∂c_j/∂q = (∂c_j/∂q)_b + (∂c_j/∂b) J_b[:3],     ∂c_j/∂θ = (∂c_j/∂b) ∂b/∂θ.

(∂c_j/∂q)_b is the clearance modules' exact gradient. ∂c_j/∂b (1×3): moving the surface by δ is moving every
link by −δ, so it is minus the gradient in a common translation t of the links, which the clearance modules'
own gradient gives when each link frame's Jacobian gets three columns more, [I₃; 0] (:data:`TRANSLATION`: a
translation moves every point of a link by t and turns none), in the same pass as (∂c_j/∂q)_b, witness and
clip-point rule alike. A link whose least clearance is from a further obstacle (fixed) has ∂c_j/∂b = 0.

Capsules: the surface's rule (the disk and the cylinder below) through b. Collision meshes and primitives
(:class:`bracekit.geometry.distance.MeshClearance`, coal): the surface's solid is fixed where the brace put it
(through b₀), and moving it by δ = b − b₀ is moving every link by −δ, so the links' placements are shifted
by −δ (:class:`ShiftedMeshClearance`; a shift changes neither the Jacobians nor the witnesses' arms); the
environment's further obstacles (``[[obstacle]]``) stay where they are (a second, unshifted clearance, the
least of the two per link).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from bracekit.geometry.distance import MeshClearance
from bracekit.kinematics import BracedRobot
from bracekit.kinematics.clearance import Clearance, LinkDistance

Array = NDArray[np.float64]

#: The Jacobian columns of a common translation of the links (6×3, LOCAL_WORLD_ALIGNED: linear rows first).
TRANSLATION = np.vstack([np.eye(3), np.zeros((3, 3))])


class ShiftedMeshClearance(MeshClearance):
    """:class:`MeshClearance` with every link's placement translated by ``shift`` (m, world; the surface by −shift)."""

    shift: Array = np.zeros(3)
    _translated = False  # while True, each link frame's Jacobian carries the TRANSLATION columns

    def _jacobian(self, jacs: list[Array], s: int) -> Array:
        """The link's Jacobian (6×n), with :data:`TRANSLATION`'s columns (6×(n + 3)) while translated."""
        jac = super()._jacobian(jacs, s)
        return np.hstack([jac, TRANSLATION]) if self._translated else jac

    def _placements(self, qa: Array, gradient: bool) -> tuple[Array, list[Array] | None]:
        placements, jacs = super()._placements(qa, gradient)
        placements = placements.copy()
        placements[:, :3, 3] += self.shift
        return placements, jacs


class MovingClearance(Clearance):
    """The clearance of each link but the braced one from the brace's surface put through a given point."""

    def __init__(self, braced: BracedRobot) -> None:
        super().__init__(braced)
        self._mesh_fixed: MeshClearance | None = None
        self._translated = False  # while True, each link frame's Jacobian carries the TRANSLATION columns
        if self.mesh is not None:  # the braced link left out, as with capsules: the pad moves along it
            skip = int(braced.robot.model.frames[braced.brace_id].parentJoint)
            elements = [e for e in braced.robot.geometry if e.joint != skip]
            self._origin = np.array(braced.brace.surface.point, dtype=float)
            self.mesh = ShiftedMeshClearance(braced, elements)
            if braced.obstacles:
                self._mesh_fixed = MeshClearance(braced, elements, braced.obstacles, surfaces=False)

    def _placements(self, qa: Array, gradient: bool) -> tuple[Array, list[Array] | None]:
        """The clearance module's placements and Jacobians, with :data:`TRANSLATION`'s columns while translated."""
        placements, jacs = super()._placements(qa, gradient)
        if jacs is not None and self._translated:
            jacs = [np.hstack([j, TRANSLATION]) for j in jacs]
        return placements, jacs

    def _found(self, q: Array, point: Array, gradient: bool) -> list[LinkDistance]:
        """Each link's clearance with the surface through `point`, in chain order."""
        self._point = point
        if self.mesh is None:
            return sorted(self.links(q, gradient=gradient), key=lambda d: d.joint)
        assert isinstance(self.mesh, ShiftedMeshClearance)
        self.mesh.shift = self._origin - point
        least = {j: LinkDistance(j, v, g) for j, v, g in self.mesh.links(q, gradient)}
        if self._mesh_fixed is not None:
            for j, v, g in self._mesh_fixed.links(q, gradient):
                if j not in least or v < least[j].clearance:
                    least[j] = LinkDistance(j, v, g)
        return [least[j] for j in sorted(least)]

    def values(self, q: Array, point: Array) -> Array:
        """Each link's clearance (J,), m, with the surface through `point` (no gradients)."""
        return np.array([d.clearance for d in self._found(q, point, False)])

    def rows(self, q: Array, point: Array) -> tuple[Array, Array, Array]:
        """(Each link's clearance (J,), m; (∂c/∂q)_b (J, n); ∂c/∂b (J, 3)) with the surface through `point`."""
        moving: list[MovingClearance | ShiftedMeshClearance] = [self]
        if isinstance(self.mesh, ShiftedMeshClearance):
            moving.append(self.mesh)
        for each in moving:
            each._translated = True
        try:
            found = self._found(q, point, True)
        finally:
            for each in moving:
                each._translated = False
        n = q.size
        values = np.array([d.clearance for d in found])
        dq, db = np.zeros((values.size, n)), np.zeros((values.size, 3))
        for i, d in enumerate(found):
            if d.gradient.size == n + 3:  # a link from the moving surface: −∂c/∂t
                dq[i], db[i] = d.gradient[:n], -d.gradient[n:]
            elif d.gradient.size == n:  # from a further obstacle, fixed: no dependence on b
                dq[i] = d.gradient
            else:
                raise ValueError(f"a clearance gradient of {d.gradient.size} entries for {n} joints")
        return values, dq, db
