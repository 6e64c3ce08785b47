"""Batch evaluation over many configurations: C_e (both models), C_i and k, vectorised with NumPy.

For an array Q of N configurations (N×n), :func:`evaluate_batch` gives what the single-configuration
path gives one configuration at a time, ``end_effector_compliance(braced.state(q), model)``,
``compliance_index(C_e, β_x)`` and ``frobenius_condition(J)``, to about 1e-12, at 10⁵–10⁶
configurations per second.

The Jacobians come from :class:`ChainKinematics`, a vectorised product of exponentials built from the
Pinocchio model's joint placements and motion subspaces, Mᵢ = M_parent · placementᵢ · exp(Sᵢ qᵢ), checked
against Pinocchio when it is built (a robot whose joints it cannot reproduce is evaluated with a loop of
Pinocchio calls instead). Beyond DATA_JOINT_LIMIT joints, where Pinocchio's Data (n³ in size) is too costly,
the reference is :class:`bracekit.model.chain.ChainFK`. The compliance formulas are those of
:mod:`bracekit.compliance`, over stacks of matrices:

* C2 part: S_t2 C2 S_t2ᵀ = J_e2 K2⁻¹ J_e2ᵀ, since S_t2 J2 = J_e[:, n1:] (eq:J2, eq:twists);
* ``projection``: S_t1 C̃1 S_t1ᵀ = Ĵ1 K1⁻¹ Ĵ1ᵀ with Ĵ1 = S_t1 (I − P) J1 (eq:C1wave_detail, eq:Ce);
* ``constrained``: C̃1 = C1 − C1 X G Xᵀ C1, G = (Xᵀ C1 X [+ I/k_env])⁻¹ (docs/model.md), unloaded directions
  dropped by ``compliance.loaded_gain`` as in ``compliance.constraint_gain`` and counted in one UnloadedContactWarning;
* a compliance that is not finite (overflow) raises NumericalError naming the configuration (no RuntimeWarning);
* k = √(tr(JJᵀ) tr((JJᵀ)⁻¹)) / 6 (eq:manip) from a batched inverse of JJᵀ, with the reference's SVD for any
  configuration whose condition number is not certified below 10³ (so singular ones raise, or give NaN
  when ``errors="nan"``).

Two backends compute the same numbers: ``"numpy"`` (vectorised over chunks of configurations) and ``"numba"``
(``pip install bracekit[fast]``): one compiled kernel (:mod:`bracekit.compliance._numba_batch`, cached on disk
after its first compilation) that runs the same formulas configuration by configuration, in parallel over
configurations on numba's threads (``NUMBA_NUM_THREADS``, or the ``threads`` argument; ``threads=1`` and a
process forked from one that already ran the parallel kernel use a serial copy of it). Configurations where a
shortcut of k is not certified get the reference's SVD as in the NumPy path; a compliance that is not finite
makes the whole call run the NumPy path, which raises its NumericalError. ``backend="auto"`` (the default) is
numba when it can be imported and the product of exponentials models the robot, else NumPy; the evaluator's
``backend`` says which one runs and ``fallback_reason`` why it is not numba.
"""

from __future__ import annotations

import importlib
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from types import ModuleType
from typing import Any, Literal, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from bracekit._linalg import as_array, as_count, finite_math, show
from bracekit.compliance.chain_kinematics import ChainKinematics
from bracekit.compliance.first_order import (
    COMPLIANCE_MODELS,
    ComplianceModel,
    check_finite,
    check_model,
    loaded_gain,
    warn_unloaded,
)
from bracekit.compliance.measures import frobenius_condition
from bracekit.errors import InputError, SingularityError
from bracekit.kinematics import BracedRobot
from bracekit.spatial import unit
from bracekit.tolerances import CERTIFIED_COND, UNLOADED_TOL

Array = NDArray[np.float64]

#: Configurations evaluated together (bounds the memory: about 2 kB per configuration and chunk).
CHUNK = 2048

Backend = Literal["numpy", "numba", "auto"]
#: The values of ``BatchEvaluator(..., backend=...)``.
BACKENDS: tuple[str, ...] = ("numpy", "numba", "auto")
#: The process that started numba's thread pool (a forked child runs the kernel on one thread: the pool's
#: threads do not survive a fork, and OpenMP's runtime may hang in the child).
_PARALLEL_PID: int | None = None


def batch_kernels() -> ModuleType:
    """The numba batch kernel (:mod:`bracekit.compliance._numba_batch`), imported on first use.

    Raises InputError when numba cannot be imported.
    """
    try:
        return importlib.import_module("bracekit.compliance._numba_batch")
    except ImportError as exc:
        raise InputError(
            f"backend='numba' needs numba, which cannot be imported here ({exc}); install it with "
            "`pip install bracekit[fast]` (or `pip install 'numba>=0.60'`), or use backend='numpy'"
        ) from exc


@dataclass(frozen=True)
class BatchEvaluation:
    """Measures at N configurations (SI units), row i for configuration Q[i].

    Attributes:
        C_e: model → (N, 6, 6) end-effector compliance (eq:Ce), world axes.
        Ci: model → (N,) compliance index ‖β_xᵀ C_e‖ (eq:compliance_index), m/N for a translational β_x.
        k: (N,) Frobenius condition number of the free-space J (eq:manip, eq:J).
        k_braced: (N,) the same of J̃ (eq:J_wave), as Table I reports; None unless asked for.
    """

    C_e: dict[str, Array]
    Ci: dict[str, Array]
    k: Array
    k_braced: Array | None = None
    models: tuple[str, ...] = field(default=COMPLIANCE_MODELS)


class BatchEvaluator:
    """Vectorised C_e, C_i and k of a braced robot; build once, call with arrays of configurations.

    Args:
        braced: the braced robot (one brace).
        backend: ``"auto"`` (default: numba if it can be imported, else NumPy), ``"numba"`` (InputError if
            numba is not installed) or ``"numpy"``. Both give the single-configuration path's numbers to ~1e-12.
            The first numba call of a process loads the kernel from numba's disk cache (about 0.1 s), or
            compiles it (20–30 s, once) when there is no cache yet; ``threads=1`` uses a serial copy, compiled
            on its own first use.

    Attributes:
        backend: the backend in use, ``"numpy"`` or ``"numba"``.
        fallback_reason: why the NumPy code runs although numba was asked for (None otherwise): numba not
            importable (``"auto"``), or a joint the product of exponentials does not model.
    """

    def __init__(self, braced: BracedRobot, backend: Backend = "auto") -> None:
        if not isinstance(braced, BracedRobot):
            raise InputError(f"expected a BracedRobot, got {type(braced).__name__}")
        if not isinstance(backend, str) or backend not in BACKENDS:
            raise InputError(f"unknown backend {show(backend)}; choose one of {', '.join(BACKENDS)}")
        self.braced = braced
        robot = braced.robot
        self.kinematics = ChainKinematics(robot, (robot.tip_id, braced.split.brace_id))
        self._n1 = braced.split.n1
        self._k1inv = 1.0 / robot.stiffness[: braced.split.n1]
        self._k2inv = 1.0 / robot.stiffness[braced.split.n1 :]
        self._X = braced.split.X
        self._t = np.eye(6) - braced.split.P
        self._k_env = braced.split.brace.environment_stiffness
        self.fallback_reason: str | None = None
        kernels: ModuleType | None = None
        if backend != "numpy":
            try:
                kernels = batch_kernels()
            except InputError as exc:
                if backend == "numba":
                    raise
                self.fallback_reason = f"numba cannot be imported ({exc.__cause__})"
        if kernels is not None and not self.kinematics.exact:
            kernels = None
            self.fallback_reason = "a joint is not a revolute, prismatic or helical joint about its own origin"
        self._kernels = kernels
        self._kernel_args = None if kernels is None else self._kernel_constants()
        self.backend: str = "numpy" if kernels is None else "numba"

    def _kernel_constants(self) -> tuple[Any, ...]:
        """The chain and contact as the arrays :func:`bracekit.compliance._numba_batch.evaluate` takes."""
        kin = self.kinematics
        joints = range(1, len(kin._parent))
        n = kin.n
        support = np.zeros((2, n), dtype=np.int64)
        for f, cols in enumerate(kin._supports):
            support[f, cols] = 1
        k_env = self._k_env
        return (
            np.array([kin._motion[j][0] for j in joints], dtype=float),
            np.array([kin._motion[j][1] for j in joints], dtype=float),
            np.array([kin._col[j] for j in joints], dtype=np.int64),
            np.array([kin._parent[j] for j in joints], dtype=np.int64),
            np.ascontiguousarray([r for r, _ in kin._place], dtype=float).reshape(-1, 3, 3),
            np.ascontiguousarray([t for _, t in kin._place], dtype=float).reshape(-1, 3),
            np.array([p for p, _, _ in kin._frames], dtype=np.int64),
            np.ascontiguousarray([t for _, _, t in kin._frames], dtype=float),
            support,
            np.ascontiguousarray(np.concatenate((self._k1inv, self._k2inv)), dtype=float),
            int(self._n1),
            np.ascontiguousarray(self._X, dtype=float),
            np.ascontiguousarray(self._t, dtype=float),
            0.0 if k_env is None else 1.0 / float(k_env),
            float(UNLOADED_TOL),
            float(CERTIFIED_COND**2),
        )

    def __call__(
        self,
        Q: ArrayLike,
        beta_x: ArrayLike,
        *,
        models: Sequence[str] = COMPLIANCE_MODELS,
        errors: str = "raise",
        k_braced: bool = False,
        chunk: int = CHUNK,
        threads: int | None = None,
    ) -> BatchEvaluation:
        """Evaluate every row of Q (N×n).

        Args:
            Q: configurations, one per row, chain order.
            beta_x: unit twist of the compliance index, (6,) for all rows or (N, 6) one per row.
            models: compliance models to evaluate.
            errors: ``"raise"`` (SingularityError naming the first singular configuration, as
                frobenius_condition does) or ``"nan"`` (k is NaN there). A compliance that is not finite
                raises NumericalError in either case.
            k_braced: also compute k of J̃.
            chunk: configurations evaluated together (NumPy backend; with numba, the order in which
                singular configurations are reported is the same as with this chunk size).
            threads: numba threads for this call (at most ``numba.config.NUMBA_NUM_THREADS``); None keeps
                numba's setting (``NUMBA_NUM_THREADS`` in the environment). 1 runs single-threaded, for
                callers that run several processes. The NumPy backend is single-threaded and ignores it.
        """
        n = self.kinematics.n
        q = as_array(Q, "the configurations Q", finite=False)
        if q.ndim == 1:
            q = q[None, :]
        if q.ndim != 2 or q.shape[1] != n or q.shape[0] == 0:
            raise InputError(f"the configurations Q must be an array of shape (N, {n}) with N ≥ 1, got {q.shape}")
        finite = np.isfinite(q).all(axis=1)
        if not finite.all():
            raise InputError(f"configuration {int(np.argmin(finite))} of Q is not finite (NaN or inf)")
        N = q.shape[0]
        if isinstance(models, str):
            models = (models,)
        if not isinstance(models, Sequence) or len(models) == 0:
            raise InputError(f"models must be a list of compliance models ({', '.join(COMPLIANCE_MODELS)})")
        mods = tuple(check_model(m) for m in models)
        if not isinstance(errors, str) or errors not in ("raise", "nan"):
            raise InputError(f"errors must be 'raise' or 'nan', got {show(errors)}")
        if not isinstance(k_braced, bool):
            raise InputError(f"k_braced must be True or False, got {show(k_braced)}")
        size = as_count(chunk, "chunk")
        beta = _betas(beta_x, N)
        nthreads = None
        if threads is not None:
            limit = _max_threads() if self._kernels is not None else None
            nthreads = as_count(threads, "threads", high=limit)
        if self._kernels is not None:
            got = self._numba(q, beta, mods, errors, k_braced, size, nthreads)
            if got is not None:
                evaluation, unloaded = got
                if unloaded:
                    warn_unloaded(unloaded, configurations=N, stacklevel=2)
                return evaluation
        c_e: dict[str, Array] = {m: np.empty((N, 6, 6)) for m in mods}
        ci: dict[str, Array] = {m: np.empty(N) for m in mods}
        k, kb = np.empty(N), (np.empty(N) if k_braced else None)
        unloaded = 0
        for s in range(0, N, size):
            sl = slice(s, min(N, s + size))
            fr = self.kinematics.frames(q[sl])
            je, jb = fr.jacobian[0], fr.jacobian[1]
            with np.errstate(all="ignore"):  # a non-finite row raises NumericalError naming its configuration
                d = fr.position[1] - fr.position[0]  # b − e
                out, jt, bad = self._compliance(je, jb, d, mods, k_braced, s)
                unloaded += bad
                for m in mods:
                    c_e[m][sl] = _check_rows(out[m], s, f"C_e ({m})")
                    v = np.einsum("ni,nij->nj", beta[sl], out[m])
                    ci[m][sl] = _check_rows(np.sqrt(np.einsum("ni,ni->n", v, v)), s, f"C_i ({m})")
            k[sl] = _frobenius(je, errors, s)
            if kb is not None and jt is not None:
                kb[sl] = _frobenius(jt, errors, s)
        if unloaded:
            warn_unloaded(unloaded, configurations=N, stacklevel=2)
        return BatchEvaluation(C_e=c_e, Ci=ci, k=k, k_braced=kb, models=mods)

    def _numba(
        self, q: Array, beta: Array, mods: tuple[str, ...], errors: str, k_braced: bool, size: int, threads: int | None
    ) -> tuple[BatchEvaluation, int] | None:
        """The numba kernel's evaluation and its count of unloaded configurations.

        None if a compliance is not finite somewhere: the NumPy code then runs, and raises its NumericalError.
        """
        kern = self._kernels
        assert kern is not None and self._kernel_args is not None
        N = q.shape[0]
        con, proj = "constrained" in mods, "projection" in mods
        empty = np.empty((0, 6, 6))
        ce_con = np.empty((N, 6, 6)) if con else empty
        ce_proj = np.empty((N, 6, 6)) if proj else empty
        ci_con, ci_proj = np.empty(N if con else 0), np.empty(N if proj else 0)
        k, kb = np.empty(N), np.empty(N if k_braced else 0)
        flags = np.zeros(N, dtype=np.int64)
        b = np.ascontiguousarray(beta[:1] if beta.strides[0] == 0 else beta)
        qc = np.ascontiguousarray(q)
        args = (qc, self._kernel_args, (b, con, proj, k_braced), (ce_con, ce_proj, ci_con, ci_proj, k, kb, flags))
        global _PARALLEL_PID
        if threads == 1 or _PARALLEL_PID not in (None, os.getpid()):  # one thread, or a fork of a parallel process
            kern.evaluate_serial(*args)
        elif threads is None:
            _PARALLEL_PID = os.getpid()
            kern.evaluate(*args)
        else:
            import numba

            _PARALLEL_PID = os.getpid()
            before = numba.get_num_threads()
            numba.set_num_threads(threads)
            try:
                kern.evaluate(*args)
            finally:
                numba.set_num_threads(before)
        if np.any(flags & kern.NOT_FINITE):
            return None
        uncertified = np.flatnonzero(flags & (kern.K_UNCERTIFIED | kern.KB_UNCERTIFIED))
        if uncertified.size:  # the reference's SVD, in the NumPy path's order (chunk by chunk, k then k of J̃)
            fr = self.kinematics.frames(q[uncertified])
            je, jb = fr.jacobian[0], fr.jacobian[1]
            with np.errstate(all="ignore"):
                jt = np.concatenate(
                    (_shift(self._t @ jb[:, :, : self._n1], fr.position[1] - fr.position[0]), je[:, :, self._n1 :]),
                    axis=2,
                )
            for s in range(0, N, size):
                inside = np.flatnonzero((uncertified >= s) & (uncertified < s + size))
                for out, jac, bit in ((k, je, kern.K_UNCERTIFIED), (kb, jt, kern.KB_UNCERTIFIED)):
                    for r in inside.tolist():
                        i = int(uncertified[r])
                        if flags[i] & bit:
                            out[i] = _reference_condition(jac[r], errors, i)
        c_e: dict[str, Array] = {}
        ci: dict[str, Array] = {}
        for m in mods:
            c_e[m], ci[m] = (ce_con, ci_con) if m == "constrained" else (ce_proj, ci_proj)
        unloaded = int(np.count_nonzero(flags & kern.UNLOADED_ROW)) if con else 0
        return BatchEvaluation(C_e=c_e, Ci=ci, k=k, k_braced=kb if k_braced else None, models=mods), unloaded

    def _compliance(
        self, je: Array, jb: Array, d: Array, models: tuple[str, ...], k_braced: bool, offset: int
    ) -> tuple[dict[str, Array], Array | None, int]:
        n1 = self._n1
        j1 = np.ascontiguousarray(jb[:, :, :n1])
        je2 = je[:, :, n1:]
        c2 = _gram(je2, self._k2inv)  # S_t2 C2 S_t2ᵀ
        # J̃ = [S_t1 (I − P) J1, S_t2 J2] (eq:J_wave); S_t1 x = [x_v + d × x_ω; x_ω]
        jh1 = _shift(self._t @ j1, d) if "projection" in models or k_braced else np.empty((0, 6, n1))
        jt = np.concatenate((jh1, je2), axis=2) if k_braced else None
        out: dict[str, Array] = {}
        bad = 0
        for m in models:
            if m == "projection":
                ce = _gram(jh1, self._k1inv) + c2
            else:  # S_t1 C̃1 S_t1ᵀ = (S_t1 (S_t1 C̃1)ᵀ)ᵀ
                c1t, bad = self._constrained(j1, offset)
                ce = _shift(_shift(c1t, d).transpose(0, 2, 1), d).transpose(0, 2, 1) + c2
            out[m] = 0.5 * (ce + ce.transpose(0, 2, 1))
        return out, jt, bad

    def _constrained(self, j1: Array, offset: int) -> tuple[Array, int]:
        """C̃1 = C1 − C1 X G Xᵀ C1 per configuration (compliance.braced_C1), and the unloaded count."""
        x = self._X
        c1 = _check_rows(_gram(j1, self._k1inv), offset, "C1")
        cx = c1 @ x  # (N, 6, m)
        g, unloaded = loaded_gain(x.T @ cx, np.trace(c1, axis1=1, axis2=2), self._k_env)
        out = c1 - cx @ g @ cx.transpose(0, 2, 1)
        return 0.5 * (out + out.transpose(0, 2, 1)), int(np.count_nonzero(unloaded))


def _betas(beta_x: ArrayLike, N: int) -> Array:
    b = as_array(beta_x, "beta_x", finite=False)
    if b.shape == (6,):
        return np.broadcast_to(unit(b, "beta_x"), (N, 6))
    if b.shape != (N, 6):
        raise InputError(f"beta_x must have shape (6,) or ({N}, 6), got {b.shape}")
    with finite_math("the norms of beta_x"):
        norms = np.linalg.norm(b, axis=1) if np.all(np.isfinite(b)) else np.zeros(N)
    if np.any(norms < 1e-12):
        raise InputError("every beta_x must be a finite, non-zero 6-vector [v; ω]")
    return b / norms[:, None]


def _check_rows(a: Array, offset: int, what: str) -> Array:
    """A (one row per configuration) if finite; else NumericalError naming the first configuration that is not."""
    finite = np.isfinite(a.reshape(a.shape[0], -1)).all(axis=1)
    if not finite.all():
        i = int(np.argmin(finite))
        check_finite(a[i], f"{what} at configuration {offset + i}")
    return a


def _gram(j: Array, kinv: Array) -> Array:
    """J K⁻¹ Jᵀ for a stack of Jacobians (N, 6, m)."""
    return (j * kinv) @ np.ascontiguousarray(j.transpose(0, 2, 1))


def _shift(j: Array, d: Array) -> Array:
    """S_t1 J for a stack (N, 6, m): moves the twists' reference point by d = b − e (eq:twists)."""
    out = j.copy()  # rows v += d × ω, written out (np.cross's operations, without its overhead)
    w0, w1, w2 = j[:, 3], j[:, 4], j[:, 5]
    dx, dy, dz = d[:, 0, None], d[:, 1, None], d[:, 2, None]
    out[:, 0] += dy * w2 - dz * w1
    out[:, 1] += dz * w0 - dx * w2
    out[:, 2] += dx * w1 - dy * w0
    return out


def _inverse_trace(m: Array) -> Array:
    """tr(M⁻¹) for a stack of symmetric positive-definite matrices: ‖L⁻¹‖²_F with M = L Lᵀ (Cholesky).

    L⁻¹ by forward substitution, vectorised over the stack. Raises LinAlgError if one is not positive definite.
    """
    low = np.linalg.cholesky(m)
    N, size = m.shape[0], m.shape[1]
    inv = np.zeros((N, size, size))
    diag = 1.0 / np.diagonal(low, axis1=1, axis2=2)
    for i in range(size):
        row = -np.einsum("nk,nkj->nj", low[:, i, :i], inv[:, :i, :]) if i else np.zeros((N, size))
        row[:, i] += 1.0
        inv[:, i, :] = row * diag[:, i, None]
    return cast(Array, np.einsum("nij,nij->n", inv, inv))


def _frobenius(j: Array, errors: str, offset: int) -> Array:
    """K of eq:manip for a stack of 6×n Jacobians, certified or recomputed by frobenius_condition."""
    m = j @ np.ascontiguousarray(j.transpose(0, 2, 1))
    a = np.trace(m, axis1=1, axis2=2)
    with np.errstate(all="ignore"):
        try:
            bb = _inverse_trace(m)
        except np.linalg.LinAlgError:  # some JJᵀ is not positive definite: certify the others one by one
            bb = np.full(a.shape, np.inf)
            for i in range(m.shape[0]):
                try:
                    bb[i] = _inverse_trace(m[i : i + 1])[0]
                except np.linalg.LinAlgError:
                    pass
        k2 = a * bb
        k = np.sqrt(k2) / 6.0
    for i in np.flatnonzero(~(k2 < CERTIFIED_COND**2)).tolist():  # 36 k² ≥ cond(J)²; also nan
        k[i] = _reference_condition(j[i], errors, offset + int(i))
    return cast(Array, k)


def _reference_condition(j: Array, errors: str, index: int) -> float:
    """frobenius_condition(j) of configuration `index`: SingularityError naming it, or NaN with errors="nan"."""
    try:
        return frobenius_condition(j)
    except SingularityError as exc:
        if errors == "raise":
            raise SingularityError(f"configuration {index}: {exc}") from exc
        return float("nan")


def _max_threads() -> int:
    """The size of numba's thread pool (NUMBA_NUM_THREADS), the most threads one call can use."""
    import numba

    return int(numba.config.NUMBA_NUM_THREADS)  # type: ignore[attr-defined]


def evaluate_batch(
    braced: BracedRobot,
    Q: ArrayLike,
    beta_x: ArrayLike,
    *,
    models: Sequence[ComplianceModel | str] = COMPLIANCE_MODELS,
    errors: str = "raise",
    k_braced: bool = False,
    backend: Backend = "auto",
    threads: int | None = None,
) -> BatchEvaluation:
    """C_e (each model), C_i along β_x and k at every row of Q (N×n); see :class:`BatchEvaluator`.

    Build a :class:`BatchEvaluator` once when evaluating many batches of the same robot. ``backend`` and
    ``threads`` are those of :class:`BatchEvaluator` (numba when installed; ``threads=1`` for one thread).
    """
    return BatchEvaluator(braced, backend)(Q, beta_x, models=models, errors=errors, k_braced=k_braced, threads=threads)
