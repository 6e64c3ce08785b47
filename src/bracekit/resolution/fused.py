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
(SingularityError, BarrierError), warnings and results stay the reference's. Every objective term gives its
own value and gradient coefficients (:meth:`bracekit.objective.Term.fused_gradient`); a term without them is
evaluated by its own ``gradient``/``value`` on a BracedState.

Two backends compute the same step: ``"numpy"`` (the default; no compilation) and ``"numba"`` (``pip install
bracekit[fast]``), which hands everything after Pinocchio's pass to one compiled kernel
(:mod:`bracekit.resolution._numba_step`, cached on disk after the first compilation) with the same shortcuts and
certificates, for any split n1 (dq1/db̃ = J1⁻¹ H when n1 = 6, else an orthonormal basis of the null space of Xᵀ J1);
the kernel holds compiled copies of the terms that give :meth:`~bracekit.objective.Term.numba_params`. Where the
kernel does not apply (finite differences, a term without numba parameters, a task space other than the full pose:
``fallback_reason`` says which) or declines at a configuration (a certificate fails, an unloaded contact, {b} outside
its region), the numba backend runs the NumPy code, so errors and warnings are the same. A task space other than the
pose resolves its selected rows S A and S ẋ (:mod:`bracekit.resolution.task_space`) in the NumPy code.
``backend="auto"`` is numba when it can be imported, else NumPy; :mod:`bracekit.simulation.simulate` runs ``"auto"``
and notes a run that took the NumPy step because numba cannot be imported.
"""

from __future__ import annotations

import importlib
from collections.abc import Sequence
from dataclasses import replace
from types import ModuleType
from typing import Any, Literal, NamedTuple, cast

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike, NDArray

from bracekit._linalg import inverse, row_basis
from bracekit.errors import InputError, ModelError
from bracekit.kinematics import LWA, BracedRobot, contact_null_space, frame_hessian_rows
from bracekit.kinematics.braced import MAX_HESSIAN_JOINTS
from bracekit.kinematics.hessian import ensure_hessian_layout
from bracekit.objective import Objective, Term, central_difference
from bracekit.objective.fused import FusedGradient, FusedKinematics, NotCertified
from bracekit.resolution.fused_several import FramePass, KernelInputs, Kinematics, SeveralBraceKernel
from bracekit.resolution.strategies import BracedGradientProjection, finite_rates, tip_twist
from bracekit.spatial import twist_shift
from bracekit.tolerances import CERTIFIED_COND, NULL_SPACE_RTOL, UNLOADED_TOL

Array = NDArray[np.float64]


Backend = Literal["numpy", "numba", "auto"]
#: ``fallback_reason`` of a step that asked for ``backend="auto"`` where numba cannot be imported (the NumPy step).
NO_NUMBA = "numba cannot be imported"
#: The values of ``GradientProjectionStep(..., backend=...)``.
BACKENDS: tuple[str, ...] = ("numpy", "numba", "auto")
#: The term kinds the numba kernel holds a compiled copy of (:meth:`bracekit.objective.Term.numba_params`).
KERNEL_TERMS: tuple[str, ...] = ("k", "Ci", "theta_z", "d")


def numba_kernels() -> ModuleType:
    """The numba kernels (:mod:`bracekit.resolution._numba_step`), imported on first use; InputError without numba."""
    try:
        return importlib.import_module("bracekit.resolution._numba_step")
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


def fused_step(braced: BracedRobot, strategy: object, backend: Backend = "numpy") -> GradientProjectionStep | None:
    """The fused step of a gradient-projection strategy, or None where the reference path runs instead.

    None for another strategy and beyond MAX_HESSIAN_JOINTS joints. With several braces and the NumPy backend
    the step runs the reference (its ``fallback_reason`` says so): the NumPy code is written over one brace's
    chain split; the numba backend has a kernel for several braces (:mod:`bracekit.resolution.fused_several`).
    """
    if type(strategy) is not BracedGradientProjection or braced.n > MAX_HESSIAN_JOINTS:
        return None
    return GradientProjectionStep(braced, strategy, backend=backend)


def chain1_map(jb: Array, n1: int, h: Array, x: Array, cert2: float) -> Array:
    """dq1/db̃ (n1×l) from J_b (6×n): J1⁻¹ H (eq:q1) when n1 = 6, else the null space of Xᵀ J1 (as ChainSplit).

    NotCertified where ‖J1‖²_F ‖J1⁻¹‖²_F ≥ `cert2` (a bound of cond(J1)²) or J1 has an exactly zero pivot.
    """
    j1 = jb[:, :n1]
    if n1 == 6:
        inv = inverse(j1)
        if inv is None or not float(np.vdot(j1, j1)) * float(np.vdot(inv, inv)) < cert2:
            raise NotCertified  # ‖J1‖²_F ‖J1⁻¹‖²_F ≥ cond(J1)²
        return cast(Array, inv.dot(h))
    return contact_null_space(x.T @ j1)


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
    (False for the NumPy backend and where the kernel does not apply; see the module docstring), and
    ``fallback_reason`` why not (None when it does): ``"numpy backend"``, ``"numba cannot be imported"`` (with
    ``backend="auto"``), ``"finite-difference gradient"``, ``"task space other than the full pose"`` or
    ``"term without a compiled copy: <name>"``.
    """

    def __init__(self, braced: BracedRobot, strategy: BracedGradientProjection, backend: Backend = "numpy") -> None:
        if not isinstance(strategy, BracedGradientProjection):
            raise InputError("GradientProjectionStep needs a BracedGradientProjection strategy")
        if backend not in BACKENDS:
            raise InputError(f"unknown backend '{backend}'; choose one of {', '.join(BACKENDS)}")
        self.braced = braced
        self.strategy = strategy
        self._several = len(braced.braces) > 1
        self._multi: SeveralBraceKernel | None = None
        if self._several:  # the NumPy code is written over one brace's chain split: the reference or the kernel
            self._n = braced.n
            self.backend: str = "numpy"
            self.uses_kernel: bool = False
            self._kernel: Any = None
            self.fallback_reason: str | None = (
                "several braces: the fused step holds one brace's chain split, the reference step runs (same q̇)"
            )
            if backend != "numpy":
                self._several_setup(backend)
            return
        robot = braced.robot
        self._model = robot.model
        if braced.n > MAX_HESSIAN_JOINTS:
            raise ModelError(
                f"the fused gradient-projection step supports up to {MAX_HESSIAN_JOINTS} joints (it needs Pinocchio's "
                f"kinematic Hessians); the robot has {braced.n}"
            )
        self._data = robot.model.createData()
        self._tip, self._bid = robot.tip_id, braced.split.brace_id
        self._n, self._n1 = braced.n, braced.split.n1
        self._k1inv = 1.0 / robot.stiffness[: braced.split.n1]
        self._kinv = 1.0 / robot.stiffness
        self._H, self._X = braced.split.H, braced.split.X
        self._t = np.eye(6) - braced.split.P
        self._eye = np.eye(6)
        self._k_env = braced.split.brace.environment_stiffness
        self._normal = braced.split.brace.surface.normal
        self._nl = self._normal.tolist()
        self._fk: FusedKinematics | None = None
        self._beta: tuple[bytes, Terms] | None = None  # the last β_x (its bytes) and the terms with it
        self._last: tuple[Array, tuple[Any, ...]] | None = None
        obj = strategy.objective
        if not isinstance(obj, Objective):
            raise InputError("the fused step needs an Objective")
        kept = [(t, float(w)) for t, w in zip(obj.terms, obj.weights, strict=True) if w]
        self._objective = Objective([t for t, _ in kept], [w for _, w in kept])  # the terms of non-zero weight
        self._fd = strategy.gradient == "finite-difference"
        if not self._fd:  # check Pinocchio's Hessian layout once, with this step's own data (no second n³ Data)
            ensure_hessian_layout(self._model, self._data, (self._tip, self._bid))
        self._alpha = float(strategy.alpha)
        self._space = strategy.space
        self._cert2 = CERTIFIED_COND**2
        kernels = None
        self.fallback_reason = "numpy backend"
        if backend == "numba":
            kernels = numba_kernels()
        elif backend == "auto":
            try:
                kernels = numba_kernels()
            except InputError:
                kernels = None
                self.fallback_reason = NO_NUMBA
        self.backend = "numpy" if kernels is None else "numba"
        self._kernel = None if kernels is None else self._numba_setup(kernels)
        self.uses_kernel = self._kernel is not None

    def _several_setup(self, backend: str) -> None:
        """The numba kernel of several braces (:mod:`bracekit.resolution.fused_several`) where it applies."""
        try:
            kernels = importlib.import_module("bracekit.resolution._numba_several")
        except ImportError as exc:
            if backend == "numba":
                numba_kernels()  # the InputError that says how to install numba
                raise InputError(f"the numba kernel of several braces cannot be imported: {exc}") from exc
            self.fallback_reason = NO_NUMBA
            return
        self.backend = "numba"
        self._multi, reason = SeveralBraceKernel.build(self.braced, self.strategy, kernels)
        self.uses_kernel = self._multi is not None
        self.fallback_reason = reason

    def _numba_setup(self, kernels: ModuleType) -> Any:
        """The kernel and its constant arguments, or None where it does not apply (the NumPy code runs).

        Sets ``fallback_reason`` (None when the kernel applies).
        """
        if self._fd:
            self.fallback_reason = "finite-difference gradient"
            return None
        if not self._space.is_pose:
            self.fallback_reason = "task space other than the full pose"
            return None
        rows: dict[str, list[list[float]]] = {kind: [] for kind in KERNEL_TERMS}
        for term, weight in _terms(self._objective):
            p = _call(term, "numba_params", None, self.braced, weight)
            if p is None or p[0] not in KERNEL_TERMS:
                self.fallback_reason = f"term without a compiled copy: {getattr(term, 'name', type(term).__name__)}"
                return None
            rows[p[0]].append(list(p[1]))
        self._inputs = KernelInputs(np.array(rows["Ci"], dtype=float).reshape(-1, 8))
        self._nb_const = (
            np.ascontiguousarray(self._H, dtype=float),
            np.ascontiguousarray(self._X, dtype=float),
            np.ascontiguousarray(self._t, dtype=float),
            np.ascontiguousarray(self._kinv, dtype=float),
        )
        self._reg = np.array(rows["d"], dtype=float).reshape(-1, 5)
        self._nb_normal = np.ascontiguousarray(self._normal, dtype=float)
        w_k = sum(r[0] for r in rows["k"])
        w_theta = sum(r[0] for r in rows["theta_z"])
        self._par = np.array([self._alpha, self._cert2, UNLOADED_TOL, w_k, w_theta, NULL_SPACE_RTOL])
        self.fallback_reason = None
        return kernels.gp_step

    # --- public API --------------------------------------------------------------------------------
    def __call__(
        self, q: ArrayLike, xdot: ArrayLike, beta_x: ArrayLike | None = None, at: FramePass | None = None
    ) -> Array:
        """Joint velocities q̇ (n,) that realise the tip twist ẋ (6,) and descend g, at q (n,).

        `at`: a Pinocchio pass of this model already made at q (a run's correction's, the frames of
        ``state_from_kinematics``): the compiled step then adds only the Hessians (the same q̇ to the last bit).
        """
        qa = self._check_q(q)
        xd = xdot
        if not (type(xd) is np.ndarray and xd.dtype == np.float64 and xd.shape == (6,) and bool(np.isfinite(xd).all())):
            xd = tip_twist(xdot)
        if self._several:
            if self._multi is not None:
                fast = self._multi(qa, xd, beta_x, at)
                if fast is not None:
                    return fast
            strategy = self._reference(beta_x)
            return strategy.velocity(self.braced.state(qa, hessians=strategy.needs_hessians), xd)
        if self._kernel is not None:
            out = self._numba_step(qa, xd, beta_x, at)
            if out is not None:
                return out
        obj = self._with_beta(beta_x)
        try:
            with np.errstate(over="ignore", invalid="ignore"):  # an overflow is reported by finite_rates, by name
                qdot = self._step(qa, xd, obj)
                finite = bool(np.isfinite(qdot).all())
            return qdot if finite else finite_rates(qdot)
        except NotCertified:
            strategy = replace(self.strategy, objective=_objective(obj))
            return strategy.velocity(self.braced.state(qa, hessians=strategy.needs_hessians), xd)

    def gradient(self, q: ArrayLike, beta_x: ArrayLike | None = None) -> Array:
        """∂g/∂q (n,) at q in the strategy's gradient mode, as ``BracedGradientProjection.dg_dq``."""
        qa = self._check_q(q)
        if self._several:
            strategy = self._reference(beta_x)
            return strategy.dg_dq(self.braced.state(qa, hessians=strategy.needs_hessians))
        obj = self._with_beta(beta_x)
        try:
            if self._fd:
                return self._fd_gradient(qa, obj)
            return self._dg_dq(qa, self._kinematics(qa, True), obj)
        except NotCertified:
            strategy = replace(self.strategy, objective=_objective(obj))
            return strategy.dg_dq(self.braced.state(qa, hessians=strategy.needs_hessians))

    def value(self, q: ArrayLike, beta_x: ArrayLike | None = None) -> float:
        """G at q (eq:objective), as ``Objective.value``."""
        qa = self._check_q(q)
        if self._several:
            return float(self._reference(beta_x).objective.value(self.braced.state(qa)))
        obj = self._with_beta(beta_x)
        try:
            return self._value(qa, obj)
        except NotCertified:
            return _objective(obj).value(self.braced.state(qa))

    # --- internals ---------------------------------------------------------------------------------
    def _reference(self, beta_x: ArrayLike | None) -> BracedGradientProjection:
        """The reference strategy with β_x replaced (the step of several braces)."""
        if beta_x is None:
            return self.strategy
        return replace(self.strategy, objective=self.strategy.objective.with_beta_x(beta_x))

    def _check_q(self, q: ArrayLike) -> Array:
        if type(q) is np.ndarray and q.dtype == np.float64 and q.shape == (self._n,) and bool(np.isfinite(q).all()):
            return q
        return self.braced.robot.check_q(q)

    def _with_beta(self, beta_x: ArrayLike | None) -> Objective | Terms:
        """The objective with β_x of every term that has one replaced (``Objective.with_beta_x``'s terms).

        The terms and weights were checked when the step was built: they are not checked again each step.
        """
        if beta_x is None:
            return self._objective
        fixed = type(beta_x) is np.ndarray and beta_x.dtype == np.float64 and beta_x.shape == (6,)
        key = beta_x.tobytes() if fixed else None  # type: ignore[union-attr]
        last = self._beta
        if key is not None and last is not None and last[0] == key:  # the same β_x as the last step (a fixed one)
            return last[1]
        obj = self._objective
        terms = Terms([t.with_beta_x(beta_x) if isinstance(t, Term) else t for t in obj.terms], obj.weights)
        self._beta = None if key is None else (key, terms)
        return terms

    def last_kinematics(self, q: Array) -> Kinematics | None:
        """(⁰M, J) of the tip, then of each brace, of this step's last Pinocchio pass if it was at this very array q.

        None otherwise. The order of :meth:`BracedRobot.state_from_kinematics`: a caller builds the state at q
        without a second pass.
        """
        if self._multi is not None:
            return self._multi.last_kinematics(q)
        last = getattr(self, "_last", None)
        if last is None or last[0] is not q:
            return None
        je, jb, mb, me = last[1]
        return (me, je), (mb, jb)

    def _kinematics(self, qa: Array, hessians: bool, at: FramePass | None = None) -> tuple[Any, ...]:
        """One Pinocchio pass (or `at`'s): J_e, J_b (6×n, world axes), ⁰M_b, ⁰M_e (4×4), Hessian rows if asked."""
        model, data = self._model, self._data
        if at is not None:
            data, (me, mb), (je, jb) = at.data, at.placements, at.jacobians
        else:
            pin.computeJointJacobians(model, data, qa)
            mb = pin.updateFramePlacement(model, data, self._bid).homogeneous  # the two frames, not the model's
            me = pin.updateFramePlacement(model, data, self._tip).homogeneous
            je = pin.getFrameJacobian(model, data, self._tip, LWA)
            jb = pin.getFrameJacobian(model, data, self._bid, LWA)
        self._last = (qa, (je, jb, mb, me))
        if not hessians:
            return je, jb, mb, me, None, None
        pin.computeJointKinematicHessians(model, data)
        return je, jb, mb, me, frame_hessian_rows(model, data, self._tip), frame_hessian_rows(model, data, self._bid)

    def _numba_step(self, qa: Array, xd: Array, beta_x: ArrayLike | None, at: FramePass | None = None) -> Array | None:
        """q̇ by the numba kernel after one Pinocchio pass; None where the kernel declines (NumPy code then)."""
        ci, xd = self._inputs(beta_x, xd)
        je, jb, mb, me, he, hb = self._kinematics(qa, True, at)
        h, x, t, kinv = self._nb_const
        assert self._kernel is not None
        status, out = self._kernel(
            je, jb, he, hb, mb, me, xd, h, x, t, kinv, ci, self._reg, self._nb_normal, self._par, self._n1
        )
        return out if status == 0 and bool(np.isfinite(out).all()) else None  # else the NumPy code (raises or warns)

    def _chain1(self, jb: Array) -> Array:
        """dq1/db̃ (n1×l): J1⁻¹ H (eq:q1) when n1 = 6, else the null space of Xᵀ J1 (as BracedState)."""
        return chain1_map(jb, self._n1, self._H, self._X, self._cert2)

    def _step(self, qa: Array, xd: Array, obj: Objective | Terms) -> Array:
        kin = self._kinematics(qa, not self._fd)
        je, jb, mb, me = kin[:4]
        n1 = self._n1
        s1 = twist_shift(mb[:3, 3], me[:3, 3])
        g1 = self._chain1(jb)
        l_ = g1.shape[1]
        # A = [S_t1 J1 dq1/db̃, S_t2 J2] (eq:braced_kin): S_t1 H when n1 = 6, and S_t2 J2 = J_e[:, n1:]
        a = np.concatenate((s1.dot(self._H if n1 == 6 else jb[:, :n1].dot(g1)), je[:, n1:]), axis=1)
        if not self._space.is_pose:  # the selected rows S(⁰R_e) A, S ẋ
            sel = self._space.selection(me[:3, :3])
            a, xd = sel.dot(a), sel.dot(xd)
        if a.shape[0] > a.shape[1]:  # fewer braced coordinates than twist components: no null space
            raise NotCertified
        qr = row_basis(a)  # Aᵀ = Q R
        if qr is None or not float(np.vdot(a, a)) * float(np.vdot(qr[1], qr[1])) < self._cert2:
            raise NotCertified  # ‖A‖_F ‖R⁻¹‖_F ≥ cond(A)
        q, rinv = qr
        dg = self._fd_gradient(qa, obj) if self._fd else self._dg_dq(qa, kin, obj, s1)
        grad = np.concatenate((g1.T.dot(dg[:n1]), dg[n1:]))  # eq:grad_g
        # A⁺ẋ + (I − A⁺A) α∇g with A⁺ = Q R⁻ᵀ, A⁺A = Q Qᵀ  (eq:grad_proj)
        y = q.dot(rinv.T.dot(xd)) + self._alpha * (grad - q.dot(q.T.dot(grad)))
        return np.concatenate((g1.dot(y[:l_]), y[l_:]))  # eq:q1

    def _fused_kinematics(
        self, kin: tuple[Any, ...], s1: Array | None = None, q: Array | None = None
    ) -> FusedKinematics:
        """The terms' view of one Pinocchio pass (one object per step instance, moved to each q)."""
        if self._fk is None:
            self._fk = FusedKinematics(
                je=kin[0],
                jb=kin[1],
                mb=kin[2],
                me=kin[3],
                n=self._n,
                n1=self._n1,
                kinv=self._kinv,
                k1inv=self._k1inv,
                X=self._X,
                t_proj=self._t,
                k_env=self._k_env,
                normal=self._nl,
                cert2=self._cert2,
            )
        return self._fk.at(kin[0], kin[1], kin[2], kin[3], s1, q)

    def _dg_dq(self, qa: Array, kin: tuple[Any, ...], obj: Objective | Terms, s1: Array | None = None) -> Array:
        """∂g/∂q (n,), analytic: each term's fused coefficients, contracted once per Hessian.

        A term without fused coefficients adds its own ``gradient`` on a BracedState (computed once).
        """
        fk = self._fused_kinematics(kin, s1, qa)
        out = FusedGradient(self._n, self._n1)
        state = None
        for term, weight in _terms(obj):
            if not _call(term, "fused_gradient", False, fk, weight, out):
                if state is None:
                    state = self.braced.state(qa, hessians=True)
                out.add_extra(weight * term.gradient(state))
        return out.total(fk, kin[4], kin[5])

    def _value(self, qa: Array, obj: Objective | Terms) -> float:
        """G at q (eq:objective), term by term as Objective.value."""
        fk = self._fused_kinematics(self._kinematics(qa, False), None, qa)
        total = 0.0
        state = None
        for term, weight in _terms(obj):
            value = _call(term, "fused_value", None, fk)
            if value is None:
                if state is None:
                    state = self.braced.state(qa)
                value = term.value(state)
            total += weight * value
        return total

    def _fd_gradient(self, qa: Array, obj: Objective | Terms) -> Array:
        """Central differences of g with δq = the strategy's fd_step (objective.central_difference)."""
        return central_difference(lambda x: self._value(x, obj), qa, self.strategy.fd_step)


class Terms(NamedTuple):
    """An objective's terms and weights (eq:objective) without an Objective's checks: the step's β_x replaced."""

    terms: list[Any]
    weights: Sequence[float]


def _objective(obj: Objective | Terms) -> Objective:
    """The Objective of `obj` (checked), for the reference path."""
    return obj if isinstance(obj, Objective) else Objective(obj.terms, obj.weights)


def _terms(obj: Objective | Terms) -> zip[tuple[Any, float]]:
    """(term, weight) pairs of an objective."""
    return zip(obj.terms, obj.weights, strict=True)


def _call(term: Any, method: str, default: Any, *args: Any) -> Any:
    """term.method(*args), or `default` for a term without it (a user's object that is not a Term)."""
    fn = getattr(term, method, None)
    return default if fn is None else fn(*args)
