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
    """The first-order contact response at one configuration for the m listed wrenches (every brace stacked)."""

    ka: Array  # K⁻¹ A (n×c)
    s_inv: Array  # S⁻¹ (c×c)
    lam: Array  # δλ_j (c×m)
    dq: Array  # δq_j (n×m)
    force: tuple[Array, ...]  # F_i,j = f_c,i,j[:3] of each brace at scale 1 (3×m), N


@register_term
@dataclass(frozen=True, eq=False)
class BraceMargin(Term):
    """Σ φ(r) over the lift-off and slip residuals r (N) of each brace under each listed tool wrench; dimensionless.

    With several braces the contact response stacks every brace's load wrenches (A = [J_b_iᵀ X_L,i]) and each
    brace i has its residuals r_n,i = n̂_iᵀ F_i and (μ_i > 0) r_t,i = μ_i f_n,i − √(‖f_t,i‖² + ε²), F_i its force.

    Attributes:
        braced: the braced robot (its braces, surface normals n̂_i and joint stiffnesses K).
        wrenches: tool wrenches w_j (m×6, or one (6,)), [f; m] at e, world axes, N and N·m.
        preload: P_i ≥ 0, the unloaded normal force of each surface on b_i, N: one for every brace or one per
            brace.
        friction: μ_i ≥ 0; μ_i > 0 adds brace i's slip residuals (and a frictionless point brace sticks). None
            or 0: lift-off only. One for every brace or one per brace.
        margin: δ > 0, N; None: DEFAULT_MARGIN_FRACTION · max P_i (with every P_i = 0, of the largest listed
            force).
        strict: the pure barrier, BarrierError at r ≤ 0; False (default): below r_s = RELAX_FRACTION · δ the
            barrier continues as its quadratic expansion, finite for every r, so that a configuration that
            already slips or lifts off (e.g. a task's start) is pushed back toward holding.
    """

    braced: BracedRobot
    wrenches: Array
    preload: float | tuple[float, ...]
    friction: float | tuple[float | None, ...] | None = None
    margin: float | None = None
    strict: bool = False
    name: str = "brace_margin"
    key = "brace_margin"
    _x: tuple[Array, ...] = field(init=False, repr=False)
    _p: tuple[float, ...] = field(init=False, repr=False)
    _mu: tuple[float | None, ...] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        super().__post_init__()
        if not isinstance(self.braced, BracedRobot):
            raise InputError(f"the brace-margin term needs a BracedRobot, got {type(self.braced).__name__}")
        count = len(self.braced.braces)
        ws = wrench_list(self.wrenches)
        what = "the preload P (the surface pushes on b)"
        ps = self.preload if isinstance(self.preload, tuple | list) else (self.preload,) * count
        mus = self.friction if isinstance(self.friction, tuple | list) else (self.friction,) * count
        if len(ps) != count or len(mus) != count:
            raise InputError(f"give one preload and one friction for every brace or one per brace ({count})")
        p = tuple(as_number(v, what, nonnegative=True, unit="N") for v in ps)
        mu = tuple(check_friction(v) for v in mus)
        if self.margin is None:
            scale = max(p) if max(p) > 0.0 else float(np.max(np.linalg.norm(ws[:, :3], axis=1)))
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
        object.__setattr__(self, "preload", p[0] if count == 1 else p)
        object.__setattr__(self, "friction", mu[0] if count == 1 else mu)
        object.__setattr__(self, "margin", delta)
        object.__setattr__(self, "_p", p)
        object.__setattr__(self, "_mu", mu)
        xs = tuple(load_contact_wrenches(b, m) for b, m in zip(self.braced.braces, mu, strict=True))
        object.__setattr__(self, "_x", xs)

    @property
    def slip(self) -> bool:
        """Whether slip residuals are part of the term (some μ_i > 0)."""
        return any(m is not None and m > 0.0 for m in self._mu)

    # --- the physics -------------------------------------------------------------------------------
    def _response(self, je: Array, jbs: tuple[Array, ...]) -> _Response:
        """δλ, δq and each F_i at scale 1 for every listed wrench from J_e and each J_b_i (6×n, world axes)."""
        kinv = 1.0 / self.braced.robot.stiffness
        braces = self.braced.braces
        with finite_math("the brace margin's contact response"):
            a = np.hstack([jb.T @ x for jb, x in zip(jbs, self._x, strict=True)])
            ka = kinv[:, None] * a
            s = a.T @ ka
            soft = np.concatenate(
                [
                    np.full(x.shape[1], 0.0 if b.environment_stiffness is None else 1.0 / b.environment_stiffness)
                    for b, x in zip(braces, self._x, strict=True)
                ]
            )
            s = s + np.diag(soft)
            if not np.all(soft > 0.0):  # a rigid contact direction must be loaded by the joints
                trace_c1 = float(sum(np.sum(kinv * np.sum(jb * jb, axis=0)) for jb in jbs))
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
            force = tuple(
                p * b.surface.normal[:, None] + x[:3] @ lam[sl]
                for p, b, x, sl in zip(self._p, braces, self._x, self._slices(), strict=True)
            )
        return _Response(ka, s_inv, lam, dq, force)

    def _slices(self) -> list[slice]:
        """The rows of each brace in the stacked multipliers δλ."""
        out, start = [], 0
        for x in self._x:
            out.append(slice(start, start + x.shape[1]))
            start += x.shape[1]
        return out

    def _residuals(self, i: int, force: Array) -> tuple[Array, Array | None, Array, Array | None]:
        """(r_n, r_t, ∂r_n/∂F, ∂r_t/∂F) of brace i: residuals (m,), N, gradients in F (3×m); r_t None if μ_i = 0."""
        nhat = self.braced.braces[i].surface.normal
        r_n = nhat @ force
        g_n = np.repeat(nhat[:, None], force.shape[1], axis=1)
        mu = self._mu[i]
        if mu is None or mu <= 0.0:
            return r_n, None, g_n, None
        f_t = force - np.outer(nhat, r_n)
        norm = np.sqrt(np.sum(f_t * f_t, axis=0) + SLIP_SMOOTHING**2)
        return r_n, mu * r_n - norm, g_n, mu * g_n - f_t / norm

    def forces(self, state: BracedState) -> tuple[Array, Array]:
        """(f_n, ‖f_t‖) under each listed wrench at scale 1, N: (m,) for one brace, brace after brace for several."""
        found = self._response(state.J_e, state.J_b_i).force
        f_n, f_t = [], []
        for brace, force in zip(self.braced.braces, found, strict=True):
            nhat = brace.surface.normal
            f_n.append(nhat @ force)
            f_t.append(np.linalg.norm(force - np.outer(nhat, f_n[-1]), axis=0))
        return np.concatenate(f_n), np.concatenate(f_t)

    def residuals(self, state: BracedState) -> Array:
        """[r_n,1 … r_n,m, r_t,1 … r_t,m] (2m,; m without slip) of each brace in turn, N: > 0 while it holds."""
        out = []
        for i, force in enumerate(self._response(state.J_e, state.J_b_i).force):
            r_n, r_t, _, _ = self._residuals(i, force)
            out.append(r_n if r_t is None else np.concatenate([r_n, r_t]))
        return np.concatenate(out)

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

    def _what(self, i: int, verb: str) -> str:
        """'lifts off' (one brace) or 'braces[i] lifts off' for the barrier's error."""
        return verb if len(self.braced.braces) == 1 else f"braces[{i}] {verb}"

    def _value(self, je: Array, jbs: tuple[Array, ...]) -> float:
        total = 0.0
        for i, force in enumerate(self._response(je, jbs).force):
            r_n, r_t, _, _ = self._residuals(i, force)
            total += self._barrier(r_n, self._what(i, "lifts off"))[0]
            if r_t is not None:
                total += self._barrier(r_t, self._what(i, "slips"))[0]
        return total

    def _coefficients(self, je: Array, jbs: tuple[Array, ...]) -> tuple[Array, list[Array]]:
        """(U_e, [U_b_i]) (6×n each): ∂value/∂q = Σ U_e ∂J_e + Σ_i Σ U_b_i ∂J_b_i (module docstring)."""
        resp = self._response(je, jbs)
        slices = self._slices()
        h = np.zeros_like(resp.lam)  # X_F,iᵀ Σ φ'(r) ∂r/∂F_i, stacked over the braces (c×m)
        for i, (force, x, sl) in enumerate(zip(resp.force, self._x, slices, strict=True)):
            r_n, r_t, g_n, g_t = self._residuals(i, force)
            g = self._barrier(r_n, self._what(i, "lifts off"))[1] * g_n  # per wrench (3×m)
            if r_t is not None and g_t is not None:
                g = g + self._barrier(r_t, self._what(i, "slips"))[1] * g_t
            h[sl] = x[:3].T @ g
        with finite_math("the brace margin's gradient"):
            z = resp.s_inv @ h  # (c×m)
            v = resp.ka @ z  # (n×m)
            u_b = [-((x @ z[sl]) @ resp.dq.T + (x @ resp.lam[sl]) @ v.T) for x, sl in zip(self._x, slices, strict=True)]
            u_e = -(self.wrenches.T @ v.T)
        return u_e, u_b

    # --- Term --------------------------------------------------------------------------------------
    def value(self, state: BracedState) -> float:
        """The term's value at the state (the class docstring gives it)."""
        return self._value(state.J_e, state.J_b_i)

    def gradient(self, state: BracedState) -> Array:
        """∂value/∂q (n,), exact through the state's kinematic Hessians (of J_e and every J_b_i)."""
        d_je, d_jb = hessians(state)
        u_e, u_b = self._coefficients(state.J_e, state.J_b_i)
        out = contract(d_je, u_e)
        for dj, u in zip(d_jb, u_b, strict=True):
            out = out + contract(dj, u)
        return np.asarray(out, dtype=float)

    def fused_value(self, kin: FusedKinematics) -> float:
        """The value from the fused step's J_e, J_b (the same as :meth:`value`; the fused step has one brace)."""
        return self._value(kin.je, (kin.jb,))

    def fused_gradient(self, kin: FusedKinematics, weight: float, out: FusedGradient) -> bool:
        """Add weight · ∂value/∂q to the fused step's accumulator as Hessian coefficients; True when done here."""
        u_e, (u_b,) = self._coefficients(kin.je, (kin.jb,))
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
        count = len(context.braced.braces)
        preloads, frictions = h.brace_preloads(count), h.brace_frictions(count)
        if not any(p > 0.0 or (mu is not None and mu > 0.0) for p, mu in zip(preloads, frictions, strict=True)):
            raise ScenarioError(
                "the 'brace_margin' weight needs a brace that can hold a load: add [brace] preload = P (N, > 0) "
                "and/or friction = μ (> 0), or set the weight to 0"
            )
        if count == 1:
            return cls(context.braced, h.wrenches, h.preload, h.friction)
        return cls(context.braced, h.wrenches, tuple(preloads), tuple(frictions))
