"""The minimum-norm steps of a run from the state's own Jacobians, without the chain split's objects.

:class:`MinNormStep` gives the q̇ of ``strategy.velocity(state, ẋ)`` for :class:`FreeSpaceMinNorm` (q̇ = J⁺ ẋ)
and :class:`BracedMinNorm` ([ḃ; q̇2] = A⁺ ẋ, eq:general_inv with η = 0, then q̇1 = dq1/db̃ ḃ, eq:q1) from the
state's J_e, J_b and placements, with the fused gradient-projection step's shortcuts
(:mod:`bracekit.resolution.fused`):

* A = [S_t1 J1 dq1/db̃, J_e[:, n1:]] (eq:braced_kin; S_t2 J2 = J_e[:, n1:], and S_t1 J1 dq1/db̃ = S_t1 H when
  n1 = 6), dq1/db̃ = J1⁻¹ H by LU when n1 = 6, else the null space of Xᵀ J1
  (:func:`~bracekit.resolution.fused.chain1_map`);
* M⁺ S ẋ = Q R⁻ᵀ S ẋ from a Householder QR Mᵀ = QR of the full-row-rank M = S A or S J (no SVD), S the
  task space's selection (:mod:`bracekit.resolution.task_space`).

Where numba can be imported, a step in the full pose or the position is one compiled call
(:mod:`bracekit.resolution._numba_min_norm`, the same formulas and certificates); where the kernel declines, the
NumPy code runs.

With several braces, BracedMinNorm's q̇ = N (S J_e N)⁺ S ẋ takes N = ``contact_null_space(G)`` of the stacked
constraint G where every row of G is kept (:func:`~bracekit.kinematics.constraint.full_rank_constraint`: no row
dropped, no warning), and the same QR pseudo-inverse.

The shortcuts are taken only where certified (‖J1‖_F ‖J1⁻¹‖_F and ‖M‖_F ‖R⁻¹‖_F below CERTIFIED_COND, far
below the reference's singularity thresholds); elsewhere (several braces with a dependent or unloaded row, whose
state's own constraint drops it and warns) the step is the strategy's own ``velocity``, so errors and warnings stay
the reference's. Where certified, q̇ equals the reference's to ~1e-13 relative.
"""

from __future__ import annotations

import importlib
from typing import Any

import numpy as np
from numpy.typing import NDArray

from bracekit._linalg import row_basis
from bracekit.kinematics import BracedRobot, BracedState, contact_null_space
from bracekit.kinematics.constraint import full_rank_constraint
from bracekit.objective.fused import NotCertified
from bracekit.resolution.fused import Backend, chain1_map
from bracekit.resolution.strategies import BracedMinNorm, FreeSpaceMinNorm, tip_twist
from bracekit.resolution.task_space import select
from bracekit.spatial import twist_shift
from bracekit.tolerances import CERTIFIED_COND, NULL_SPACE_RTOL

Array = NDArray[np.float64]

__all__ = ["MinNormStep", "min_norm_step"]


def min_norm_step(braced: BracedRobot, strategy: object, backend: Backend = "auto") -> MinNormStep | None:
    """The lean step of a minimum-norm strategy (FreeSpaceMinNorm, BracedMinNorm), None for another strategy."""
    if type(strategy) not in (FreeSpaceMinNorm, BracedMinNorm):
        return None
    return MinNormStep(braced, strategy, backend)  # type: ignore[arg-type]


def _kernel(backend: Backend) -> Any:
    """The compiled minimum-norm step, or None for the NumPy backend or where numba cannot be imported."""
    if backend == "numpy":
        return None
    try:
        return importlib.import_module("bracekit.resolution._numba_min_norm").min_norm_step
    except ImportError:
        if backend == "numba":
            from bracekit.resolution.fused import numba_kernels

            numba_kernels()  # the InputError that says how to install numba
        return None


class MinNormStep:
    """Q̇ of a minimum-norm strategy at a state: ``step(state, xdot)`` is ``strategy.velocity(state, xdot)``.

    Args:
        braced: the braced robot.
        strategy: a :class:`FreeSpaceMinNorm` or :class:`BracedMinNorm`.
        backend: ``"auto"`` (the compiled kernel where numba can be imported), ``"numba"`` (InputError without
            numba) or ``"numpy"``.

    Where a certificate fails at a state, or with several braces a row of G is dropped there, the strategy's own
    ``velocity`` runs. ``uses_kernel``: whether the compiled kernel computes the step (free space or one brace, in
    the task spaces whose rows do not turn with the tool: pose, position).
    """

    def __init__(
        self, braced: BracedRobot, strategy: FreeSpaceMinNorm | BracedMinNorm, backend: Backend = "auto"
    ) -> None:
        self.strategy = strategy
        self._braced = bool(strategy.braced)
        self._split = self._braced and len(braced.braces) == 1  # the paper's chart (b̃, q2); else N y
        self._cert2 = CERTIFIED_COND**2
        self._n1, self._h, self._x = 1, np.zeros((6, 1)), np.zeros((6, 1))  # unused in free space
        if self._split:
            model = braced.split
            self._n1 = model.n1
            self._h, self._x = np.ascontiguousarray(model.H, dtype=float), np.ascontiguousarray(model.X, dtype=float)
        self._rows = {"pose": 6, "position": 3}.get(strategy.space.kind, 0)  # S = [I 0] of these spaces
        self._kernel = _kernel(backend) if self._rows and (self._split or not self._braced) else None
        self.uses_kernel = self._kernel is not None

    def __call__(self, state: BracedState, xdot: Array) -> Array:
        """Joint velocities q̇ (n,) that realise the tip twist ẋ (6,) at the state."""
        xd = tip_twist(xdot)
        if self._kernel is not None:
            contact = state.contacts[0]
            status, qdot = self._kernel(
                state.J_e, contact.J_b, contact.b, state.e, xd, self._h, self._x, self._n1, self._braced,
                self._rows, self._cert2, NULL_SPACE_RTOL,
            )  # fmt: skip
            if status == 0 and bool(np.isfinite(qdot).all()):
                return np.asarray(qdot, dtype=np.float64)
        rates = self._braced_rates if self._split else self._null_rates if self._braced else self._free_rates
        try:
            with np.errstate(over="ignore", invalid="ignore"):  # an overflow is reported by the reference
                qdot = rates(state, xd)
            if bool(np.isfinite(qdot).all()):
                return qdot
        except NotCertified:
            pass
        return self.strategy.velocity(state, xdot)

    def _pinv_times(self, state: BracedState, m: Array, xd: Array) -> Array:
        """(S M)⁺ S ẋ = Q R⁻ᵀ S ẋ from (S M)ᵀ = QR, S the task rows at the state (m: 6×k).

        NotCertified where S M has more rows than columns or cond(S M) may reach the bound.
        """
        m, xd = select(self.strategy.space, state.R_e, m, xd)
        if m.shape[0] > m.shape[1]:
            raise NotCertified
        qr = row_basis(m)
        if qr is None or not float(np.vdot(m, m)) * float(np.vdot(qr[1], qr[1])) < self._cert2:
            raise NotCertified  # ‖M‖²_F ‖R⁻¹‖²_F ≥ cond(M)²
        q, rinv = qr
        return np.asarray(q.dot(rinv.T.dot(xd)), dtype=np.float64)

    def _free_rates(self, state: BracedState, xd: Array) -> Array:
        """Q̇ = (S J)⁺ S ẋ (FreeSpaceMinNorm)."""
        return self._pinv_times(state, state.J_e, xd)

    def _braced_rates(self, state: BracedState, xd: Array) -> Array:
        """[ḃ; q̇2] = (S A)⁺ S ẋ, q̇ = [dq1/db̃ ḃ; q̇2] (eq:general_inv with η = 0, eq:q1)."""
        contact = state.contacts[0]
        n1, jb, je = self._n1, contact.J_b, state.J_e
        s1 = twist_shift(contact.b, state.e)
        g1 = chain1_map(jb, n1, self._h, self._x, self._cert2)
        a = np.concatenate((s1.dot(self._h if n1 == 6 else jb[:, :n1].dot(g1)), je[:, n1:]), axis=1)
        y = self._pinv_times(state, a, xd)
        return np.concatenate((g1.dot(y[: g1.shape[1]]), y[g1.shape[1] :]))

    def _null_rates(self, state: BracedState, xd: Array) -> Array:
        """Q̇ = N (S J_e N)⁺ S ẋ of several braces, N the null space of G; NotCertified where a row of G drops."""
        if "constraint" in state.__dict__:  # the state's own (rows dropped and warned there, or not): the reference
            raise NotCertified
        found = full_rank_constraint([state], state.K)
        if found is None:
            raise NotCertified
        null = contact_null_space(found[0][0])
        return np.asarray(null.dot(self._pinv_times(state, np.asarray(state.J_e @ null), xd)), dtype=np.float64)
