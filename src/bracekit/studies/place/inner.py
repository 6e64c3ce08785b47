"""The inner level: pad place and start posture optimised together at the task's start (SciPy SLSQP).

Variables x = (q, s, φ): the posture (n,), the fraction along the link and the angle about it (rad). The
surface is the spec's plane through the pad point, so it moves with the place (its height, or the post's
position); the contact is closed by construction. Minimise the objective — C_i (eq:compliance_index) or
c_t = β_xᵀ C_e β_x of the constrained model at the start's β_x — subject to

- the task's start pose: the tip at the task's start position (3 rows) and, with the task space ``pose``, its
  rotation (log₃(R₀ᵀ R_e) = 0, 3 rows; ``position+axis``: the tool axis, 1 row);
- k(J_e) ≤ the spec's ``feasibility.k_max`` (eq:manip, the free-space Jacobian's: the whole-task check uses J̃'s);
- every link but the braced one clear of the surface's solid by ``min_clearance`` + ``clearance_margin``
  (:mod:`bracekit.studies.place.clearance`);
- the pad facing the surface: its inward normal within ``max_tilt_deg`` of the surface normal, n_wᵀ n̂ ≥ cos;
- the posture within ``posture_radius`` R of the reference start q0, ‖q − q0‖² ≤ R² (rad²): the start alone does
  not see the task, and far from the reference start (the one the grid's candidates start from) the inner
  optimum tends to put a joint at its limit or a link through the surface later along the path;
- the joint limits less a margin and the fraction's bounds (SLSQP bounds); with a posture radius, each joint
  also within q0 ± R (the ball lies inside that box: the same feasible set, but SLSQP keeps every iterate
  in its bounds, whereas the ball's linearisation at q0 bounds nothing and the first step left it by radians).

Every gradient is analytic: the objective's through :mod:`bracekit.studies.place.compliance`, the pose's
through J_e, the pad's through :mod:`bracekit.studies.place.kinematics`, k's through
:class:`bracekit.objective.ConditionNumber`. Margins need statics: ``paper`` has none, so none is constrained
here; the whole-task evaluation applies the sweep's margin rules (:mod:`bracekit.studies.place.outer`).
"""

from __future__ import annotations

import math
import time
import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np
import pinocchio as pin
from numpy.typing import NDArray

from bracekit.errors import BracekitError, ContactError
from bracekit.objective import ConditionNumber
from bracekit.studies.place.clearance import MovingClearance
from bracekit.studies.place.compliance import Measure, placed_compliance
from bracekit.studies.place.kinematics import PlacedBrace, link_axes_in_brace, placed_brace
from bracekit.studies.place.scenario import Place, place_scenario
from bracekit.studies.place.surface import PadSurface, SurfaceKind, link_surface
from bracekit.studies.sweep.spec import POINT_FRAME, SweepSpec

Array = NDArray[np.float64]


@dataclass(frozen=True)
class InnerSettings:
    """The inner problem's settings.

    Objective, tilt bound (degrees), clearance margin (m, over the spec's ``min_clearance``: the path moves the
    links), joint-limit margin (rad: a start at a limit leaves the task no room), fraction bounds, SLSQP
    iterations (the converged seeds of paper-links and panda-links take 12 to 24; the rest run to the limit
    with the pose still off by centimetres), the posture radius (rad about the reference start; None: no
    bound), the surface the pad is placed on (:func:`bracekit.studies.place.surface.link_surface`).
    """

    measure: Measure = "Ci"
    max_tilt_deg: float = 45.0
    clearance_margin: float = 0.01
    limit_margin: float = 0.3
    fraction_bounds: tuple[float, float] = (0.02, 0.98)
    maxiter: int = 60
    posture_radius: float | None = 0.3
    surface: SurfaceKind = "capsule"


@dataclass(frozen=True)
class InnerResult:
    """One seed's optimum: the place, the posture q (n,), the objective there (m/N), k, tilt (deg), success.

    ``radius``: the posture radius it was found within (rad; None: no bound).
    """

    seed: int
    place: Place
    q: Array
    value: float
    k: float
    tilt_deg: float
    pose_error: float
    success: bool
    message: str
    iterations: int
    wall_s: float
    radius: float | None = None

    def row(self) -> dict[str, Any]:
        """The result as a row of the evaluations table (SI units; the angle in degrees)."""
        return {
            "stage": "start",
            "seed": self.seed,
            "link": self.place.link,
            "fraction": self.place.fraction,
            "angle_deg": self.place.angle_deg,
            "start_value": self.value,
            "start_k": self.k,
            "start_tilt_deg": self.tilt_deg,
            "start_pose_error": self.pose_error,
            "start_success": self.success,
            "start_message": self.message,
            "iterations": self.iterations,
            "wall_s": self.wall_s,
            "start_radius": self.radius,
        }


def facing_angle(surface: PadSurface, rotation: Array, normal: Array) -> float:
    """The angle φ (rad) whose inward normal ⁰R_link n(φ) is nearest the surface normal."""
    a, b = -(normal @ rotation @ surface.x), -(normal @ rotation @ surface.y)
    return math.atan2(b, a) if math.hypot(a, b) > 1e-9 else 0.0


def _template(surface: PadSurface, link: str, settings: InnerSettings) -> Place:
    """The place the problem's scenario is built at; ContactError when no ray meets the surface.

    Mid-fraction, the first of four angles whose ray meets the surface (on a collision surface a ray may miss).
    """
    fraction = 0.5 * sum(surface.fraction_bounds(settings.fraction_bounds))
    for angle in (0.0, 0.5 * math.pi, math.pi, -0.5 * math.pi):
        try:
            surface.point(fraction, angle)
        except ContactError:
            continue
        return Place(link, fraction, angle)
    raise ContactError(f"no ray from the axis of link {link!r} at fraction {fraction:g} meets its surface")


class StartProblem:
    """The inner problem of one link (see the module); evaluations cached by x."""

    def __init__(self, spec: SweepSpec, link: str, q0: Array, settings: InnerSettings) -> None:
        robot = spec.base_scenario().robot
        self.surface = link_surface(robot, link, settings.surface)
        self.template = _template(self.surface, link, settings)
        self.scenario = place_scenario(spec, self.surface, self.template, q0)
        self.p0 = self.surface.point(self.template.fraction, self.template.angle)
        self.rot = link_axes_in_brace(self.scenario.robot, link, POINT_FRAME)
        self.settings = settings
        self.n = robot.n
        self.k_max = spec.feasibility.k_max
        self.normal = self.scenario.braced.braces[0].surface.normal
        task = self.scenario.task
        self.x0 = np.asarray(task.position(0.0), dtype=float)
        rotation = task.rotation
        self.R0 = self.scenario.braced.state(q0).R_e if rotation is None else np.asarray(rotation)
        self.space = self.scenario.task_space
        self.axis = np.array([0.0, 0.0, 1.0]) if self.space.axis is None else np.asarray(self.space.axis, dtype=float)
        self.beta = self.scenario.beta_x(0.0)
        self.X = self.scenario.braced.X_i[0]
        self.D = np.zeros(self.X.shape[1])
        self.k_term = ConditionNumber()
        self.q0 = np.asarray(q0, dtype=float)
        self.clearance = MovingClearance(self.scenario.braced)
        self.min_clearance = spec.feasibility.min_clearance + settings.clearance_margin
        self._key: bytes | None = None
        self._cache: tuple[Any, PlacedBrace, float, Array] | None = None
        self._ckey: bytes | None = None
        self._crows: tuple[Array, Array] | None = None

    def clearance_rows(self, x: Array) -> tuple[Array, Array]:
        """(Each link's clearance − the bound (J,), m; its gradient (J, n + 2)), the surface through the pad."""
        key = x.tobytes()
        if key != self._ckey or self._crows is None:
            _, pb, _, _ = self.evaluate(x)
            values, dq, db = self.clearance.rows(x[: self.n], pb.b)
            grad = np.hstack([dq + db @ pb.J_b[:3], db @ pb.db_dtheta])
            self._ckey, self._crows = key, (values - self.min_clearance, grad)
        return self._crows

    def evaluate(self, x: Array) -> tuple[Any, PlacedBrace, float, Array]:
        """(The state at q, the placed brace, the objective, its gradient (n + 2,))."""
        key = x.tobytes()
        if key != self._key or self._cache is None:
            n = self.n
            state = self.scenario.braced.state(x[:n], hessians=True)
            pb = placed_brace(state, self.surface, self.p0, x[n:], self.rot)
            assert state.dJ_e is not None  # hessians=True
            dje = np.concatenate([state.dJ_e, np.zeros((6, n, 2))], axis=2)
            djb = np.concatenate([pb.dJ_dq, pb.dJ_dtheta], axis=2)
            out = placed_compliance(
                state.J_e, dje, pb.J_b, djb, self.X, state.K, self.D, self.beta, self.settings.measure
            )
            self._key, self._cache = key, (state, pb, out.value, out.gradient)
        return self._cache

    def value_at(self, q: Array, fraction: float, angle: float) -> float:
        """The objective at posture q and place (s, φ), without gradients (one kinematics pass per posture)."""
        key = q.tobytes()
        if getattr(self, "_vkey", None) != key:
            self._vkey, self._vstate = key, self.scenario.braced.state(q, hessians=True)
        state = self._vstate
        pb = placed_brace(state, self.surface, self.p0, np.array([fraction, angle]), self.rot)
        zero = np.zeros((6, self.n, 0))
        m = self.settings.measure
        return placed_compliance(state.J_e, zero, pb.J_b, zero, self.X, state.K, self.D, self.beta, m).value

    def objective(self, x: Array) -> tuple[float, Array]:
        """The objective (scaled to mm/N for SLSQP's tolerances) and its gradient."""
        _, _, value, grad = self.evaluate(x)
        return 1e3 * value, 1e3 * grad

    def pose(self, x: Array) -> Array:
        """The start-pose equality rows (m, rad)."""
        state = self.evaluate(x)[0]
        rows = [state.e - self.x0]
        if self.space.kind == "pose":
            rows.append(pin.log3(self.R0.T @ state.R_e))
        elif self.space.kind == "position+axis":
            rows.append(np.array([1.0 - (state.R_e @ self.axis) @ (self.R0 @ self.axis)]))
        return np.concatenate(rows)

    def pose_jacobian(self, x: Array) -> Array:
        """∂(pose rows)/∂x."""
        state = self.evaluate(x)[0]
        rows = [np.hstack([state.J_e[:3], np.zeros((3, 2))])]
        if self.space.kind == "pose":
            jl = pin.Jlog3(self.R0.T @ state.R_e) @ state.R_e.T @ state.J_e[3:]
            rows.append(np.hstack([jl, np.zeros((3, 2))]))
        elif self.space.kind == "position+axis":
            a = state.R_e @ self.axis
            da = np.cross(state.J_e[3:], a, axisa=0, axisc=0)  # ∂(R_e a)/∂q_k = ω_k × R_e a
            rows.append(np.hstack([-(self.R0 @ self.axis) @ da, np.zeros(2)])[None, :])
        return np.vstack(rows)

    def inequalities(self, x: Array) -> Array:
        """[k_max − k(J_e), n_wᵀn̂ − cos(max tilt), R² − ‖q − q0‖², each link's clearance − bound] ≥ 0."""
        state, pb, _, _ = self.evaluate(x)
        cos = math.cos(math.radians(self.settings.max_tilt_deg))
        head = np.array([self.k_max - self.k_term.value(state), pb.n @ self.normal - cos, self.radius(x)])
        if x.tobytes() == self._ckey and self._crows is not None:
            return np.concatenate([head, self._crows[0]])
        return np.concatenate([head, self.clearance.values(x[: self.n], pb.b) - self.min_clearance])

    def inequality_jacobian(self, x: Array) -> Array:
        """∂(inequalities)/∂x."""
        state, pb, _, _ = self.evaluate(x)
        dk = np.concatenate([-self.k_term.gradient(state), np.zeros(2)])
        dn = np.concatenate([self.normal @ pb.dn_dq, self.normal @ pb.dn_dtheta])
        dr = np.concatenate([-2.0 * (x[: self.n] - self.q0), np.zeros(2)]) if self.settings.posture_radius else 0 * dk
        return np.vstack([dk, dn, dr, self.clearance_rows(x)[1]])

    def radius(self, x: Array) -> float:
        """R² − ‖q − q0‖² (rad²; 1 without a posture radius): the posture within R of the reference start."""
        r = self.settings.posture_radius
        return 1.0 if r is None else float(r * r - np.sum((x[: self.n] - self.q0) ** 2))

    def bounds(self, angle0: float) -> list[tuple[float | None, float | None]]:
        """SLSQP bounds: the joint limits less the margin (None where infinite), the fraction's, φ within π.

        With a posture radius R, each joint also within q0 ± R: the ball ‖q − q0‖ ≤ R lies inside that box, so
        the feasible set is the same, but SLSQP keeps every iterate inside its bounds, whereas the ball's
        linearisation at q0 itself (gradient 0) bounds nothing: the first step would leave it by radians.
        """
        robot = self.scenario.robot
        m = self.settings.limit_margin
        r = self.settings.posture_radius
        out: list[tuple[float | None, float | None]] = []
        for lo, hi, centre in zip(robot.lower, robot.upper, self.q0, strict=True):
            mm = min(m, 0.25 * float(hi - lo)) if np.isfinite(hi - lo) else m
            low = float(lo + mm) if np.isfinite(lo) else None
            high = float(hi - mm) if np.isfinite(hi) else None
            if r is not None:
                box = (float(centre) - r, float(centre) + r)
                low2 = box[0] if low is None else max(low, box[0])
                high2 = box[1] if high is None else min(high, box[1])
                if low2 <= high2:  # else the ball misses the limits: no feasible posture, the limits kept
                    low, high = low2, high2
            out.append((low, high))
        return [*out, self.surface.fraction_bounds(self.settings.fraction_bounds), (angle0 - math.pi, angle0 + math.pi)]


def optimise_start(
    spec: SweepSpec, link: str, fraction0: float, q0: Array, settings: InnerSettings, seed: int = 0
) -> InnerResult:
    """One seed of the inner level from (q0, fraction0, the facing angle); never raises a BracekitError."""
    from scipy.optimize import minimize

    from bracekit.studies.sweep.evaluate import single_thread

    single_thread()
    began = time.perf_counter()
    nan = float("nan")
    try:
        problem = StartProblem(spec, link, q0, settings)
        state = problem.scenario.braced.state(q0)
        rotation = state.R_b_i[0] @ problem.rot
        angle0 = facing_angle(problem.surface, rotation, problem.normal)
        bounds = problem.bounds(angle0)
        lower = np.array([-np.inf if lo is None else lo for lo, _ in bounds[:-2]])
        upper = np.array([np.inf if hi is None else hi for _, hi in bounds[:-2]])
        x0 = np.concatenate([np.clip(q0, lower, upper), [fraction0, angle0]])
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = minimize(
                problem.objective,
                x0,
                jac=True,
                method="SLSQP",
                bounds=bounds,
                constraints=[
                    {"type": "eq", "fun": problem.pose, "jac": problem.pose_jacobian},
                    {"type": "ineq", "fun": problem.inequalities, "jac": problem.inequality_jacobian},
                ],
                options={"maxiter": settings.maxiter, "ftol": 1e-9},
            )
            x = np.asarray(res.x, dtype=float)
            state, pb, value, _ = problem.evaluate(x)
            ineq = problem.inequalities(x)
            pose_error = float(np.linalg.norm(problem.pose(x)))
        angle = (float(x[-1]) + math.pi) % (2.0 * math.pi) - math.pi
        tilt = math.degrees(math.acos(float(np.clip(pb.n @ problem.normal, -1.0, 1.0))))
        ok = bool(pose_error < 1e-6 and ineq.min() > -1e-6 and np.isfinite(value))
        return InnerResult(
            seed,
            Place(link, float(x[-2]), angle),
            x[: problem.n].copy(),
            float(value),
            float(problem.k_term.value(state)),
            tilt,
            pose_error,
            ok,
            str(res.message),
            int(res.nit),
            time.perf_counter() - began,
            settings.posture_radius,
        )
    except (BracekitError, ArithmeticError, np.linalg.LinAlgError, ValueError) as exc:
        msg = f"{type(exc).__name__}: {exc}"
        wall = time.perf_counter() - began
        place = Place(link, fraction0, 0.0)
        return InnerResult(seed, place, q0, nan, nan, nan, nan, False, msg, 0, wall, settings.posture_radius)
