"""Everything the model says at one configuration, as one JSON-able dict (``bracekit evaluate``)."""

from __future__ import annotations

import dataclasses
import warnings
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from bracekit._linalg import as_array, show
from bracekit.compliance.directional import directional_compliances, directional_keys
from bracekit.compliance.first_order import (
    compliance_ellipsoids,
    compliance_index,
    constrained_compliance,
    end_effector_compliance,
    free_space_compliance,
    unit6,
)
from bracekit.compliance.measures import SingularValues, frobenius_condition, singular_value_measures, theta_z
from bracekit.compliance.preloaded import preloaded_compliance
from bracekit.compliance.stiffness import stiffness_report, tool_stiffness
from bracekit.contact import Brace, ContactType, Surface, contact_type
from bracekit.errors import ChainSingularWarning, ContactError, InputError, SingularityError
from bracekit.kinematics import BracedRobot, BracedState, contact_null_space
from bracekit.model.robot import Robot
from bracekit.simulation.holding import Holding
from bracekit.spatial import unit
from bracekit.statics import capacity_of, contact_responses, effort_limits
from bracekit.tolerances import J1_COND_LIMIT


def _ellipsoids(c: np.ndarray) -> dict[str, Any]:
    e = compliance_ellipsoids(c)
    return {
        "translational": {"semi_axes": e.translational.semi_axes, "axes": e.translational.axes},
        "rotational": {"semi_axes": e.rotational.semi_axes, "axes": e.rotational.axes},
    }


def _reduction(braced: float | None, free: float | None) -> float | None:
    """1 − braced/free, or None when the free compliance along β_x is (numerically) zero or a model is absent."""
    return None if braced is None or free is None or free <= 1e-15 else 1.0 - braced / free


def _unit(v: NDArray[np.float64]) -> NDArray[np.float64]:
    """V / ‖v‖, scaled first where the norm leaves float64 (vectors of extreme size)."""
    with np.errstate(over="ignore", under="ignore"):
        size = np.linalg.norm(v)
    return v / size if np.isfinite(size) and size > 1e-150 else unit(v, "beta_x")


def _rank(m: NDArray[np.float64], scale: float) -> int:
    """Singular values of m above scale / J1_COND_LIMIT (the limit beyond which J1 counts as singular)."""
    if m.size == 0:
        return 0
    return int(np.sum(np.linalg.svd(m, compute_uv=False) > scale / J1_COND_LIMIT))


def chain1_motions(state: BracedState) -> dict[str, Any]:
    """How many braced motions of {b} chain 1 realises at the state, and the rank of A it gives.

    ``J1_condition``: σ_max/σ_min of J1 (None if σ_min = 0); ``J1_singular``: σ_min ≤ σ_max / J1_COND_LIMIT;
    ``braced_motions``: rank of J1 N, N the chain-1 motions that keep the contact (null space of Xᵀ J1);
    ``A_rank``: rank of [S_t1 J1 N, S_t2 J2], the braced Jacobian that chain 1 actually realises (equal to the
    rank of A, built from H, wherever J1 is regular).
    """
    j1 = state.split.J1
    s = np.linalg.svd(j1, compute_uv=False)
    top = float(s[0]) if s.size else 0.0
    keep = contact_null_space(state.split.X.T @ j1)
    motions = j1 @ keep
    realised = np.hstack([state.split.S_t1 @ motions, state.split.S_t2 @ state.split.J2])
    return {
        "J1_condition": float(s[0] / s[-1]) if s.size and s[-1] > 0 else None,
        "J1_singular": bool(not s.size or not s[-1] > top / J1_COND_LIMIT),
        "braced_motions": _rank(motions, top),
        "A_rank": _rank(realised, float(np.linalg.norm(realised, 2)) if realised.size else 0.0),
    }


def evaluate(
    robot: Robot,
    brace_frame: str | Sequence[str],
    q: ArrayLike,
    *,
    normal: ArrayLike = (0.0, 0.0, 1.0),
    contact: str | ContactType | Sequence[str | ContactType] = "frictionless_point",
    beta_x: ArrayLike | None = None,
    holding: Holding | None = None,
    beta_w: ArrayLike | None = None,
    stiffness_frame: str | ArrayLike | None = None,
) -> dict[str, Any]:
    """The braced model at q with N ≥ 1 braces, brace i on a surface through its b_i with normal i (world).

    `brace_frame` is one frame or a sequence of frames (a sequence of one is one brace), `normal` one normal
    (3,) for every brace or one per brace (N×3), `contact` one type or one per brace, in the order of the frames.
    The compliance is the constrained model with the stacked constraint G = [X_1ᵀ J_b1; X_2ᵀ J_b2; …]
    (:func:`~bracekit.compliance.first_order.constrained_compliance`, eq:Ce).

    Keys of every brace count (SI; matrices as nested lists row-major; twists [v; ω] and wrenches [f; m] at the
    tip point, world axes): n, joint_names, tip_frame, q, e, R_e, J (= J_e, 6×n), C_free, C_e_constrained,
    C_e_projection, k (of J), k_braced and the Πσ measures (:func:`singular_value_measures`), the compliance index
    along β_x (default [n̂_1; 0], the first brace's normal) in each model (Ci_*, Ci_reduction_*),
    max_translational_*, the ellipsoids; beside C_i (the paper's index, mixed units) ``ct_<model>`` is the
    translational compliance along β_x (m/N, None if β_x rotates) and, with a wrench direction `beta_w`,
    ``Cw_<model>`` = β_xᵀ C β_w; ``measures`` names each. With `stiffness_frame` ("world", "tool" or a 3×3
    rotation) ``tool_stiffness`` holds the tool stiffness (:func:`~bracekit.compliance.stiffness.stiffness_report`,
    with the statics' preloads and gravity).

    One brace adds the paper's chain split (state.split): n1, n2, brace_frame, contact, b, R_b, normal, J1, J2,
    H, X, A, J_braced (J̃, of which k_braced and Πσ are taken), theta_z, the projection model, and J1_condition,
    J1_singular, braced_motions and A_rank (:func:`chain1_motions`; where J1 is singular a ChainSingularWarning
    says that chain 1 realises fewer braced motions than A's columns suggest). Several braces add brace_frames,
    ``braces`` (per brace frame, contact, normal, b, R_b, H, X, J_b), ``G`` (c×n), ``G_rows`` ([brace index from
    0, column of X_i] per row), ``G_rank``, ``G_dependent_rows`` (rows of G left out: dependent or unloaded),
    ``N`` (n×(n − rank G)) and ``braced_jacobian`` (J_e N, of which k_braced and Πσ are taken, None where it is
    singular); the projection model's keys are None with ``projection_reason``.

    With `holding` (gravity, preloads P_i, frictions μ_i, tool wrenches) also the statics at q
    (:func:`~bracekit.statics.contact_responses` of every brace): ``tau0`` (N·m, unloaded joint torques, set
    points holding the preloads), ``q_s``, ``torque_ratio`` (peak |τ_i|/effort_i), per listed wrench
    ``liftoff``, ``slip`` (the least over the braces), ``torque`` (scales), ``torque_ratio_loaded`` and the
    margins ``liftoff_margin``, ``slip_margin``, ``torque_margin`` (None: nothing limits the scale), and with
    gravity or a preload ``C_e_preloaded``, ``Ci_preloaded`` and ``ct_preloaded``. Each brace's
    ``contact_wrench`` (unloaded), ``contact_wrench_loaded``, ``preload_N`` and ``friction`` are top-level keys
    with one brace and keys of its ``braces`` entry with several (there also its ``liftoff``, ``slip``,
    ``liftoff_margin`` and ``slip_margin``).
    """
    if not isinstance(robot, Robot):
        raise InputError(f"evaluate needs a bracekit Robot, got {type(robot).__name__}")
    frames = (brace_frame,) if isinstance(brace_frame, str) else _frames(brace_frame)
    qa = robot.check_q(q)
    normals = _normals(normal, len(frames))
    kinds = _contacts(contact, len(frames))
    probe = BracedRobot(robot, [Brace(f, Surface(np.zeros(3), n)) for f, n in zip(frames, normals, strict=True)])
    points = probe.state(qa).b_i
    braces = [Brace(f, Surface(b, n), kind) for f, b, n, kind in zip(frames, points, normals, kinds, strict=True)]
    braced = BracedRobot(robot, braces)
    st: BracedState = braced.state(qa)
    if beta_x is None:
        beta = np.concatenate([braces[0].surface.normal, np.zeros(3)])
    else:
        beta = as_array(beta_x, "beta_x", finite=False).reshape(-1)
        unit6(beta, "beta_x")  # 6 finite numbers, not all zero
    one = len(braces) == 1
    c_free = free_space_compliance(st)
    c_con = constrained_compliance(st)
    c_proj = end_effector_compliance(st, "projection") if one else None
    models = {"free": c_free, "constrained": c_con, "projection": c_proj}
    ci = {name: None if c is None else compliance_index(c, beta) for name, c in models.items()}
    view = _split_keys(braced, st) if one else _stacked_keys(braced, st)
    j_braced = view["J_braced"] if one else view["braced_jacobian"]
    measure: Callable[[Any], Any] = (lambda f: f(j_braced)) if one else (lambda f: _measure(f, j_braced))
    sv = measure(singular_value_measures)
    out = {
        "n": robot.n,
        "joint_names": list(robot.joint_names),
        "tip_frame": robot.tip,
        "q": qa,
        "e": st.e,
        "R_e": st.R_e,
        **view,
        "J": st.J_e,
        "C_free": c_free,
        "C_e_constrained": c_con,
        "C_e_projection": c_proj,
        "k": frobenius_condition(st.J_e),
        "k_braced": measure(frobenius_condition),
        **{f.name: None if sv is None else getattr(sv, f.name) for f in dataclasses.fields(SingularValues)},
        "beta_x": _unit(beta),
        **{f"Ci_{name}": value for name, value in ci.items()},
        **{f"Ci_reduction_{name}": _reduction(ci[name], ci["free"]) for name in ("constrained", "projection")},
        "max_translational_free": float(np.linalg.eigvalsh(c_free[:3, :3])[-1]),
        "max_translational_constrained": float(np.linalg.eigvalsh(c_con[:3, :3])[-1]),
        **{f"ellipsoid_{name}": None if c is None else _ellipsoids(c) for name, c in models.items()},
        "units": "m, rad, N, N·m; compliances in m/N, 1/N, rad/N, rad/(N·m)",
        **directional_keys(models, beta, beta_w),
    }
    if holding is not None:
        top, per_brace = _statics(braced, qa, holding, beta)
        out.update(top)
        if one:
            out.update(per_brace[0])
        else:
            for entry, extra in zip(out["braces"], per_brace, strict=True):
                entry.update(extra)
    if stiffness_frame is not None:
        count = len(braces)
        loaded = tool_stiffness(
            st,
            stiffness_frame,
            preload=(0.0,) * count if holding is None else holding.brace_preloads(count),
            gravity=holding is not None and holding.gravity,
        )
        out["tool_stiffness"] = stiffness_report(st, loaded)
    return out


def _split_keys(braced: BracedRobot, st: BracedState) -> dict[str, Any]:
    """One brace's keys of :func:`evaluate`: the paper's chain split at the state (warns where J1 is singular)."""
    split = st.split
    chain1 = chain1_motions(st)
    if chain1["J1_singular"]:
        cond = chain1["J1_condition"]
        warnings.warn(
            f"J1 is singular at this configuration (cond = {'inf' if cond is None else f'{cond:.3g}'}): chain 1 "
            f"realises {chain1['braced_motions']} of the {split.H.shape[1]} braced motions of {{b}} that A's "
            f"columns assume (A_rank = {chain1['A_rank']}); move chain 1 away from its singularity",
            ChainSingularWarning,
            stacklevel=3,
        )
    brace = braced.split.brace
    return {
        "n1": braced.split.n1,
        "n2": braced.split.n2,
        "brace_frame": brace.frame,
        "contact": brace.kind.name,
        "b": split.b,
        "R_b": split.R_b,
        "normal": brace.surface.normal,
        "J1": split.J1,
        "J2": split.J2,
        "H": split.H,
        "X": split.X,
        "A": split.A,
        **chain1,
        "J_braced": split.J_braced,
        "theta_z": theta_z(brace.surface.normal, split.z_b),
    }


def _stacked_keys(braced: BracedRobot, st: BracedState) -> dict[str, Any]:
    """Several braces' keys of :func:`evaluate`: each brace, the stacked constraint G, N and J_e N."""
    con = st.constraint
    return {
        "brace_frames": [b.frame for b in braced.braces],
        "braces": [
            {
                "frame": brace.frame,
                "contact": brace.kind.name,
                "normal": brace.surface.normal,
                "b": b,
                "R_b": r_b,
                "H": brace.H(),
                "X": brace.X(),
                "J_b": j_b,
            }
            for brace, b, r_b, j_b in zip(braced.braces, st.b_i, st.R_b_i, st.J_b_i, strict=True)
        ],
        "G": con.G,
        "G_rows": [list(r) for r in con.rows],
        "G_rank": con.rank,
        "G_dependent_rows": list(con.dependent),
        "N": st.N,
        "braced_jacobian": st.braced_jacobian,
        "projection_reason": PROJECTION_ONE_BRACE,
    }


#: Why the several-brace report has no projection-model keys.
PROJECTION_ONE_BRACE = (
    "the projection model (the paper's C̃1 of chain 1) is defined for one brace; several braces have the "
    "constrained model only"
)


def _frames(brace_frame: object) -> tuple[str, ...]:
    """The bracing frames of `brace_frame` (a str or a non-empty sequence of str); InputError otherwise."""
    if isinstance(brace_frame, Sequence) and not isinstance(brace_frame, bytes):
        frames = tuple(brace_frame)
        if frames and all(isinstance(f, str) for f in frames):
            return frames
    raise InputError(f"brace_frame must be a frame name or a non-empty list of frame names, got {show(brace_frame)}")


def _normals(normal: ArrayLike, count: int) -> list[NDArray[np.float64]]:
    """One normal (3,) for each of `count` braces from one normal (3,) or one per brace (count×3)."""
    a = as_array(normal, "the surface normal", error=ContactError)
    if a.shape == (3,):
        return [a] * count
    if a.shape != (count, 3):
        raise InputError(
            f"give one surface normal (3 numbers) or one per brace ({count}×3), in the order of the braces; "
            f"got shape {a.shape}"
        )
    return list(a)


def _contacts(contact: object, count: int) -> list[ContactType]:
    """One contact type for each of `count` braces from one type or a list with one per brace."""
    if isinstance(contact, str | ContactType):
        return [contact_type(contact)] * count
    if not isinstance(contact, (list, tuple)):
        raise InputError(
            f"contact must be a contact type (or its name) or a list with one per brace, got {show(contact)}"
        )
    items = list(contact)
    if len(items) != count:
        raise InputError(f"give one contact type or one per brace ({count}), got {len(items)}")
    return [contact_type(c) for c in items]


def _measure(f: Any, j: NDArray[np.float64]) -> Any:
    """f(j), or None where j is singular (no finite k)."""
    try:
        return f(j)
    except SingularityError:
        return None


def _finite(x: float | None) -> float | None:
    return None if x is None or not np.isfinite(x) else float(x)


def _statics(
    braced: BracedRobot, q: NDArray[np.float64], holding: Holding, beta: NDArray[np.float64]
) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    """The statics keys of :func:`evaluate` (see its docstring): those of the robot and those of each brace."""
    if not isinstance(holding, Holding):
        raise InputError(f"holding must be a bracekit Holding, got {type(holding).__name__}")
    count = len(braced.braces)
    preloads, frictions = holding.brace_preloads(count), holding.brace_frictions(count)
    resp = contact_responses(braced, q[None, :], preload=preloads, gravity=holding.gravity, friction=frictions)
    cap = capacity_of(resp, holding.loads, effort_limits(braced.robot))
    out: dict[str, Any] = {
        "tau0": resp.tau0[0],
        "q_s": resp.q_s[0],
        "torque_ratio": float(cap.peak_unloaded[0]),
        "gravity": holding.gravity,
    }
    per_brace: list[dict[str, Any]] = [
        {"contact_wrench": resp.f_c0[0, i], "preload_N": preloads[i], "friction": frictions[i]} for i in range(count)
    ]
    if holding.wrenches is not None:
        out.update(
            {
                "wrenches": holding.wrenches,
                "liftoff": _finite_list(cap.liftoff[0]),
                "slip": None if cap.slip is None else _finite_list(cap.slip[0]),
                "torque": _finite_list(cap.torque[0]),
                "torque_ratio_loaded": [float(x) for x in cap.peak_loaded[0]],
                "liftoff_margin": _finite(cap.liftoff_margin[0]),
                "slip_margin": None if cap.slip_margin is None else _finite(cap.slip_margin[0]),
                "torque_margin": _finite(cap.torque_margin[0]),
            }
        )
        for i, entry in enumerate(per_brace):
            view = cap.at(0, i)
            entry["contact_wrench_loaded"] = view.contact_wrench
            if count > 1:  # one brace: the robot's keys above are the brace's
                entry |= {
                    "liftoff": _finite_list(view.liftoff),
                    "slip": None if view.slip is None else _finite_list(view.slip),
                    "liftoff_margin": _finite(view.liftoff_margin),
                    "slip_margin": _finite(view.slip_margin),
                }
    if holding.gravity or max(preloads) > 0.0:
        c = preloaded_compliance(braced, q, list(preloads), gravity=holding.gravity)
        out["C_e_preloaded"] = c
        out["Ci_preloaded"] = compliance_index(c, beta)
        out["ct_preloaded"] = directional_compliances(c, beta).c_t
    return out, per_brace


def _finite_list(values: NDArray[np.float64]) -> list[float | None]:
    return [_finite(x) for x in values]
