"""Pink barriers of a braced robot: the bracing regions and the links' clearance from the bracing surfaces.

A pink barrier h(q) ≥ 0 (vector) enters ``solve_ik(..., barriers=[...])`` as the inequality
(∂h/∂q) Δq/dt ≥ −gain · h(q), a control barrier function: h may approach 0 but not cross it.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray
from pink.barriers import Barrier

from bracekit._linalg import as_number
from bracekit.errors import InputError
from bracekit.kinematics import BracedRobot
from bracekit.objective.brace_margin import BraceMargin
from bracekit.pink.tasks import brace_frames
from bracekit.resolution.qp import clearance_rows
from pink import Configuration

Array = NDArray[np.float64]


class BraceRegionBarrier(Barrier):
    """h_i = r_max,i² − ‖L_i (b_i − p_i)‖² ≥ 0 (m²): brace i's point inside its bracing region (the region of d).

    L_i = I − n̂_i n̂_iᵀ projects onto brace i's plane, p_i is the region's centre (``surface.point``); one row per
    brace with a ``region_radius``. ∂h_i/∂q = −2 (L_i (b_i − p_i))ᵀ J_v,b_i.
    """

    def __init__(self, braced: BracedRobot, gain: float = 1.0, safe_displacement_gain: float = 0.0):
        self.braced = braced
        self.rows = [i for i, b in enumerate(braced.braces) if b.region_radius is not None]
        if not self.rows:
            raise InputError("a BraceRegionBarrier needs a brace with a region_radius; none of the braces has one")
        super().__init__(len(self.rows), gain=gain, safe_displacement_gain=safe_displacement_gain)

    def _lateral(self, configuration: Configuration) -> list[tuple[Array, Array, float]]:
        frames = brace_frames(self.braced, configuration)
        out = []
        for i in self.rows:
            brace = self.braced.braces[i]
            n = brace.surface.normal
            lat = frames[i].b - brace.surface.point
            lat = lat - n * float(n @ lat)
            out.append((lat, frames[i].J_b[:3], float(brace.region_radius)))  # type: ignore[arg-type]
        return out

    def compute_barrier(self, configuration: Configuration) -> Array:
        """H (rows,), m²."""
        return np.array([r * r - float(lat @ lat) for lat, _, r in self._lateral(configuration)])

    def compute_jacobian(self, configuration: Configuration) -> Array:
        """∂h/∂q (rows × n), m² per rad."""
        return np.array([-2.0 * lat @ jv for lat, jv, _ in self._lateral(configuration)])


class LinkClearanceBarrier(Barrier):
    """h_j = c_j − c_min ≥ 0 (m): every link's clearance c_j from every brace's surface (kinematics.clearance).

    The rows are the (brace, link) pairs of the configuration given at construction; the links that carry a
    pad are left out for that pad's surface (as :func:`bracekit.resolution.qp.clearance_rows` does).
    """

    def __init__(
        self,
        braced: BracedRobot,
        configuration: Configuration,
        clearance_min: float = 0.0,
        gain: float = 1.0,
        safe_displacement_gain: float = 0.0,
    ):
        self.braced = braced
        self.clearance_min = as_number(clearance_min, "the least clearance clearance_min", unit="m")
        self.names = [r.name for r in clearance_rows(braced, configuration.q, math.inf)]
        if not self.names:
            raise InputError("a LinkClearanceBarrier needs link capsules: the robot has none besides the pads' links")
        super().__init__(len(self.names), gain=gain, safe_displacement_gain=safe_displacement_gain)

    def _rows(self, configuration: Configuration) -> dict[str, tuple[float, Array]]:
        return {r.name: (r.clearance, r.gradient) for r in clearance_rows(self.braced, configuration.q, math.inf)}

    def compute_barrier(self, configuration: Configuration) -> Array:
        """H (rows,), m."""
        rows = self._rows(configuration)
        return np.array([rows[name][0] - self.clearance_min for name in self.names])

    def compute_jacobian(self, configuration: Configuration) -> Array:
        """∂h/∂q (rows × n), m per rad."""
        rows = self._rows(configuration)
        return np.array([rows[name][1] for name in self.names])


def holding_residuals(term: BraceMargin, q: Array) -> Array:
    """The adapter to bracekit's brace margin: its lift-off and slip residuals r (N) at q (the term's public API)."""
    return np.asarray(term.residuals(term.braced.state(q)), dtype=np.float64)


class BraceMarginBarrier(Barrier):
    """h_j = r_j − r_min ≥ 0 (N): the brace holds each listed tool wrench (lift-off, and slip with friction).

    r_j are the residuals of bracekit's :class:`~bracekit.objective.BraceMargin` term (its module docstring: the
    contact force under each listed wrench at scale 1, first order in the joint springs K), one row each;
    ∂h/∂q by central differences of r over q with step ``fd_step`` (rad). One brace (the term's model).
    """

    def __init__(
        self,
        term: BraceMargin,
        configuration: Configuration,
        margin_min: float = 0.0,
        fd_step: float = 1e-6,
        gain: float = 1.0,
        safe_displacement_gain: float = 0.0,
    ):
        if not isinstance(term, BraceMargin):
            raise InputError(f"a BraceMarginBarrier needs a bracekit BraceMargin term, got {type(term).__name__}")
        self.term = term
        self.margin_min = as_number(margin_min, "the least holding residual margin_min", unit="N")
        self.fd_step = as_number(fd_step, "the finite-difference step fd_step", positive=True, unit="rad")
        dim = holding_residuals(term, configuration.q).size
        super().__init__(dim, gain=gain, safe_displacement_gain=safe_displacement_gain)

    def compute_barrier(self, configuration: Configuration) -> Array:
        """H (rows,), N."""
        return holding_residuals(self.term, configuration.q) - self.margin_min

    def compute_jacobian(self, configuration: Configuration) -> Array:
        """∂h/∂q (rows × n), N per rad, by central differences."""
        q = np.asarray(configuration.q, dtype=float)
        cols = []
        for i in range(q.size):
            dq = np.zeros(q.size)
            dq[i] = self.fd_step
            plus, minus = holding_residuals(self.term, q + dq), holding_residuals(self.term, q - dq)
            cols.append((plus - minus) / (2.0 * self.fd_step))
        return np.array(cols).T
