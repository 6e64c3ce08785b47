"""Whether the brace holds along a run: joint torques, contact forces and load capacity at every sample.

A run's samples q(t) are the commanded configurations. With :class:`Holding` (gravity, preload P, friction μ,
tool wrenches w_j) each sample gets the static equilibrium of the spring-jointed chain whose set points make the
contact carry P·n̂ (:mod:`bracekit.statics.equilibrium`): τ0 = g(q) − J_bᵀ[P n̂; 0]. Under each listed tool
wrench (N, N·m, world axes, at the tip) the first-order response gives the largest scale before lift-off, slip
(Coulomb cone, with μ) or actuator saturation (|τ_i| > URDF effort_i) (:mod:`bracekit.statics.capacity`).
In free space τ = g(q) − J_eᵀ w. Sign conventions: the contact wrench acts on the robot, its normal force is
positive when pressing; a margin is a scale factor on the listed load (> 1: it holds at that load).

With several braces brace i presses with its own P_i and has its own μ_i: τ0 = g(q) − Σ_i J_b_iᵀ[P_i n̂_i; 0],
and the response keeps every load contact closed (:func:`~bracekit.statics.contact_responses`).
A sample's margins are the least over the braces and the loads; each brace also gets its own series.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from bracekit._linalg import show
from bracekit.compliance.first_order import compliance_index
from bracekit.compliance.preloaded import loaded_free_space_compliance, preloaded_compliance
from bracekit.errors import InputError, UnstableEquilibriumError
from bracekit.kinematics import BracedRobot
from bracekit.statics import (
    actuator_torques,
    capacity_along,
    effort_limits,
    gravity_torque,
    peak_ratio,
    relief_of,
    saturation_scale,
)
from bracekit.statics.equilibrium import check_friction, check_preload, wrench_list

Array = NDArray[np.float64]

#: Per-sample measure names a braced run gets from :func:`holding_measures` (a free-space run: torque only).
BRACED_MEASURES = (
    "torque_ratio",
    "torque_ratio_loaded",
    "contact_force_N",
    "liftoff_margin",
    "slip_margin",
    "torque_margin",
)


@dataclass(frozen=True)
class Holding:
    """What the brace must hold: gravity, the preload, friction and the tool wrenches to check.

    Attributes:
        gravity: gravity along −z of the world with the URDF's masses and inertias.
        preload: the normal force chain 1 presses the brace with, N (≥ 0).
        friction: Coulomb friction coefficient μ of the contact (None: frictionless, no slip check).
        wrenches: tool wrenches to check (m×6: [fx, fy, fz, mx, my, mz], N and N·m, world axes), or None.
        preloads: P_i of each brace (N), for several braces; None: ``preload`` for every brace.
        frictions: μ_i (or None) of each brace, for several braces; None: ``friction`` for every brace.
    """

    gravity: bool = False
    preload: float = 0.0
    friction: float | None = None
    wrenches: Array | None = None
    preloads: tuple[float, ...] | None = None
    frictions: tuple[float | None, ...] | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.gravity, bool):
            raise InputError(f"gravity must be true or false, got {show(self.gravity)}")
        object.__setattr__(self, "preload", check_preload(self.preload))
        if self.friction is not None:
            object.__setattr__(self, "friction", check_friction(self.friction))
        if self.wrenches is not None:
            object.__setattr__(self, "wrenches", wrench_list(self.wrenches))
        if self.preloads is not None:
            object.__setattr__(self, "preloads", tuple(check_preload(p) for p in _sequence(self.preloads, "preloads")))
        if self.frictions is not None:
            object.__setattr__(
                self, "frictions", tuple(check_friction(m) for m in _sequence(self.frictions, "frictions"))
            )

    @property
    def active(self) -> bool:
        """Whether there is anything to compute (gravity, a preload, friction or a load)."""
        return (
            self.gravity
            or self.preload > 0.0
            or self.friction is not None
            or self.wrenches is not None
            or any(p > 0.0 for p in self.preloads or ())
            or any(m is not None for m in self.frictions or ())
        )

    def brace_preloads(self, count: int) -> tuple[float, ...]:
        """P_i of each of `count` braces (N): ``preloads``, or ``preload`` for every brace."""
        if self.preloads is None:
            return (self.preload,) * count
        if len(self.preloads) != count:
            raise InputError(f"give one preload per brace: {count} braces, {len(self.preloads)} preloads")
        return self.preloads

    def brace_frictions(self, count: int) -> tuple[float | None, ...]:
        """μ_i (or None) of each of `count` braces: ``frictions``, or ``friction`` for every brace."""
        if self.frictions is None:
            return (self.friction,) * count
        if len(self.frictions) != count:
            raise InputError(f"give one friction coefficient per brace: {count} braces, {len(self.frictions)} given")
        return self.frictions

    @property
    def loads(self) -> Array:
        """The listed wrenches (m×6), or one zero wrench when none is listed."""
        return np.zeros((1, 6)) if self.wrenches is None else self.wrenches


def _sequence(values: object, name: str) -> tuple[object, ...]:
    if not isinstance(values, (list, tuple)) or not values:
        raise InputError(f"{name} must be a list with one value per brace, got {show(values)}")
    return tuple(values)


def holding_measures(
    braced: BracedRobot, qs: Array, holding: Holding, is_braced: bool, beta: Array | None = None
) -> dict[str, Array]:
    """Per-sample statics along the samples qs (N×n) of a run.

    Returns (N,) arrays: ``torque_ratio`` (peak |τ_i|/effort_i unloaded), ``torque_ratio_loaded`` (the same,
    worst listed wrench at scale 1), ``torque_margin``; for a braced run also ``contact_force_N`` (largest
    ‖f_c‖ unloaded or under a listed wrench at scale 1), ``liftoff_margin`` and ``slip_margin`` (inf without μ).
    Margins are inf where nothing limits the scale. With `beta` (N×6, the unit twists of C_i) and gravity or a
    preload, also ``Ci_preloaded``: C_i of the preloaded compliance (:func:`preloaded_compliance` for a braced
    run with each brace's own contact and P_i, :func:`loaded_free_space_compliance` in free space; no tool load).
    ``unstable`` (1.0 where the loaded equilibrium is unstable: K plus the geometric stiffness of gravity and the
    preload is not positive on the allowed motions; there the margins are 0 and ``Ci_preloaded`` is inf).
    """
    qs = np.atleast_2d(np.asarray(qs, dtype=float))
    count = len(braced.braces)
    try:
        out = _statics(braced, qs, holding, is_braced)
        out["unstable"] = np.zeros(qs.shape[0])
    except UnstableEquilibriumError:  # sample by sample: mark the unstable ones
        rows = [_statics_or_unstable(braced, q, holding, is_braced) for q in qs]
        out = {key: np.array([r[key][0] for r in rows]) for key in rows[0]}
    preloads = holding.brace_preloads(count)
    if beta is not None and (holding.gravity or max(preloads) > 0.0):
        ci = []
        for k, (q, b) in enumerate(zip(qs, beta, strict=True)):
            try:
                if is_braced:
                    c = preloaded_compliance(braced, q, list(preloads), gravity=holding.gravity)
                else:
                    c = loaded_free_space_compliance(braced, q, gravity=holding.gravity)
            except UnstableEquilibriumError:
                out["unstable"][k] = 1.0
                ci.append(np.inf)
                continue
            ci.append(compliance_index(c, b))
        out["Ci_preloaded"] = np.array(ci)
        if np.any(out["unstable"] > 0.0):
            for key in ("liftoff_margin", "slip_margin", "torque_margin"):
                if key in out:
                    out[key] = np.where(out["unstable"] > 0.0, 0.0, out[key])
    return out


def _tau0(braced: BracedRobot, q: Array, holding: Holding) -> Array:
    """τ0 = g(q) − Σ_i J_b_i,vᵀ P_i n̂_i (n,), N·m: the rigid torques without tool load."""
    st = braced.state(q)
    tau0 = gravity_torque(braced.robot, q) if holding.gravity else np.zeros(q.size)
    for p, brace, j_b in zip(holding.brace_preloads(len(braced.braces)), braced.braces, st.J_b_i, strict=True):
        tau0 = tau0 - p * (j_b[:3].T @ brace.surface.normal)
    return np.asarray(tau0, dtype=float)


def _statics_or_unstable(braced: BracedRobot, q: Array, holding: Holding, is_braced: bool) -> dict[str, Array]:
    """:func:`_statics` at one configuration; at an unstable one the rigid torques, margins 0, ``unstable`` 1."""
    try:
        out = _statics(braced, q[None, :], holding, is_braced)
        out["unstable"] = np.zeros(1)
        return out
    except UnstableEquilibriumError:
        ratio = np.atleast_1d(peak_ratio(_tau0(braced, q, holding), effort_limits(braced.robot)))
        zero = np.zeros(1)
        rows = {"torque_ratio": ratio, "torque_ratio_loaded": ratio, "torque_margin": zero, "unstable": np.ones(1)}
        if is_braced:
            count = len(braced.braces)
            force = np.full(1, max(holding.brace_preloads(count)))
            rows |= {"contact_force_N": force, "liftoff_margin": zero, "slip_margin": zero}
            if count > 1:
                for i in range(count):
                    rows |= {f"liftoff_margin_{i}": zero, f"slip_margin_{i}": zero}
        return rows


def _statics(braced: BracedRobot, qs: Array, holding: Holding, is_braced: bool) -> dict[str, Array]:
    """Torques, contact forces and margins of :func:`holding_measures` (every brace with its own P_i and μ_i).

    With several braces also each brace's ``liftoff_margin_<i>`` and ``slip_margin_<i>`` (i from 0, the order of
    ``braced.braces``); the plain names hold the least over the braces and wrenches.
    """
    qs = np.atleast_2d(np.asarray(qs, dtype=float))
    effort = effort_limits(braced.robot)
    loads = holding.loads
    if not is_braced:
        tau0 = np.array([gravity_torque(braced.robot, q) if holding.gravity else np.zeros(q.size) for q in qs])
        jac = np.array([_tip_jacobian(braced, q) for q in qs])  # N×6×n
        d_tau = -np.einsum("kri,mr->kmi", jac, loads)  # N×m×n: τ = g − J_eᵀ w
        ratio0 = peak_ratio(tau0, effort)
        loaded = np.max(peak_ratio(tau0[:, None, :] + d_tau, effort), axis=1)
        margin = np.array([np.min(saturation_scale(tau0[k][None, :], d_tau[k], effort)) for k in range(qs.shape[0])])
        return {"torque_ratio": ratio0, "torque_ratio_loaded": loaded, "torque_margin": margin}
    count = len(braced.braces)
    preloads = holding.brace_preloads(count)
    cap = capacity_along(
        braced,
        qs,
        loads,
        preload=preloads,
        gravity=holding.gravity,
        friction=holding.brace_frictions(count),
        effort=effort,
    )
    loaded_force = np.max(np.linalg.norm(cap.contact_wrench[..., :3], axis=-1), axis=(1, 2))
    inf = np.full(qs.shape[0], np.inf)
    out = {
        "torque_ratio": np.asarray(cap.peak_unloaded, dtype=float),
        "torque_ratio_loaded": np.max(cap.peak_loaded, axis=1),
        "contact_force_N": np.maximum(max(preloads), loaded_force),
        "liftoff_margin": np.asarray(cap.liftoff_margin, dtype=float),
        "slip_margin": np.asarray(inf if cap.slip_margin is None else cap.slip_margin, dtype=float),
        "torque_margin": np.asarray(cap.torque_margin, dtype=float),
    }
    if count > 1:
        brace_slip = np.full((qs.shape[0], count), np.inf) if cap.brace_slip_margin is None else cap.brace_slip_margin
        for i in range(count):
            out[f"liftoff_margin_{i}"] = np.asarray(cap.brace_liftoff_margin[:, i], dtype=float)
            out[f"slip_margin_{i}"] = np.asarray(brace_slip[:, i], dtype=float)
    return out


def per_brace_summary(measures: dict[str, Array], count: int) -> list[dict[str, float | None]]:
    """Per-brace summary of a several-brace run: ``min_liftoff_margin`` and ``min_slip_margin`` of each brace.

    From the per-brace measures of :func:`holding_measures` (None where the margin is inf or the run has no
    statics).
    """
    out: list[dict[str, float | None]] = []
    for i in range(count):
        lift, slip = measures.get(f"liftoff_margin_{i}"), measures.get(f"slip_margin_{i}")
        out.append(
            {
                "min_liftoff_margin": None if lift is None else _least(lift),
                "min_slip_margin": None if slip is None else _least(slip),
            }
        )
    return out


def _tip_jacobian(braced: BracedRobot, q: Array) -> Array:
    """J_e (6×n) at q."""
    return braced.state(q).J_e


#: measure → what falls short when it is below 1 (a margin) or above 1 (a torque ratio).
_LIMITS = (
    ("liftoff_margin", "the brace lifts off under a listed load", "lift-off margin"),
    ("slip_margin", "the brace slips under a listed load", "slip margin"),
    ("torque_margin", "an actuator saturates under a listed load", "torque margin"),
)


def holding_warnings(name: str, t: Array, measures: dict[str, Array]) -> list[str]:
    """One line per way the brace fails to hold along a run (margins below 1, unloaded torque beyond effort)."""
    out = []
    if "unstable" in measures and np.any(measures["unstable"] > 0.0):
        bad = np.flatnonzero(measures["unstable"] > 0.0)
        out.append(
            f"{name}: the loaded equilibrium is unstable at {bad.size} of {t.size} samples (first at t = "
            f"{t[bad[0]]:.2f} s): the joint springs cannot hold gravity and the preload there (K + geometric "
            "stiffness not positive on the allowed motions); use stiffer joints or a smaller preload"
        )
    if "torque_ratio" in measures:
        over = measures["torque_ratio"] > 1.0
        if np.any(over):
            k = int(np.argmax(measures["torque_ratio"]))
            out.append(
                f"{name}: an actuator exceeds its effort limit with no tool load at {int(over.sum())} of {t.size} "
                f"samples (peak |τ|/effort {measures['torque_ratio'][k]:.3g} at t = {t[k]:.2f} s); lower the preload "
                "or move the task"
            )
    stable = measures["unstable"] == 0.0 if "unstable" in measures else np.ones(t.size, dtype=bool)
    for key, what, label in _LIMITS:
        if key not in measures:
            continue
        short = (measures[key] < 1.0) & stable  # unstable samples are reported above
        if np.any(short):
            k = int(np.flatnonzero(short)[np.argmin(measures[key][short])])
            out.append(
                f"{name}: {what} at {int(short.sum())} of {t.size} samples (least {label} {measures[key][k]:.3g} "
                f"at t = {t[k]:.2f} s: it holds only that fraction of the load)"
            )
    return out


def holds(measures: dict[str, Array]) -> bool | None:
    """Whether the brace holds along the run (None without statics): margins ≥ 1, unloaded torque within effort."""
    if "torque_ratio" not in measures:
        return None
    ok = bool(np.all(measures["torque_ratio"] <= 1.0)) and not bool(np.any(measures.get("unstable", 0.0)))
    return ok and all(bool(np.all(measures[k] >= 1.0)) for k, _, _ in _LIMITS if k in measures)


def _mean_or_none(values: Array | None) -> float | None:
    """The mean, or None when absent or not finite (an unstable sample's C_i is inf)."""
    if values is None or not np.all(np.isfinite(values)):
        return None
    return float(np.mean(values))


def _least(values: Array) -> float | None:
    low = float(np.min(values))
    return low if np.isfinite(low) else None


def holding_summary(measures: dict[str, Array]) -> dict[str, Any]:
    """Summary keys of a run from its :func:`holding_measures` (None where a quantity does not apply)."""
    out: dict[str, Any] = {
        "holds": holds(measures),
        "Ci_preloaded_mean": _mean_or_none(measures.get("Ci_preloaded")),
        "unstable_samples": int(np.count_nonzero(measures["unstable"])) if "unstable" in measures else None,
        "min_liftoff_margin": None,
        "min_slip_margin": None,
        "min_torque_margin": None,
        "max_contact_force_N": None,
        "max_torque_ratio": None,
    }
    if "torque_ratio" not in measures:
        return out
    out["min_torque_margin"] = _least(measures["torque_margin"])
    out["max_torque_ratio"] = float(max(np.max(measures["torque_ratio"]), np.max(measures["torque_ratio_loaded"])))
    if "liftoff_margin" in measures:
        out["min_liftoff_margin"] = _least(measures["liftoff_margin"])
        out["min_slip_margin"] = _least(measures["slip_margin"])
        out["max_contact_force_N"] = float(np.max(measures["contact_force_N"]))
    return out


def relief_summary(braced: BracedRobot, qs: Array, holding: Holding) -> dict[str, Any]:
    """Actuator relief along a braced run's samples: peak |τ_i|/effort_i free against braced (best preloads).

    The free-space peak is at the same configurations without the braces; the braced peak with the run's P_i
    (rigid statics); the best constant preloads are the LP of :func:`~bracekit.statics.actuator_relief` over
    every brace. ``best_preload_N`` is P (N) for one brace and the list of P_i for several.
    """
    effort = effort_limits(braced.robot)
    tau, a = actuator_torques(braced, qs, holding.wrenches, gravity=holding.gravity)
    preloads = np.asarray(holding.brace_preloads(len(braced.braces)), dtype=float)
    braced_peak = float(np.max(peak_ratio(tau - np.einsum("kbn,b->kn", a, preloads)[:, None, :], effort)))
    rel = relief_of(tau, a, effort)
    best = [float(p) for p in rel.preloads]
    return {
        "free_peak_torque_ratio": float(rel.free_peak),
        "braced_peak_torque_ratio": braced_peak,
        "best_preload_N": best[0] if len(best) == 1 else best,
        "best_braced_peak_torque_ratio": float(rel.braced_peak),
        "best_relief": float(rel.ratio),
    }
