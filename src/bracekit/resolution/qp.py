"""Braced redundancy resolution as one quadratic program per step: the strategy ``braced_qp``.

Per step, in the joint velocities q̇ (n,), rad/s (m/s for a prismatic joint):

    minimise   ½ (1 + μ) ‖q̇‖² + ½ w ‖S J_e q̇ − S ẋ‖² − α (∂g/∂q)ᵀ q̇
    subject to X_iᵀ J_b_i q̇ = −(β/dt) X_iᵀ ρ_i             every brace i                  (contacts)
               S J_e q̇ = S ẋ                                when the task is an equality   (task)
               max(−q̇_max, γ (q_min − q)/dt) ≤ q̇ ≤ min(q̇_max, γ (q_max − q)/dt)     (joint limits)
               (∂r_i/∂q) q̇ ≤ γ (r_max,i − r_i)/dt            every brace with a region, r_i > r_max,i/2
               (∂c_j/∂q) q̇ ≥ −γ_c max(c_j − c_min, 0)/dt − ε   every link j with c_j < margin (clearance)

S = S(⁰R_e) the task rows of the :class:`~bracekit.resolution.task_space.TaskSpace` and ẋ the tip twist [v; ω]
(m/s, rad/s), J_e and J_b_i the tip's and brace i's Jacobians (LOCAL_WORLD_ALIGNED, 6×n), X_i brace i's constraint
wrenches (eq:constraint) and ρ_i = [n̂ n̂ᵀ(b_i − p_i); 0] the offset of b_i from its plane (m), closed at the rate
β/dt (Baumgarte). q̇_max are the URDF velocity limits, q_min, q_max the position limits, approached at the rate
γ/dt; c_j is link j's clearance from each brace's surface (m, :mod:`bracekit.kinematics.clearance`) and ∂c_j/∂q
its gradient: a link at or inside c_min may not go deeper (a step cannot take it out against the task; ε =
:data:`CLEARANCE_SLACK` absorbs round-off where its row is parallel to a contact's). Where that leaves no
solution (a start with links already inside, which the task and the contacts drive deeper), the clearance rows
become soft: (∂c_j/∂q) q̇ + s_j ≥ γ_c (c_min − c_j)/dt with s_j ≥ 0 and a cost ½ w_s ‖s‖² (w_s =
:data:`SOFT_CLEARANCE_WEIGHT`; for a link inside c_min a rate out of it), so the step keeps the links as clear as
the equalities allow, said by a ClearanceWarning (the run's verdict names a link inside an obstacle). The link
that carries a pad, the one whose capsule ends at a pad on a joint's origin, and any link whose clearance moves
only with a pad's normal motion (its row in the span of the contact rows) touch that surface by design and are
left out for it. g is the objective of eq:objective (its analytic ∂g/∂q, eq:grad_g, or central differences;
for any number of braces), α < 0.

The task is an equality (``task_weight=None``, the default) or a weighted cost w. μ is the damping of Nakamura
and Hanafusa: μ = λ (1 − (σ/ε)²) while σ, the least singular value of B = S J_e N over the contact motions N
(σ_min/σ_max), is below ε, else 0; with the task an equality, B singular raises SingularityError instead.

With the task an equality, μ = 0 and no inequality active, the solution is the closed form of
the braced motions N (state.N): q̇ = N [B⁺ S ẋ + α (I − B⁺B) Nᵀ ∂g/∂q] on the surface (the least-norm q̇; for
one brace the paper's A⁺ weighs (b̃, q2) instead, so braced_qp's path differs from braced gradient projection's).

It never fails silently: an infeasible QP raises NumericalError naming the first constraint set (contacts, task,
joint limits, clearance) whose addition makes it infeasible; a solution that misses a constraint by more than
:data:`QP_FEASIBILITY_TOL` raises too.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from functools import lru_cache
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from bracekit._linalg import as_number, show
from bracekit.errors import ClearanceWarning, InputError, MissingDependencyError, NumericalError, SingularityError
from bracekit.kinematics import BracedRobot, BracedState
from bracekit.kinematics.clearance import Clearance
from bracekit.objective import Objective
from bracekit.resolution.strategies import GRADIENT_MODES, BracedGradientProjection, GradientMode, tip_twist
from bracekit.resolution.task_space import POSE, TaskSpace, select
from bracekit.tolerances import STEP_SINGULAR_RATIO

Array = NDArray[np.float64]
#: How far (in the rows' own units) a QP solution may miss an equality, a bound or an inequality.
QP_FEASIBILITY_TOL = 1e-9
#: The QP solvers braced_qp accepts (qpsolvers names).
QP_SOLVERS = ("daqp", "proxqp")
#: How fast (m/s) a link at or inside c_min may still go deeper: the round-off of a row parallel to a contact's.
CLEARANCE_SLACK = 1e-10
#: A clearance row with less than this part (relative) off the contact rows is held by the contacts and left out.
HELD_BY_CONTACT = 1e-4
#: w_s, the cost (s²/m²) of the rate s (m/s) by which a link inside c_min falls short of leaving, when soft.
SOFT_CLEARANCE_WEIGHT = 1e4
#: Relative rank tolerance of the stacked contact rows G.
CONTACT_RANK_RTOL = 1e-10


class ContactRows(NamedTuple):
    """Every brace's contact rows at q: G = [X_iᵀ J_b_i] (k×n) and the plane offsets Xᵢᵀ ρ_i (k,), m."""

    G: Array
    offset: Array


class ClearanceRow(NamedTuple):
    """One link's clearance c (m) from one brace's surface and ∂c/∂q (n,)."""

    name: str
    clearance: float
    gradient: Array


class ConstraintSet(NamedTuple):
    """Rows of the QP: equality (M q̇ = v) or inequality (M q̇ ≤ v), named for the error messages."""

    name: str
    equality: bool
    M: Array
    v: Array


def contact_rows(state: BracedState) -> ContactRows:
    """The adapter to bracekit's state: X_iᵀ J_b_i and X_iᵀ [n̂ n̂ᵀ(b_i − p_i); 0] of every brace i at the state."""
    braces, points, jacobians = state.braced.braces, state.b_i, state.J_b_i
    rows, offsets = [], []
    for brace, b, j_b in zip(braces, points, jacobians, strict=True):
        x = brace.X()
        n = brace.surface.normal
        rho = np.concatenate([n * brace.surface.signed_distance(b), np.zeros(3)])
        rows.append(x.T @ j_b)
        offsets.append(x.T @ rho)
    return ContactRows(np.vstack(rows), np.concatenate(offsets))


@lru_cache(maxsize=16)
def _clearance_models(braced: BracedRobot) -> tuple[tuple[Clearance, frozenset[int]], ...]:
    """Each brace's clearance model with the links it leaves out beside the pad's own (Clearance skips that one).

    A pad at its joint's origin also touches its surface through the previous link's capsule when that capsule
    ends at the origin (the default capsule does): that link is left out for this brace's surface too.
    """
    robot = braced.robot
    model = robot.model
    out = []
    for brace, fid in zip(braced.braces, braced.brace_ids, strict=True):
        one = braced if len(braced.braces) == 1 else BracedRobot(robot, brace)
        joint = int(model.frames[fid].parentJoint)
        skip = set()
        if joint > 1 and np.linalg.norm(model.frames[fid].placement.translation) < 1e-9:
            origin = model.jointPlacements[joint].translation
            for capsule in robot.link_capsules():
                ends_there = min(np.linalg.norm(capsule.a - origin), np.linalg.norm(capsule.b - origin)) < 1e-9
                if capsule.joint == joint - 1 and ends_there:
                    skip.add(joint - 2)  # chain order (0-based), as LinkDistance.joint
        out.append((Clearance(one), frozenset(skip)))
    return tuple(out)


def clearance_rows(braced: BracedRobot, q: Array, below: float) -> list[ClearanceRow]:
    """The adapter to bracekit's clearance: each link closer than `below` (m) to a brace's surface, with ∂c/∂q."""
    out = []
    for i, (model, skip) in enumerate(_clearance_models(braced)):
        for link in model.links(q, gradient=True, below=below):
            if link.clearance < below and link.joint not in skip:
                name = f"link {link.joint + 1} from braces[{i}]'s surface"
                out.append(ClearanceRow(name, link.clearance, link.gradient))
    return out


def region_rows(state: BracedState, rate: float) -> ConstraintSet | None:
    """Each brace point b_i kept inside its region: (∂r_i/∂q) q̇ ≤ rate (r_max,i − r_i), r_i = ‖(I − n̂n̂ᵀ)(b_i − p_i)‖.

    `rate` = γ/dt (1/s); only braces with a region and r_i above half of r_max get a row (∂r_i/∂q is undefined at
    the centre). None when no brace has one.
    """
    rows, bounds = [], []
    for brace, b, j_b in zip(state.braced.braces, state.b_i, state.J_b_i, strict=True):
        if brace.region_radius is None:
            continue
        n = brace.surface.normal
        off = b - brace.surface.point
        off = off - n * float(n @ off)
        r = float(np.linalg.norm(off))
        if r > 0.5 * brace.region_radius:
            rows.append((off / r) @ j_b[:3])
            bounds.append(rate * (brace.region_radius - r))
    if not rows:
        return None
    return ConstraintSet("the brace regions (r_i ≤ r_max)", False, np.array(rows), np.array(bounds))


def _free_of_contacts(rows: list[ClearanceRow], g: Array) -> list[ClearanceRow]:
    """The rows whose ∂c/∂q is not in the span of the contact rows G (relative part off it > HELD_BY_CONTACT).

    A link whose clearance moves only as a pad's normal motion (its nearest point at the pad) is held by the contact
    equality; its inequality would repeat that row and conflict with it by round-off.
    """
    if not rows:
        return rows
    _, s, vt = np.linalg.svd(g, full_matrices=False)
    basis = vt[s > CONTACT_RANK_RTOL * max(1.0, s[0] if s.size else 1.0)]
    out = []
    for r in rows:
        size = float(np.linalg.norm(r.gradient))
        if size > 0.0 and np.linalg.norm(r.gradient - basis.T @ (basis @ r.gradient)) > HELD_BY_CONTACT * size:
            out.append(r)
    return out


def _solve(sets: list[ConstraintSet], p: Array, c: Array, solver: str) -> Array | None:
    """The QP's q̇, or None when the solver finds none (infeasible or failed)."""
    import qpsolvers

    eq = [s for s in sets if s.equality]
    ineq = [s for s in sets if not s.equality]
    problem = qpsolvers.Problem(
        p,
        c,
        np.vstack([s.M for s in ineq]) if ineq else None,
        np.concatenate([s.v for s in ineq]) if ineq else None,
        np.vstack([s.M for s in eq]) if eq else None,
        np.concatenate([s.v for s in eq]) if eq else None,
    )
    options: dict[str, Any] = {"eps_abs": 1e-10, "eps_rel": 0.0} if solver == "proxqp" else {"primal_tol": 1e-12}
    result = qpsolvers.solve_problem(problem, solver=solver, **options)
    if not result.found or result.x is None or not np.all(np.isfinite(result.x)):
        return None
    return np.asarray(result.x, dtype=np.float64)


def _infeasible(sets: list[ConstraintSet], p: Array, c: Array, solver: str) -> NumericalError:
    """The error naming the first constraint set whose addition leaves the QP without a solution."""
    for k in range(1, len(sets) + 1):
        if _solve(sets[:k], p, c, solver) is None:
            before = ", ".join(s.name for s in sets[: k - 1]) or "nothing else"
            return NumericalError(
                f"braced_qp: the QP has no solution: {sets[k - 1].name} cannot hold together with {before}; "
                "slow the task, move the start away from the limits or the obstacle, or weight the task (task_weight)"
            )
    return NumericalError(f"braced_qp: the QP solver {solver} found no solution although each constraint set holds")


def _check(sets: list[ConstraintSet], qdot: Array) -> None:
    for s in sets:
        miss = s.M @ qdot - s.v
        worst = float(np.max(np.abs(miss) if s.equality else miss, initial=0.0))
        if worst > QP_FEASIBILITY_TOL * (1.0 + float(np.max(np.abs(s.v), initial=0.0))):
            raise NumericalError(f"braced_qp: the QP solution misses {s.name} by {worst:.3g}")


def _require_qpsolvers(solver: str) -> None:
    try:
        import qpsolvers
    except ImportError as exc:
        raise MissingDependencyError("braced_qp needs qpsolvers: pip install 'bracekit[qp]'") from exc
    if solver not in qpsolvers.available_solvers:
        raise MissingDependencyError(
            f"braced_qp: the QP solver {solver!r} is not installed: pip install 'bracekit[qp]'"
        )


@dataclass(frozen=True)
class BracedQP:
    """Strategy ``braced_qp``: one QP per step (module docstring), every brace kept, limits and clearance hard.

    Args:
        objective: g (an Objective, for any number of braces), or None for no linear cost.
        alpha: the gain α < 0 of −α ∂g/∂q in the cost (as in eq:grad_proj).
        gradient: ``analytic`` (kinematic Hessians; one brace) or ``finite-difference``.
        dt: the step (s) the position limits, the contact drift and the clearance are projected over.
        task_weight: None: the task rows are an equality; w > 0: a cost ½ w ‖S J_e q̇ − S ẋ‖².
        damping: λ, the largest Nakamura–Hanafusa damping (only with a task cost).
        singular_band: ε, the σ_min/σ_max of B below which the damping acts.
        baumgarte: β ∈ [0, 1], the share of the contact offset closed per step.
        limit_gain: γ ∈ (0, 1], the share of the distance to a joint limit a step may use.
        clearance_margin: links closer than this (m) to a surface get a clearance inequality; None: none.
        clearance_min: c_min (m), the least clearance kept.
        clearance_gain: γ_c ∈ (0, 1], the share of c_j − c_min a step may use.
        solver: ``daqp`` or ``proxqp`` (through qpsolvers).
        space: the task rows S(⁰R_e).
    """

    objective: Objective | None = None
    alpha: float = -1.0
    gradient: GradientMode = "analytic"
    dt: float = 0.05
    task_weight: float | None = None
    damping: float = 1e-3
    singular_band: float = 0.01
    baumgarte: float = 0.5
    limit_gain: float = 0.5
    clearance_margin: float | None = 0.05
    clearance_min: float = 0.002
    clearance_gain: float = 0.5
    solver: str = "daqp"
    fd_step: float = 1e-5
    space: TaskSpace = POSE
    name: str = "braced_qp"
    braced: bool = True

    def __post_init__(self) -> None:
        if self.objective is not None and not isinstance(self.objective, Objective):
            raise InputError(f"the objective must be a bracekit Objective or None, got {type(self.objective).__name__}")
        if as_number(self.alpha, "the QP gradient gain alpha") >= 0:
            raise InputError(f"the QP gradient gain alpha must be negative (it descends g), got {self.alpha}")
        if not isinstance(self.gradient, str) or self.gradient not in GRADIENT_MODES:
            raise InputError(f"unknown gradient mode {show(self.gradient)}; choose one of {', '.join(GRADIENT_MODES)}")
        as_number(self.dt, "the QP step dt", positive=True, unit="s")
        if self.task_weight is not None:
            as_number(self.task_weight, "the task weight task_weight", positive=True)
        as_number(self.damping, "the QP damping", nonnegative=True)
        as_number(self.singular_band, "the QP singular band", positive=True)
        as_number(self.clearance_min, "the least clearance clearance_min", unit="m")
        if self.clearance_margin is not None:
            as_number(self.clearance_margin, "the clearance margin", positive=True, unit="m")
        for what in ("baumgarte", "limit_gain", "clearance_gain"):
            value = as_number(getattr(self, what), f"the QP gain {what}", nonnegative=True)
            if value > 1.0 or (what != "baumgarte" and value == 0.0):
                raise InputError(f"the QP gain {what} must lie in (0, 1], got {value:g}")
        if self.solver not in QP_SOLVERS:
            raise InputError(f"unknown QP solver {show(self.solver)}; choose one of {', '.join(QP_SOLVERS)}")
        if not isinstance(self.space, TaskSpace):
            raise InputError(f"space must be a TaskSpace, got {show(self.space)}")
        _require_qpsolvers(self.solver)

    @property
    def needs_hessians(self) -> bool:
        """Whether the analytic gradient (kinematic Hessians) is used."""
        return self.objective is not None and self.gradient == "analytic"

    def dg_dq(self, state: BracedState) -> Array:
        """∂g/∂q (n,) of the objective (zeros without one), as gradient projection computes it."""
        if self.objective is None:
            return np.zeros(state.q.size)
        gp = BracedGradientProjection(self.objective, self.alpha, self.gradient, self.fd_step, space=self.space)
        return gp.dg_dq(state)

    def constraint_sets(self, state: BracedState, xdot: Array) -> list[ConstraintSet]:
        """The QP's constraint sets at the state, in the order an infeasibility is diagnosed."""
        q, robot, dt = state.q, state.braced.robot, float(self.dt)
        contacts = contact_rows(state)
        sets = [
            ConstraintSet(
                "the contact constraints X_iᵀ J_b_i q̇", True, contacts.G, -self.baumgarte / dt * contacts.offset
            )
        ]
        if self.task_weight is None:
            s_j, s_x = select(self.space, state.R_e, state.J_e, xdot)
            sets.append(ConstraintSet(f"the task rows ({self.space.kind})", True, s_j, s_x))
        vmax = np.asarray(robot.model.velocityLimit, dtype=float)
        vmax = np.where(vmax > 0, vmax, np.inf)
        upper = np.minimum(vmax, self.limit_gain * (robot.upper - q) / dt)
        lower = np.maximum(-vmax, self.limit_gain * (robot.lower - q) / dt)
        eye = np.eye(q.size)
        keep_u, keep_l = np.isfinite(upper), np.isfinite(lower)
        sets.append(
            ConstraintSet(
                "the joint position and velocity limits",
                False,
                np.vstack([eye[keep_u], -eye[keep_l]]),
                np.concatenate([upper[keep_u], -lower[keep_l]]),
            )
        )
        regions = region_rows(state, self.limit_gain / dt)
        if regions is not None:
            sets.append(regions)
        if self.clearance_margin is not None:
            rows = _free_of_contacts(clearance_rows(state.braced, q, float(self.clearance_margin)), contacts.G)
            if rows:
                sets.append(
                    ConstraintSet(
                        "the link clearance (" + ", ".join(r.name for r in rows) + ")",
                        False,
                        -np.array([r.gradient for r in rows]),
                        np.array([self.clearance_gain * max(r.clearance - self.clearance_min, 0.0) / dt for r in rows])
                        + CLEARANCE_SLACK,
                    )
                )
        return sets

    def _damping(self, state: BracedState, g: Array) -> float:
        """μ: Nakamura–Hanafusa damping on σ_min/σ_max of B = S J_e N (SingularityError with an equality task)."""
        _, s, vt = np.linalg.svd(g)
        rank = int(np.sum(s > CONTACT_RANK_RTOL * max(1.0, s[0] if s.size else 1.0)))
        b = select(self.space, state.R_e, state.J_e @ vt[rank:].T, np.zeros(6))[0]
        sb = np.linalg.svd(b, compute_uv=False) if b.size else np.zeros(0)
        ratio = float(sb[-1] / sb[0]) if b.shape[1] >= b.shape[0] and sb.size and sb[0] > 0 else 0.0
        if self.task_weight is None:
            if ratio <= STEP_SINGULAR_RATIO:
                raise SingularityError(
                    f"braced_qp: the task rows over the contact motions S J_e N are singular (σ_min/σ_max = "
                    f"{ratio:.2e}); give the task a weight (task_weight) to pass it damped"
                )
            return 0.0
        band = float(self.singular_band)
        return float(self.damping) * (1.0 - (ratio / band) ** 2) if ratio < band else 0.0

    def velocity(self, state: BracedState, xdot: ArrayLike) -> Array:
        """Joint velocities q̇ (n,) of the QP at the state for the tip twist ẋ (6,)."""
        x = tip_twist(xdot)
        sets = self.constraint_sets(state, x)
        mu = self._damping(state, sets[0].M)
        n = state.q.size
        p = (1.0 + mu) * np.eye(n)
        c = -float(self.alpha) * self.dg_dq(state)
        if self.task_weight is not None:
            s_j, s_x = select(self.space, state.R_e, state.J_e, x)
            p += float(self.task_weight) * s_j.T @ s_j
            c -= float(self.task_weight) * s_j.T @ s_x
        qdot = _solve(sets, p, c, self.solver)
        if qdot is None:
            soft = self._soften(state, sets, p, c)
            if soft is None:
                raise _infeasible(sets, p, c, self.solver)
            return soft
        _check(sets, qdot)
        return qdot

    def _soften(self, state: BracedState, sets: list[ConstraintSet], p: Array, c: Array) -> Array | None:
        """q̇ with every clearance row soft (module docstring), or None without clearance rows.

        Variables [q̇; s]: every other row as before, the clearance rows −(∂c_j/∂q) q̇ − s_j ≤ −γ_c (c_min − c_j)/dt
        (the hard rows' rate for a link outside c_min, a rate out of it for one inside), s ≥ 0, cost ½ w_s ‖s‖².
        None also when the QP stays without a solution (the caller names the set).
        """
        if self.clearance_margin is None:
            return None
        rows = _free_of_contacts(clearance_rows(state.braced, state.q, float(self.clearance_margin)), sets[0].M)
        if not rows:
            return None
        n, m, dt = state.q.size, len(rows), float(self.dt)
        kept = [s for s in sets if not s.name.startswith("the link clearance")]
        wide = [ConstraintSet(s.name, s.equality, np.hstack([s.M, np.zeros((s.M.shape[0], m))]), s.v) for s in kept]
        grad = np.array([r.gradient for r in rows])
        rate = np.array([self.clearance_gain * (self.clearance_min - r.clearance) / dt for r in rows])
        wide.append(ConstraintSet("the soft link clearance", False, np.hstack([-grad, -np.eye(m)]), -rate))
        wide.append(ConstraintSet("the soft slack", False, np.hstack([np.zeros((m, n)), -np.eye(m)]), np.zeros(m)))
        p_wide = np.zeros((n + m, n + m))
        p_wide[:n, :n] = p
        p_wide[n:, n:] = SOFT_CLEARANCE_WEIGHT * np.eye(m)
        x = _solve(wide, p_wide, np.concatenate([c, np.zeros(m)]), self.solver)
        if x is None:
            return None
        _check(wide, x)
        short = [r.name for r, slack in zip(rows, x[n:], strict=True) if slack > QP_FEASIBILITY_TOL]
        warnings.warn(
            "braced_qp: the task and the contacts drive a link toward the obstacle faster than the clearance rows "
            f"allow ({', '.join(short) or 'none short in the end'}): the clearance rows are soft at this step",
            ClearanceWarning,
            stacklevel=3,
        )
        return np.asarray(x[:n], dtype=np.float64)
