"""The brace-margin barrier: keeps the preloaded brace from lifting off or slipping under listed tool wrenches.

For each listed tool wrench w_j (6,: [f; m] on the tool at e, world axes, N and N·m) the contact wrench at
scale 1 is f_c,j = f_c0 + X_L δλ_j (:mod:`bracekit.statics.equilibrium`, ``geometric=False``), with
f_c0 = [P n̂; 0] and the first-order response of the joint springs K alone (rigid surface; with a compliant one
the multiplier also sees 1/k_env):

    A = J_bᵀ X_L (n×c),  S = Aᵀ K⁻¹ A (+ I/k_env),  δλ_j = −S⁻¹ Aᵀ K⁻¹ J_eᵀ w_j,
    δq_j = K⁻¹ (J_eᵀ w_j + A δλ_j)  (the joint deflection).

X_L is the load contact's constraint wrenches (a ``frictionless_point`` brace with μ > 0 sticks: three forces)
and is constant in the world. With F_j = f_c,j[:3], f_n = n̂ᵀ F_j and f_t = (I − n̂n̂ᵀ) F_j the holding
residuals (N) are

    lift-off  r_n = f_n,            slip (μ > 0)  r_t = μ f_n − √(‖f_t‖² + ε²),

positive while the brace holds the load at scale 1 (ε = :data:`SLIP_SMOOTHING` makes r_t smooth where f_t = 0,
and at most ε more cautious than the Coulomb cone). The term is Σ φ(r) over the residuals, φ(r) = (δ − r)²/(δ r)
below the margin δ (N) and 0 for r ≥ δ, as the clearance barrier. Strict, r ≤ 0 raises BarrierError; by default
φ continues below r_s = δ/4 as its quadratic expansion (finite, convex, falling), so that a configuration that
already slips under a listed load (the task's start may) is pushed back toward holding instead of stopping the
run.

Gradient, exact: for a residual r with ∂r/∂F = g (3,), let h = X_Fᵀ g (c,: X_F the force rows of X_L),
z = S⁻¹ h and v = K⁻¹ A z (n,). Differentiating S δλ = −Aᵀ K⁻¹ J_eᵀ w with dA = dJ_bᵀ X_L gives

    ∂r/∂q_k = −Σ_{r,i} [(X_L z)_r δq_i + (X_L δλ)_r v_i] ∂J_b[r, i]/∂q_k − Σ_{r,i} w_r v_i ∂J_e[r, i]/∂q_k,

which the fused step takes as Hessian coefficients (U_e, U_b) from J_e and J_b alone.

Gravity is not part of the term: the set points absorb g(q) in τ0 (the unloaded contact force is P n̂ with or
without gravity) and with K alone the response δf_c does not depend on g. The run's statics
(:mod:`bracekit.simulation.holding`) use the tangent stiffness, in which gravity and the preload shift δf_c by
a little; the term is its first-order, joint-spring part.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from bracekit._linalg import as_number, finite_math, show
from bracekit.errors import BarrierError, InputError, NumericalError, ScenarioError
from bracekit.kinematics import BracedRobot, BracedState
from bracekit.objective.base import Array, Term, TermContext, contract, hessians, register_term
from bracekit.objective.fused import FusedGradient, FusedKinematics
from bracekit.statics.equilibrium import check_friction, load_contact_wrenches, wrench_list
from bracekit.tolerances import UNLOADED_TOL

#: Default margin δ as a fraction of the preload P (or, with P = 0, of the largest listed tool force).
DEFAULT_MARGIN_FRACTION = 0.5
#: Below r_s = RELAX_FRACTION · δ the (non-strict) barrier continues as its second-order expansion at r_s.
RELAX_FRACTION = 0.25
#: ε of the slip residual μ f_n − √(‖f_t‖² + ε²), N.
SLIP_SMOOTHING = 1e-3


@dataclass(frozen=True)
class _Response:
    """The first-order contact response at one configuration for the m listed wrenches."""

    ka: Array  # K⁻¹ A (n×c)
    s_inv: Array  # S⁻¹ (c×c)
    lam: Array  # δλ_j (c×m)
    dq: Array  # δq_j (n×m)
    force: Array  # F_j = f_c,j[:3] at scale 1 (3×m), N


@register_term
@dataclass(frozen=True, eq=False)
class BraceMargin(Term):
    """Σ φ(r) over the lift-off and slip residuals r (N) of each listed tool wrench at scale 1; dimensionless.

    Attributes:
        braced: the braced robot (its brace, surface normal n̂ and joint stiffnesses K).
        wrenches: tool wrenches w_j (m×6, or one (6,)), [f; m] at e, world axes, N and N·m.
        preload: P ≥ 0, the unloaded normal force of the surface on b, N.
        friction: μ ≥ 0; μ > 0 adds the slip residuals (and a frictionless point brace sticks). None or 0:
            lift-off only.
        margin: δ > 0, N; None: DEFAULT_MARGIN_FRACTION · P (with P = 0, of the largest listed force).
        strict: the pure barrier, BarrierError at r ≤ 0; False (default): below r_s = RELAX_FRACTION · δ the
            barrier continues as its quadratic expansion, finite for every r, so that a configuration that
            already slips or lifts off (e.g. a task's start) is pushed back toward holding.
    """

    braced: BracedRobot
    wrenches: Array
    preload: float
    friction: float | None = None
    margin: float | None = None
    strict: bool = False
    name: str = "brace_margin"
    key = "brace_margin"
    _x: Array = field(init=False, repr=False)

    def __post_init__(self) -> None:
        super().__post_init__()
        if not isinstance(self.braced, BracedRobot):
            raise InputError(f"the brace-margin term needs a BracedRobot, got {type(self.braced).__name__}")
        ws = wrench_list(self.wrenches)
        p = as_number(self.preload, "the preload P (the surface pushes on b)", nonnegative=True, unit="N")
        mu = check_friction(self.friction)
        if self.margin is None:
            scale = p if p > 0.0 else float(np.max(np.linalg.norm(ws[:, :3], axis=1)))
            delta = DEFAULT_MARGIN_FRACTION * scale
            if not delta > 0.0:
                raise InputError(
                    "the brace-margin term needs a margin δ (N): give margin=..., a preload P > 0 or a tool force"
                )
        else:
            delta = as_number(self.margin, "the brace margin δ", positive=True, unit="N")
        if not isinstance(self.strict, bool):
            raise InputError(f"strict must be True or False, got {show(self.strict)}")
        object.__setattr__(self, "wrenches", ws)
        object.__setattr__(self, "preload", p)
        object.__setattr__(self, "friction", mu)
        object.__setattr__(self, "margin", delta)
        object.__setattr__(self, "_x", load_contact_wrenches(self.braced.split.brace, mu))

    @property
    def slip(self) -> bool:
        """Whether the slip residuals are part of the term (μ > 0)."""
        return self.friction is not None and self.friction > 0.0

    # --- the physics -------------------------------------------------------------------------------
    def _response(self, je: Array, jb: Array) -> _Response:
        """δλ, δq and F at scale 1 for every listed wrench from J_e, J_b (6×n, world axes)."""
        kinv = 1.0 / self.braced.robot.stiffness
        x = self._x
        with finite_math("the brace margin's contact response"):
            a = jb.T @ x
            ka = kinv[:, None] * a
            s = a.T @ ka
            k_env = self.braced.split.brace.environment_stiffness
            if k_env is not None:
                s = s + np.eye(s.shape[0]) / k_env
            else:
                trace_c1 = float(np.sum(kinv * np.sum(jb * jb, axis=0)))
                low = float(np.linalg.eigvalsh(s)[0])
                if not low > UNLOADED_TOL * trace_c1:
                    raise NumericalError(
                        "chain 1 cannot push the brace along a constraint direction here (Xᵀ J_b K⁻¹ J_bᵀ X is "
                        "singular): the brace margin needs every contact direction loaded; move chain 1 off its "
                        "singularity"
                    )
            s_inv = np.asarray(np.linalg.inv(s), dtype=np.float64)
            u = je.T @ self.wrenches.T  # J_eᵀ w_j (n×m)
            lam = -s_inv @ (ka.T @ u)
            dq = kinv[:, None] * (u + a @ lam)
            nhat = self.braced.split.brace.surface.normal
            force = self.preload * nhat[:, None] + x[:3] @ lam
        return _Response(ka, s_inv, lam, dq, force)

    def _residuals(self, force: Array) -> tuple[Array, Array | None, Array, Array | None]:
        """(r_n, r_t, ∂r_n/∂F, ∂r_t/∂F): residuals (m,), N, and their gradients in F (3×m); r_t None if μ = 0."""
        nhat = self.braced.split.brace.surface.normal
        r_n = nhat @ force
        g_n = np.repeat(nhat[:, None], force.shape[1], axis=1)
        if not self.slip:
            return r_n, None, g_n, None
        mu = float(self.friction)  # type: ignore[arg-type]
        f_t = force - np.outer(nhat, r_n)
        norm = np.sqrt(np.sum(f_t * f_t, axis=0) + SLIP_SMOOTHING**2)
        return r_n, mu * r_n - norm, g_n, mu * g_n - f_t / norm

    def forces(self, state: BracedState) -> tuple[Array, Array]:
        """(f_n, ‖f_t‖) under each listed wrench at scale 1 (m,), N: the contact force of the K-only response."""
        force = self._response(state.J_e, state.split.J_b).force
        nhat = self.braced.split.brace.surface.normal
        f_n = nhat @ force
        return f_n, np.linalg.norm(force - np.outer(nhat, f_n), axis=0)

    def residuals(self, state: BracedState) -> Array:
        """[r_n,1 … r_n,m, r_t,1 … r_t,m] (2m,; m without slip), N: > 0 while the brace holds each load."""
        r_n, r_t, _, _ = self._residuals(self._response(state.J_e, state.split.J_b).force)
        return r_n if r_t is None else np.concatenate([r_n, r_t])

    # --- the barrier -------------------------------------------------------------------------------
    def _barrier(self, r: Array, what: str) -> tuple[float, Array]:
        """Σ φ(r) and φ'(r) (m,) for residuals r (m,), N; strict: BarrierError where r ≤ 0.

        φ(r) = δ/r − 2 + r/δ = (δ − r)²/(δ r) on [r_s, δ), 0 from δ on; below r_s = RELAX_FRACTION·δ (not
        strict) its second-order expansion φ(r_s) + φ'(r_s)(r − r_s) + ½ φ''(r_s)(r − r_s)², φ'' = 2δ/r³.
        """
        if self.strict:
            bad = np.flatnonzero(~(r > 0.0))
            if bad.size:
                j = int(bad[0])
                raise BarrierError(
                    f"the brace {what} under tool wrench {j + 1} {show(self.wrenches[j].tolist())} at scale 1 "
                    f"(residual {r[j]:.4g} N ≤ 0)"
                )
        if not np.all(np.isfinite(r)):
            raise NumericalError(f"the brace margin's residuals are not finite: {show(r.tolist())}")
        delta = float(self.margin)  # type: ignore[arg-type]
        r_s = 0.0 if self.strict else RELAX_FRACTION * delta
        near = r < delta
        rr = np.where(near, np.maximum(r, r_s) if r_s > 0.0 else r, delta)
        phi = np.where(near, delta / rr - 2.0 + rr / delta, 0.0)
        dphi = np.where(near, 1.0 / delta - delta / (rr * rr), 0.0)
        below = r < r_s
        if np.any(below):
            d = r - r_s
            ddphi = 2.0 * delta / r_s**3
            phi = np.where(below, phi + dphi * d + 0.5 * ddphi * d * d, phi)
            dphi = np.where(below, dphi + ddphi * d, dphi)
        return float(np.sum(phi)), dphi

    def _value(self, je: Array, jb: Array) -> float:
        r_n, r_t, _, _ = self._residuals(self._response(je, jb).force)
        total = self._barrier(r_n, "lifts off")[0]
        if r_t is not None:
            total += self._barrier(r_t, "slips")[0]
        return total

    def _coefficients(self, je: Array, jb: Array) -> tuple[Array, Array]:
        """(U_e, U_b) (6×n each): ∂value/∂q = Σ U_e ∂J_e + Σ U_b ∂J_b (module docstring)."""
        resp = self._response(je, jb)
        r_n, r_t, g_n, g_t = self._residuals(resp.force)
        g = self._barrier(r_n, "lifts off")[1] * g_n  # Σ φ'(r) ∂r/∂F per wrench (3×m)
        if r_t is not None and g_t is not None:
            g = g + self._barrier(r_t, "slips")[1] * g_t
        x = self._x
        with finite_math("the brace margin's gradient"):
            z = resp.s_inv @ (x[:3].T @ g)  # (c×m)
            v = resp.ka @ z  # (n×m)
            u_b = -((x @ z) @ resp.dq.T + (x @ resp.lam) @ v.T)
            u_e = -(self.wrenches.T @ v.T)
        return u_e, u_b

    # --- Term --------------------------------------------------------------------------------------
    def value(self, state: BracedState) -> float:
        """The term's value at the state (the class docstring gives it)."""
        return self._value(state.J_e, state.split.J_b)

    def gradient(self, state: BracedState) -> Array:
        """∂value/∂q (n,), exact through the state's kinematic Hessians."""
        d_je, (d_jb,) = hessians(state)
        u_e, u_b = self._coefficients(state.J_e, state.split.J_b)
        return np.asarray(contract(d_je, u_e) + contract(d_jb, u_b), dtype=float)

    def fused_value(self, kin: FusedKinematics) -> float:
        """The value from the fused step's J_e, J_b (the same as :meth:`value`)."""
        return self._value(kin.je, kin.jb)

    def fused_gradient(self, kin: FusedKinematics, weight: float, out: FusedGradient) -> bool:
        """Add weight · ∂value/∂q to the fused step's accumulator as Hessian coefficients; True when done here."""
        u_e, u_b = self._coefficients(kin.je, kin.jb)
        out.add_ue(weight * u_e)
        out.add_ub(weight * u_b[:, : kin.n1])  # J_b's chain-2 columns are zero
        return True

    @classmethod
    def from_scenario(cls, context: TermContext) -> BraceMargin:
        """The term from the scenario's ``[brace] preload``, ``friction`` and ``[loads] wrenches``; default margin."""
        h = context.holding
        if h is None or getattr(h, "wrenches", None) is None:
            raise ScenarioError(
                "the 'brace_margin' weight needs tool wrenches to hold: add [loads] wrenches = "
                "[[fx, fy, fz, mx, my, mz], ...] (N, N·m, world axes) or set the weight to 0"
            )
        mu = h.friction
        if not (h.preload > 0.0 or (mu is not None and mu > 0.0)):
            raise ScenarioError(
                "the 'brace_margin' weight needs a brace that can hold a load: add [brace] preload = P (N, > 0) "
                "and/or friction = μ (> 0), or set the weight to 0"
            )
        return cls(context.braced, h.wrenches, h.preload, mu)
