"""The compiled gradient-projection step with several braces: one Pinocchio pass, then one numba call.

:class:`SeveralBraceKernel` serves :class:`~bracekit.resolution.GradientProjectionStep` with N ≥ 2 braces and
``backend="numba"`` (or ``"auto"`` with numba installed). It computes the q̇ of
``BracedGradientProjection.velocity(braced.state(q, hessians=True), ẋ)`` — q̇ = N [B⁺ S ẋ + α (I − B⁺B) Nᵀ ∂g/∂q],
B = S J_e N (docs/model.md, "Several braces") — in :func:`bracekit.resolution._numba_several.gp_step_several`,
with the terms that have a compiled copy there: the compliance index C_i of the constrained model (eq:Ce), each
brace's region barrier d_i and the joint-limit barrier; a braced-conditioning barrier (eq:cond_barrier) where the
kernel certifies it inactive (σ_min/σ_max of its rows of C_e above r₀ with a margin: it adds nothing), else the
kernel declines. It does not apply (``fallback_reason`` says why) to
finite-difference gradients, other terms or a compliant environment; at a configuration where the kernel's
certificates fail it returns None and the caller runs the reference step (same errors and warnings).
"""

from __future__ import annotations

from types import ModuleType
from typing import Any, NamedTuple

import numpy as np
import pinocchio as pin
from numpy.typing import NDArray

from bracekit.compliance.first_order import unit6
from bracekit.kinematics import LWA, BracedRobot, frame_hessian_rows
from bracekit.kinematics.hessian import ensure_hessian_layout
from bracekit.objective import ComplianceIndex, JointLimitBarrier, Objective, RegionBarrier
from bracekit.resolution.strategies import BracedGradientProjection
from bracekit.tolerances import CERTIFIED_COND, NULL_SPACE_RTOL, UNLOADED_TOL

Array = NDArray[np.float64]
#: (⁰M, J) of the tip, then of each brace, as :meth:`BracedRobot.state_from_kinematics` takes them.
Kinematics = tuple[tuple[Array, Array], ...]


class FramePass(NamedTuple):
    """A Pinocchio pass already made at a q (``computeJointJacobians`` and the frames' placements), to share.

    Attributes:
        data: the Data the pass wrote (Pinocchio's joint Jacobians at q); a step adds its kinematic Hessians.
        placements: ⁰M (k, 4, 4) of the tip, then of each brace, in the order of ``braced.braces``.
        jacobians: J (k, 6, n), LOCAL_WORLD_ALIGNED, of the same frames.
    """

    data: pin.Data
    placements: Array
    jacobians: Array


def kernel_inputs(ci: Array, beta_x: Any, xd: Array) -> tuple[Array, Array]:
    """The kernels' compliance-index rows with β_x (6,) replaced, and ẋ (6,) as their one compiled signature takes it.

    β_x is made a unit twist as ``ComplianceIndex(beta_x)`` does (the same InputError); None keeps the rows.
    """
    if beta_x is not None and ci.shape[0]:
        ci = ci.copy()
        ci[:, :6] = unit6(beta_x, "beta_x")
    if not (xd.flags.c_contiguous and xd.flags.writeable):
        xd = xd.copy()
    return ci, xd


class KernelInputs:
    """:func:`kernel_inputs` of one kernel's compliance-index rows, those of the last β_x kept while it stays the same.

    A run's β_x(t) is often one twist for every t: its rows are then formed (and β_x made a unit twist) once. The
    same numbers as :func:`kernel_inputs`: β_x is compared by its bytes (a float64 (6,) array), else formed anew.
    """

    def __init__(self, ci: Array) -> None:
        self.ci = ci
        self._last: tuple[bytes, Array] | None = None

    def __call__(self, beta_x: Any, xd: Array) -> tuple[Array, Array]:
        """(The compliance-index rows at β_x, ẋ) as :func:`kernel_inputs` gives them."""
        key = None
        if type(beta_x) is np.ndarray and beta_x.dtype == np.float64 and beta_x.shape == (6,):
            key = beta_x.tobytes()
            last = self._last
            if last is not None and last[0] == key:
                return kernel_inputs(last[1], None, xd)
        ci, xd = kernel_inputs(self.ci, beta_x, xd)
        if key is not None:
            self._last = (key, ci)
        return ci, xd


def _conditioning_rows(term: Any) -> int | None:
    """The task rows (6 or 3) of a braced-conditioning barrier whose inactivity the kernel can certify, else None.

    The barrier (``BracedConditioning``, the term of key ``conditioning``) adds nothing where σ_min/σ_max of its
    rows of C_e is above r₀; the kernel certifies that or declines (the reference then computes it). Rows fixed
    in the world only: the full pose (space None or ``pose``) or the position.
    """
    kind = type(term)
    if (kind.__module__, kind.__qualname__) != ("bracekit.objective.braced_conditioning", "BracedConditioning"):
        return None
    space = getattr(term, "space", None)
    name = "pose" if space is None else getattr(space, "kind", None)
    return {"pose": 6, "position": 3}.get(str(name))


def _term_rows(objective: Objective, braces: int, n: int) -> tuple[Array, Array, Array, Array] | str:
    """The kernel's rows (ci, reg, jl, cond) of the objective's terms of non-zero weight, or the name of one it lacks.

    A term the reference refuses (a region barrier of a brace the robot lacks, joint limits of another length) is
    left to the reference, which raises its error.
    """
    ci: list[list[float]] = []
    reg: list[list[float]] = []
    jl: list[list[float]] = []
    cond: list[list[float]] = []
    for term, weight in zip(objective.terms, objective.weights, strict=True):
        w = float(weight)
        if not w:
            continue
        kind = type(term)  # exactly these classes: a subclass may change value or gradient
        if kind is ComplianceIndex and isinstance(term, ComplianceIndex) and term.model == "constrained":
            ci.append([*term.beta_x.tolist(), w])
        elif kind is RegionBarrier and isinstance(term, RegionBarrier) and term.brace < braces:
            reg.append([float(term.brace), *term.centre.tolist(), float(term.r_max), w])
        elif kind is JointLimitBarrier and isinstance(term, JointLimitBarrier) and term.lower.size == n:
            index = term._index  # type: ignore[attr-defined]  # the bounded joints
            jl.extend([float(j), float(term.lower[j]), float(term.upper[j]), w] for j in index)
        elif (rows := _conditioning_rows(term)) is not None:
            cond.append([float(term.threshold), float(rows)])  # type: ignore[attr-defined]
        else:
            return str(getattr(term, "name", kind.__name__))
    return (
        np.array(ci, dtype=float).reshape(-1, 7),
        np.array(reg, dtype=float).reshape(-1, 6),
        np.array(jl, dtype=float).reshape(-1, 4),
        np.array(cond, dtype=float).reshape(-1, 2),
    )


class SeveralBraceKernel:
    """q̇ of the gradient-projection step with several braces by the numba kernel (module docstring).

    Build with :meth:`build`, which says why the kernel does not apply; call per configuration. It owns its
    Pinocchio data: one instance per thread.
    """

    def __init__(
        self, braced: BracedRobot, strategy: BracedGradientProjection, kernels: ModuleType, rows: tuple[Array, ...]
    ) -> None:
        robot = braced.robot
        self._model, self._data = robot.model, robot.model.createData()
        self._tip, self._bids = robot.tip_id, tuple(braced.brace_ids)
        ensure_hessian_layout(self._model, self._data, (self._tip, *self._bids))
        ci, self._reg, self._jl, self._cond = rows
        self._inputs = KernelInputs(ci)
        xrows, rowbrace = [], []
        for i, x in enumerate(braced.X_i):
            for col in range(x.shape[1]):
                xrows.append(x[:, col])
                rowbrace.append(i)
        self._xrows = np.array(xrows, dtype=float).reshape(-1, 6)
        self._rowbrace = np.array(rowbrace, dtype=np.int64)
        self._kinv = np.ascontiguousarray(1.0 / robot.stiffness, dtype=float)
        self._space = strategy.space
        constant = self._space.kind in ("pose", "position")  # a writable copy: one compiled signature
        self._sel = np.array(self._space.selection(np.eye(3))) if constant else None
        self._par = np.array([float(strategy.alpha), CERTIFIED_COND**2, UNLOADED_TOL, NULL_SPACE_RTOL])
        self._kernel = kernels.gp_step_several
        self._last: tuple[Array, Kinematics] | None = None

    @classmethod
    def build(
        cls, braced: BracedRobot, strategy: BracedGradientProjection, kernels: ModuleType
    ) -> tuple[SeveralBraceKernel | None, str | None]:
        """(the kernel, None), or (None, why it does not apply)."""
        if strategy.gradient != "analytic":
            return None, "finite-difference gradient"
        if any(b.environment_stiffness is not None for b in braced.braces):
            return None, "several braces with a compliant environment: the reference step runs (same q̇)"
        rows = _term_rows(strategy.objective, len(braced.braces), braced.n)
        if isinstance(rows, str):
            return None, f"term without a compiled copy for several braces: {rows}"
        return cls(braced, strategy, kernels, rows), None

    def last_kinematics(self, q: Array) -> Kinematics | None:
        """(⁰M, J) of the tip and each brace from the last call if it was at this very array q, else None."""
        last = self._last
        return None if last is None or last[0] is not q else last[1]

    def __call__(self, qa: Array, xd: Array, beta_x: Any = None, at: FramePass | None = None) -> Array | None:
        """q̇ (n,) at a checked q (n,) for a checked ẋ (6,); None where the kernel declines.

        `at`: a pass already made at qa (the same numbers as this call's own): only the Hessians are computed.
        """
        ci, xd = self._inputs(beta_x, xd)
        model, data, tip, bids = self._model, self._data, self._tip, self._bids
        if at is not None:
            data, me, je = at.data, at.placements[0], at.jacobians[0]
            mbs, jbs = tuple(at.placements[1:]), tuple(at.jacobians[1:])
        else:
            pin.computeJointJacobians(model, data, qa)
            me = pin.updateFramePlacement(model, data, tip).homogeneous  # the frames asked for, not all the model's
            mbs = tuple(pin.updateFramePlacement(model, data, f).homogeneous for f in bids)
            je = pin.getFrameJacobian(model, data, tip, LWA)
            jbs = tuple(pin.getFrameJacobian(model, data, f, LWA) for f in bids)
        self._last = (qa, ((me, je), *zip(mbs, jbs, strict=True)))
        pin.computeJointKinematicHessians(model, data)
        he = frame_hessian_rows(model, data, tip)
        hbs = tuple(frame_hessian_rows(model, data, f) for f in bids)
        sel = self._sel if self._sel is not None else self._space.selection(me[:3, :3])
        kin = (je, jbs, he, hbs, mbs)
        terms = (ci, self._reg, self._jl, self._cond)
        status, out = self._kernel(qa, kin, sel, xd, self._xrows, self._rowbrace, self._kinv, terms, self._par)
        return out if status == 0 and bool(np.isfinite(out).all()) else None
