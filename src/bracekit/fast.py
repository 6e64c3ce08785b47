"""A fused braced gradient-projection step for control loops: joint values in, joint velocities out.

:class:`GradientProjectionStep` computes the same q̇ as the reference path
``BracedGradientProjection.velocity(braced.state(q, hessians=True), xdot)`` (eq:grad_proj with ∇g of
eq:grad_g), in one call and without the reference's intermediate objects:

* one Pinocchio pass: placements, the frame Jacobians of {e} and {b} and their kinematic Hessians;
* ∂g/∂q of the terms of eq:objective as one contraction per Hessian: every term adds its coefficients to a
  (6, n) matrix U, and Σ_{r,i} U[r, i] ∂J[r, i]/∂q_k is a single (n × 6n) matrix–vector product
  (:func:`bracekit.kinematics.frame_hessian_rows`);
* C_e = Ĵ K⁻¹ Ĵᵀ with Ĵ = [S_t1 T J1, S_t2 J2] (eq:Ce; T = I − P for the projection model, I − P_C for the
  constrained one) applied to vectors, never forming the 6×6 compliances;
* eq:grad_proj with A⁺ = Q R⁻ᵀ and A⁺A = Q Qᵀ from a QR factorisation Aᵀ = QR of the full-row-rank A
  (eq:braced_kin; no SVD), and J1⁻¹ by LU (eq:q1).

The shortcuts are used only where they are certified to agree with the reference: the explicit inverses
bound the condition numbers (cond(M) ≤ ‖M‖_F ‖M⁻¹‖_F), and where a bound reaches :data:`CERTIFIED_COND`
(far below the reference's singularity thresholds), where A has more rows than columns, or with a compliant
environment under the constrained model, the step is the reference path itself, so errors
(SingularityError, BarrierError), warnings and results stay the reference's. An objective term other than
the four of eq:objective is evaluated by its own ``gradient``/``value`` on a BracedState.

Two backends compute the same step: ``"numpy"`` (the default; no compilation, what :mod:`bracekit.simulate`
uses) and ``"numba"`` (``pip install bracekit[fast]``), which hands everything after Pinocchio's pass to one
compiled kernel (:mod:`bracekit._numba_step`, cached on disk after the first compilation) with the same
shortcuts and certificates. Where the kernel does not apply (n1 ≠ 6, finite differences, a term other than
the four, a compliant environment with the constrained model) or declines (a certificate fails, an unloaded
contact, {b} outside its region), the numba backend runs the NumPy code, so errors and warnings are the same.
``backend="auto"`` is numba when it can be imported, else NumPy.
"""

from __future__ import annotations

import importlib
import math
from dataclasses import replace
from types import ModuleType
from typing import Any, Literal

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike, NDArray

from ._linalg import angle_between, cross3_list, inverse, row_basis
from .compliance import UNLOADED_TOL, _unit6, check_finite, loaded_gain, warn_unloaded
from .errors import BarrierError, InputError
from .kinematics import LWA, BracedRobot, contact_null_space, frame_hessian_rows
from .measures import region_barrier
from .objective import BraceAngle, ComplianceIndex, ConditionNumber, Objective, RegionBarrier, central_difference
from .resolution import BracedGradientProjection
from .spatial import twist_shift

Array = NDArray[np.float64]

#: Largest condition number (of J1, A and J_e) for which the shortcuts are used; beyond it the step takes
#: the reference path (whose singularity thresholds are 1e8, 1e9 and 1e12). The shortcuts lose about
#: cond · 1e-16 relative accuracy (cond(J_e)² · 1e-16 for k's gradient, as the reference's own (JJᵀ)⁻¹ does).
CERTIFIED_COND = 1e3

Backend = Literal["numpy", "numba", "auto"]
#: The values of ``GradientProjectionStep(..., backend=...)``.
BACKENDS: tuple[str, ...] = ("numpy", "numba", "auto")


def numba_kernels() -> ModuleType:
    """The numba kernels (:mod:`bracekit._numba_step`), imported on first use; InputError without numba."""
    try:
        return importlib.import_module(f"{__package__}._numba_step")
    except ImportError as exc:
        raise InputError(
            f"backend='numba' needs numba, which cannot be imported here ({exc}); install it with "
            "`pip install bracekit[fast]` (or `pip install 'numba>=0.60'`), or use backend='numpy'"
        ) from exc


def numba_available() -> bool:
    """Whether the numba backend can be used (numba importable); imports it if so."""
    try:
        numba_kernels()
    except InputError:
        return False
    return True


class _FallbackError(Exception):
    """A shortcut is not certified here: use the reference path."""


class GradientProjectionStep:
    """q̇ = [dq1/db̃ · ḃ; q̇2] with [ḃ; q̇2] = A⁺ẋ + (I − A⁺A) α ∇g (eq:grad_proj), fused.

    Args:
        braced: the braced robot.
        strategy: the gradient-projection strategy (objective, α, gradient mode, δq). With
            ``gradient="finite-difference"`` the gradient is the paper's central difference of g, each
            g evaluated by the same fused code.

        backend: ``"numpy"`` (default: no compilation), ``"numba"`` (the compiled kernel; InputError if numba
            is not installed) or ``"auto"`` (numba if it can be imported, else NumPy). Both give the
            reference's q̇ to ~1e-13; the first numba step of a process loads the kernel from numba's disk
            cache, or compiles it (seconds) when there is no cache yet.

    Call it as ``step(q, xdot)``, or ``step(q, xdot, beta_x)`` to replace the β_x of the compliance-index
    terms (a task with a time-varying direction). It owns its Pinocchio data: one instance per thread.
    ``backend`` is then the backend in use; ``uses_kernel`` says whether the numba kernel computes the step
    (False for the NumPy backend and where the kernel does not apply; see the module docstring).
    """

    def __init__(self, braced: BracedRobot, strategy: BracedGradientProjection, backend: Backend = "numpy") -> None:
        if not isinstance(strategy, BracedGradientProjection):
            raise InputError("GradientProjectionStep needs a BracedGradientProjection strategy")
        if backend not in BACKENDS:
            raise InputError(f"unknown backend '{backend}'; choose one of {', '.join(BACKENDS)}")
        self.braced = braced
        self.strategy = strategy
        robot = braced.robot
        self._model = robot.model
        self._data = robot.model.createData()
        self._tip, self._bid = robot.tip_id, braced.brace_id
        self._n, self._n1 = braced.n, braced.n1
        self._k1inv = 1.0 / robot.stiffness[: braced.n1]
        self._kinv = 1.0 / robot.stiffness
        self._H, self._X = braced.H, braced.X
        self._t = np.eye(6) - braced.P
        self._eye = np.eye(6)
        self._k_env = braced.brace.environment_stiffness
        self._normal = braced.brace.surface.normal
        self._nl = self._normal.tolist()
        obj = strategy.objective
        kept = [(t, float(w)) for t, w in zip(obj.terms, obj.weights, strict=True) if w]
        self._objective = Objective([t for t, _ in kept], [w for _, w in kept])  # the terms of non-zero weight
        self._fd = strategy.gradient == "finite-difference"
        self._alpha = float(strategy.alpha)
        self._cert2 = CERTIFIED_COND**2
        kernels = None
        if backend == "numba":
            kernels = numba_kernels()
        elif backend == "auto":
            try:
                kernels = numba_kernels()
            except InputError:
                kernels = None
        self.backend: str = "numpy" if kernels is None else "numba"
        self._kernel = None if kernels is None else self._numba_setup(kernels)
        self.uses_kernel: bool = self._kernel is not None

    def _numba_setup(self, kernels: ModuleType) -> Any:
        """The kernel and its constant arguments, or None where it does not apply (the NumPy code runs)."""
        standard = (ConditionNumber, ComplianceIndex, BraceAngle, RegionBarrier)
        terms = list(_terms(self._objective))
        if self._fd or self._n1 != 6 or any(type(t) not in standard for t, _ in terms):
            return None
        if self._k_env is not None and any(type(t) is ComplianceIndex and t.model != "projection" for t, _ in terms):
            return None
        ci = [[*t.beta_x.tolist(), w, float(t.model == "projection")] for t, w in terms if type(t) is ComplianceIndex]
        reg = [[*t.centre.tolist(), float(t.r_max), w] for t, w in terms if type(t) is RegionBarrier]
        w_k = sum(w for t, w in terms if type(t) is ConditionNumber)
        w_theta = sum(w for t, w in terms if type(t) is BraceAngle)
        self._ci = np.array(ci, dtype=float).reshape(-1, 8)
        self._nb_const = (
            np.ascontiguousarray(self._H, dtype=float),
            np.ascontiguousarray(self._X, dtype=float),
            np.ascontiguousarray(self._t, dtype=float),
            np.ascontiguousarray(self._kinv, dtype=float),
        )
        self._reg = np.array(reg, dtype=float).reshape(-1, 5)
        self._nb_normal = np.ascontiguousarray(self._normal, dtype=float)
        self._par = np.array([self._alpha, self._cert2, UNLOADED_TOL, w_k, w_theta])
        return kernels.gp_step

    # --- public API --------------------------------------------------------------------------------
    def __call__(self, q: ArrayLike, xdot: ArrayLike, beta_x: ArrayLike | None = None) -> Array:
        """Joint velocities q̇ (n,) that realise the tip twist ẋ (6,) and descend g, at q (n,)."""
        qa = self._check_q(q)
        xd = np.asarray(xdot, dtype=float)
        if xd.shape != (6,):
            raise InputError(f"the tip twist ẋ must have 6 components [v; ω], got shape {xd.shape}")
        if self._kernel is not None:
            out = self._numba_step(qa, xd, beta_x)
            if out is not None:
                return out
        obj = self._with_beta(beta_x)
        try:
            return self._step(qa, xd, obj)
        except _FallbackError:
            strategy = replace(self.strategy, objective=obj)
            return strategy.velocity(self.braced.state(qa, hessians=strategy.needs_hessians), xd)

    def gradient(self, q: ArrayLike, beta_x: ArrayLike | None = None) -> Array:
        """∂g/∂q (n,) at q in the strategy's gradient mode, as ``BracedGradientProjection.dg_dq``."""
        qa = self._check_q(q)
        obj = self._with_beta(beta_x)
        try:
            if self._fd:
                return self._fd_gradient(qa, obj)
            return self._dg_dq(qa, self._kinematics(qa, True), obj)
        except _FallbackError:
            strategy = replace(self.strategy, objective=obj)
            return strategy.dg_dq(self.braced.state(qa, hessians=strategy.needs_hessians))

    def value(self, q: ArrayLike, beta_x: ArrayLike | None = None) -> float:
        """g at q (eq:objective), as ``Objective.value``."""
        qa = self._check_q(q)
        obj = self._with_beta(beta_x)
        try:
            return self._value(qa, obj)
        except _FallbackError:
            return obj.value(self.braced.state(qa))

    # --- internals ---------------------------------------------------------------------------------
    def _check_q(self, q: ArrayLike) -> Array:
        if type(q) is np.ndarray and q.dtype == np.float64 and q.shape == (self._n,) and math.isfinite(q.sum()):
            return q
        return self.braced.robot.check_q(q)

    def _with_beta(self, beta_x: ArrayLike | None) -> Objective:
        return self._objective if beta_x is None else self._objective.with_beta_x(beta_x)

    def _kinematics(self, qa: Array, hessians: bool) -> tuple[Any, ...]:
        """One Pinocchio pass: J_e, J_b (6×n, world axes), ⁰M_b, ⁰M_e (4×4), Hessian rows (n×6n) if asked."""
        model, data = self._model, self._data
        pin.computeJointJacobians(model, data, qa)
        pin.updateFramePlacements(model, data)
        je = pin.getFrameJacobian(model, data, self._tip, LWA)
        jb = pin.getFrameJacobian(model, data, self._bid, LWA)
        mb, me = data.oMf[self._bid].homogeneous, data.oMf[self._tip].homogeneous
        if not hessians:
            return je, jb, mb, me, None, None
        pin.computeJointKinematicHessians(model, data)
        return je, jb, mb, me, frame_hessian_rows(model, data, self._tip), frame_hessian_rows(model, data, self._bid)

    def _numba_step(self, qa: Array, xd: Array, beta_x: ArrayLike | None) -> Array | None:
        """q̇ by the numba kernel after one Pinocchio pass; None where the kernel declines (NumPy code then)."""
        ci = self._ci
        if beta_x is not None and ci.shape[0]:
            ci = ci.copy()
            ci[:, :6] = _unit6(beta_x, "beta_x")  # as ComplianceIndex(beta_x): same InputError
        if not (xd.flags.c_contiguous and xd.flags.writeable):  # one compiled signature
            xd = xd.copy()
        je, jb, mb, me, he, hb = self._kinematics(qa, True)
        h, x, t, kinv = self._nb_const
        status, out = self._kernel(je, jb, he, hb, mb, me, xd, h, x, t, kinv, ci, self._reg, self._nb_normal, self._par)
        return out if status == 0 and math.isfinite(out.sum()) else None  # else the NumPy code (raises or warns)

    def _chain1(self, jb: Array) -> Array:
        """dq1/db̃ (n1×l): J1⁻¹ H (eq:q1) when n1 = 6, else the null space of Xᵀ J1 (as BracedState)."""
        j1 = jb[:, : self._n1]
        if self._n1 == 6:
            inv = inverse(j1)
            if inv is None or not float(np.vdot(j1, j1)) * float(np.vdot(inv, inv)) < self._cert2:
                raise _FallbackError  # ‖J1‖²_F ‖J1⁻¹‖²_F ≥ cond(J1)²
            return inv.dot(self._H)
        return contact_null_space(self._X.T @ j1)

    def _step(self, qa: Array, xd: Array, obj: Objective) -> Array:
        kin = self._kinematics(qa, not self._fd)
        je, jb, mb, me = kin[:4]
        n1 = self._n1
        s1 = twist_shift(mb[:3, 3], me[:3, 3])
        g1 = self._chain1(jb)
        l_ = g1.shape[1]
        # A = [S_t1 J1 dq1/db̃, S_t2 J2] (eq:braced_kin): S_t1 H when n1 = 6, and S_t2 J2 = J_e[:, n1:]
        a = np.concatenate((s1.dot(self._H if n1 == 6 else jb[:, :n1].dot(g1)), je[:, n1:]), axis=1)
        if a.shape[0] > a.shape[1]:  # fewer braced coordinates than twist components: no null space
            raise _FallbackError
        qr = row_basis(a)  # Aᵀ = Q R
        if qr is None or not float(np.vdot(a, a)) * float(np.vdot(qr[1], qr[1])) < self._cert2:
            raise _FallbackError  # ‖A‖_F ‖R⁻¹‖_F ≥ cond(A)
        q, rinv = qr
        dg = self._fd_gradient(qa, obj) if self._fd else self._dg_dq(qa, kin, obj, s1)
        grad = np.concatenate((g1.T.dot(dg[:n1]), dg[n1:]))  # eq:grad_g
        # A⁺ẋ + (I − A⁺A) α∇g with A⁺ = Q R⁻ᵀ, A⁺A = Q Qᵀ  (eq:grad_proj)
        y = q.dot(rinv.T.dot(xd)) + self._alpha * (grad - q.dot(q.T.dot(grad)))
        return np.concatenate((g1.dot(y[:l_]), y[l_:]))  # eq:q1

    def _frobenius(self, je: Array) -> tuple[float, float, Array]:
        """tr(JJᵀ), tr((JJᵀ)⁻¹) and (JJᵀ)⁻² J of eq:manip, certified far from singular (else the reference).

        With Y = (JJᵀ)⁻¹ J, tr((JJᵀ)⁻¹) = ‖J⁺‖²_F = ‖Y‖²_F since J⁺ = Jᵀ(JJᵀ)⁻¹. (JJᵀ)⁻¹ is formed
        (getrf + getri) and applied by products, not by getrs: SciPy's OpenBLAS runs getrs' triangular
        solves with several right-hand sides on its thread pool, which stalls for milliseconds (a scheduler
        tick) whenever every core is busy.
        """
        inv = inverse(je.dot(je.T))
        if inv is None:
            raise _FallbackError
        y = inv.dot(je)
        a, bb = float(np.vdot(je, je)), float(np.vdot(y, y))
        if not a * bb < self._cert2:  # a·bb = 36 k² ≥ cond(J)²; also nan
            raise _FallbackError
        return a, bb, inv.dot(y)

    def _compliance(self, term: ComplianceIndex, je: Array, jb: Array, s1: Array) -> tuple[Array, Array, Array]:
        """S_t1 T, T J1 and Ĵ = [S_t1 T J1, J_e2] (6×n) with C̃1 = T C1 Tᵀ, so that C_e = Ĵ K⁻¹ Ĵᵀ (eq:Ce).

        T = I − P for the projection model (eq:C1wave_detail) and I − P_C = I − C1 X G Xᵀ for the
        constrained one (MODEL.md; T C1 Tᵀ = C1 − C1 X G Xᵀ C1 because G Xᵀ C1 X G = G). S_t2 C2 S_t2ᵀ =
        J_e2 K2⁻¹ J_e2ᵀ since S_t2 J2 = J_e[:, n1:].
        """
        n1 = self._n1
        j1 = jb[:, :n1]
        if term.model == "projection":
            t = self._t
        else:
            if self._k_env is not None:  # C1 − C1 X G Xᵀ C1 ≠ T C1 Tᵀ with a compliant environment
                raise _FallbackError
            j1k = j1 * self._k1inv
            x = self._X
            cx = j1k.dot(j1.T.dot(x))  # C1 X
            m = x.T.dot(cx)
            trace_c1 = float(np.vdot(j1k, j1))
            if m.shape == (1, 1) and m[0, 0] > UNLOADED_TOL * trace_c1:  # one loaded direction: G = 1/m
                t = self._eye - np.multiply.outer(cx[:, 0] / m[0, 0], x[:, 0])
            else:  # as compliance.constraint_gain
                g, unloaded = loaded_gain(m, trace_c1)
                if unloaded:
                    warn_unloaded(int(unloaded), stacklevel=4)
                t = self._eye - cx.dot(g).dot(x.T)
        s1t = s1.dot(t)
        return s1t, t.dot(j1), np.concatenate((s1t.dot(j1), je[:, n1:]), axis=1)

    def _dg_dq(self, qa: Array, kin: tuple[Any, ...], obj: Objective, s1: Array | None = None) -> Array:
        """∂g/∂q (n,), analytic: the gradients of objective.py, contracted once per Hessian.

        Each term adds coefficients U[r, i] of ∂J_e[r, i]/∂q_k (``ue``) or ∂J_b[r, i]/∂q_k (``ub``, i < n1) and
        a vector y with grad += J_bᵀ y[:6] + J_e[:3]ᵀ y[6:]; one product per Hessian then gives ∂g/∂q.
        """
        je, jb, mb, me, he, hb = kin
        n, n1 = self._n, self._n1
        (_, _, zb0, b0), (_, _, zb1, b1), (_, _, zb2, b2) = mb[:3].tolist()
        ue = ub = None
        y = [0.0] * 9
        extra = None
        for term, weight in _terms(obj):
            kind = type(term)
            if kind is ConditionNumber:  # ConditionNumber.gradient: (b da + a db) / (72 k)
                a, bb, m2j = self._frobenius(je)
                c = weight / (6.0 * math.sqrt(a * bb))
                part = je * (c * bb) - m2j * (c * a)
                ue = part if ue is None else ue + part
            elif kind is ComplianceIndex:  # ComplianceIndex.gradient
                beta = term.beta_x
                if s1 is None:
                    s1 = twist_shift(mb[:3, 3], me[:3, 3])
                s1t, tj1, jh = self._compliance(term, je, jb, s1)
                kinv = self._kinv
                uk = beta.dot(jh) * kinv
                v = jh.dot(uk)  # C_e β
                ci = check_finite(math.sqrt(float(v.dot(v))), "the compliance index")
                if ci == 0.0:
                    continue
                wu = np.array((v.dot(jh) * kinv, uk)) * (weight / ci)
                # β ⊗ (J_e2ᵀ v / k2) + v ⊗ (J_e2ᵀ β / k2) on chain 2 (∂J_e); on chain 1 the same with
                # [b̂ v̂] = Tᵀ S_t1ᵀ [β v] against ∂J_b
                pb = np.array((beta, v)).T.dot(wu)
                if ue is None:
                    ue = np.zeros((6, n))
                ue[:, n1:] += pb[:, n1:]
                part = s1t.T.dot(pb[:, :n1])
                ub = part if ub is None else ub + part
                # S_t1 depends on b − e: (J_b[:3] − J_e[:3])ᵀ ((C̃1 S_t1ᵀ v)_ω × β_v + (C̃1 S_t1ᵀ β)_ω × v_v)
                cv, cb = wu[:, :n1].dot(tj1[3:].T).tolist()
                w1, w2 = cross3_list(cv, beta.tolist()), cross3_list(cb, v.tolist())
                for i in range(3):
                    wi = w1[i] + w2[i]
                    y[i] += wi
                    y[6 + i] -= wi
            elif kind is BraceAngle:  # BraceAngle.gradient
                u = cross3_list(self._nl, (zb0, zb1, zb2))
                s = math.sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2])
                if s >= 1e-12:
                    for i in range(3):
                        y[3 + i] += weight * u[i] / s
            elif kind is RegionBarrier:  # RegionBarrier.gradient
                c0, c1, c2 = term.centre.tolist()
                rel = (b0 - c0, b1 - c1, b2 - c2)
                r2 = rel[0] * rel[0] + rel[1] * rel[1] + rel[2] * rel[2]
                rm2 = term.r_max**2
                if r2 >= rm2:
                    raise BarrierError(f"the bracing point is outside the bracing region (r = {math.sqrt(r2):.4g} m)")
                c = weight * 2.0 * rm2 / (rm2 - r2) ** 2
                for i in range(3):
                    y[i] += c * rel[i]
            else:
                if extra is None:
                    extra = np.zeros(n)
                    state = self.braced.state(qa, hessians=True)
                extra += weight * term.gradient(state)
        grad = np.concatenate((jb, je[:3])).T.dot(y)
        if ue is not None:
            grad += he.dot(ue.T.ravel())
        if ub is not None:
            grad += hb[:, : 6 * n1].dot(ub.T.ravel())
        return grad if extra is None else grad + extra

    def _value(self, qa: Array, obj: Objective) -> float:
        """g at q (eq:objective), term by term as Objective.value."""
        je, jb, mb, me, _, _ = self._kinematics(qa, False)
        s1 = None
        total = 0.0
        state = None
        for term, weight in _terms(obj):
            kind = type(term)
            if kind is ConditionNumber:
                a, bb, _ = self._frobenius(je)
                value = float(np.sqrt(a * bb) / 6.0)
            elif kind is ComplianceIndex:
                if s1 is None:
                    s1 = twist_shift(mb[:3, 3], me[:3, 3])
                jh = self._compliance(term, je, jb, s1)[2]
                v = jh.dot(jh.T.dot(term.beta_x) * self._kinv)
                value = check_finite(float(np.sqrt(v.dot(v))), "the compliance index")
            elif kind is BraceAngle:
                value = angle_between(self._normal, mb[:3, 2])
            elif kind is RegionBarrier:
                value = region_barrier(float(np.linalg.norm(mb[:3, 3] - term.centre)), term.r_max)
            else:
                if state is None:
                    state = self.braced.state(qa)
                value = term.value(state)
            total += weight * value
        return total

    def _fd_gradient(self, qa: Array, obj: Objective) -> Array:
        """Central differences of g with δq = the strategy's fd_step (objective.central_difference)."""
        return central_difference(lambda x: self._value(x, obj), qa, self.strategy.fd_step)


def _terms(obj: Objective) -> zip[tuple[Any, float]]:
    """(term, weight) pairs of an objective."""
    return zip(obj.terms, obj.weights, strict=True)
