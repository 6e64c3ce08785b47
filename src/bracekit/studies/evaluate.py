"""Everything the model says at one configuration, as one JSON-able dict (``bracekit evaluate``)."""

from __future__ import annotations

import dataclasses
import warnings
from collections.abc import Sequence
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
from bracekit.compliance.stiffness import stiffness_report
from bracekit.contact import Brace, ContactType, Surface, contact_type
from bracekit.errors import ChainSingularWarning, ContactError, InputError, SingularityError
from bracekit.kinematics import BracedRobot, BracedState, contact_null_space
from bracekit.model.robot import Robot
from bracekit.simulation.holding import Holding
from bracekit.spatial import unit
from bracekit.statics import contact_response, load_capacity
from bracekit.tolerances import J1_COND_LIMIT


def _ellipsoids(c: np.ndarray) -> dict[str, Any]:
    e = compliance_ellipsoids(c)
    return {
        "translational": {"semi_axes": e.translational.semi_axes, "axes": e.translational.axes},
        "rotational": {"semi_axes": e.rotational.semi_axes, "axes": e.rotational.axes},
    }


def _reduction(braced: float, free: float) -> float | None:
    """1 − braced/free, or None when the free compliance along β_x is (numerically) zero."""
    return None if free <= 1e-15 else 1.0 - braced / free


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
    contact: str | ContactType = "frictionless_point",
    beta_x: ArrayLike | None = None,
    holding: Holding | None = None,
    beta_w: ArrayLike | None = None,
    stiffness_frame: str | ArrayLike | None = None,
) -> dict[str, Any]:
    """The braced model at q with a surface through b of the given normal (world).

    Several braces: `brace_frame` a sequence of frames and `normal` one normal (3,) for every brace or one per
    brace (m×3), in the same order; see :func:`evaluate_braces`. A sequence of one frame is one brace.

    With `holding` (gravity, preload, friction, tool wrenches) also the statics at q: ``tau0`` (N·m, unloaded
    joint torques, set points holding the preload), ``q_s``, ``torque_ratio`` (peak |τ_i|/effort_i), per listed
    wrench ``liftoff``, ``slip``, ``torque`` (scales), ``contact_wrench_loaded`` and the margins
    ``liftoff_margin``, ``slip_margin``, ``torque_margin`` (None: nothing limits the scale), and with gravity or
    a preload ``C_e_preloaded`` and ``Ci_preloaded``.

    Keys (SI; matrices as nested lists row-major; twists [v; ω] and wrenches [f; m] at the tip point,
    world axes): J, J1, J2, H, X, A, J_braced, C_free, C_e_projection, C_e_constrained, k, k_braced,
    b, e, theta_z, the compliance index along β_x (default [n̂; 0]) in each model and the ellipsoids;
    J1_condition, J1_singular, braced_motions and A_rank (:func:`chain1_motions`). Where J1 is singular a
    ChainSingularWarning says that chain 1 realises fewer braced motions than A's columns suggest.
    Beside C_i (the paper's index, mixed units) ``ct_<model>`` is the translational compliance along β_x (m/N,
    None if β_x rotates) and, with a wrench direction `beta_w`, ``Cw_<model>`` = β_xᵀ C β_w; ``measures`` names
    each. With `stiffness_frame` ("world", "tool" or a 3×3 rotation) ``tool_stiffness`` holds the tool stiffness
    (:func:`~bracekit.compliance.stiffness.stiffness_report`, with the statics' preload and gravity).
    """
    if not isinstance(robot, Robot):
        raise InputError(f"evaluate needs a bracekit Robot, got {type(robot).__name__}")
    if not isinstance(brace_frame, str):
        frames = _frames(brace_frame)
        if len(frames) > 1:
            return evaluate_braces(
                robot,
                frames,
                q,
                normal=normal,
                contact=contact,
                beta_x=beta_x,
                holding=holding,
                beta_w=beta_w,
                stiffness_frame=stiffness_frame,
            )
        brace_frame = frames[0]
        if np.shape(normal) == (1, 3):  # one normal per brace, for one brace
            normal = np.asarray(normal)[0]
    qa = robot.check_q(q)
    kind = contact_type(contact)
    n_raw = as_array(normal, "the surface normal", error=ContactError)
    probe = BracedRobot(robot, Brace(brace_frame, Surface(np.zeros(3), n_raw)))
    b = probe.state(qa).split.b
    braced = BracedRobot(robot, Brace(brace_frame, Surface(b, n_raw), kind))
    st = braced.state(qa)
    if beta_x is None:
        beta = np.concatenate([braced.split.brace.surface.normal, np.zeros(3)])
    else:
        beta = as_array(beta_x, "beta_x", finite=False).reshape(-1)
        unit6(beta, "beta_x")  # 6 finite numbers, not all zero
    c_free = free_space_compliance(st)
    c_con = end_effector_compliance(st, "constrained")
    c_proj = end_effector_compliance(st, "projection")
    ci = {
        name: compliance_index(c, beta)
        for name, c in (("free", c_free), ("constrained", c_con), ("projection", c_proj))
    }
    sv = singular_value_measures(st.split.J_braced)
    chain1 = chain1_motions(st)
    if chain1["J1_singular"]:
        cond = chain1["J1_condition"]
        warnings.warn(
            f"J1 is singular at this configuration (cond = {'inf' if cond is None else f'{cond:.3g}'}): chain 1 "
            f"realises {chain1['braced_motions']} of the {st.split.H.shape[1]} braced motions of {{b}} that A's "
            "columns "
            f"assume (A_rank = {chain1['A_rank']}); move chain 1 away from its singularity",
            ChainSingularWarning,
            stacklevel=2,
        )
    out = {
        "n": robot.n,
        "n1": braced.split.n1,
        "n2": braced.split.n2,
        "joint_names": list(robot.joint_names),
        "brace_frame": brace_frame,
        "tip_frame": robot.tip,
        "contact": kind.name,
        "q": qa,
        "b": st.split.b,
        "e": st.e,
        "R_b": st.split.R_b,
        "R_e": st.R_e,
        "normal": braced.split.brace.surface.normal,
        "J": st.split.J,
        "J1": st.split.J1,
        "J2": st.split.J2,
        "H": st.split.H,
        "X": st.split.X,
        "A": st.split.A,
        **chain1,
        "J_braced": st.split.J_braced,
        "C_free": c_free,
        "C_e_constrained": c_con,
        "C_e_projection": c_proj,
        "k": frobenius_condition(st.split.J),
        "k_braced": frobenius_condition(st.split.J_braced),
        **{f.name: getattr(sv, f.name) for f in dataclasses.fields(sv)},
        "theta_z": theta_z(braced.split.brace.surface.normal, st.split.z_b),
        "beta_x": _unit(beta),
        "Ci_free": ci["free"],
        "Ci_constrained": ci["constrained"],
        "Ci_projection": ci["projection"],
        "Ci_reduction_constrained": _reduction(ci["constrained"], ci["free"]),
        "Ci_reduction_projection": _reduction(ci["projection"], ci["free"]),
        "max_translational_free": float(np.linalg.eigvalsh(c_free[:3, :3])[-1]),
        "max_translational_constrained": float(np.linalg.eigvalsh(c_con[:3, :3])[-1]),
        "ellipsoid_free": _ellipsoids(c_free),
        "ellipsoid_constrained": _ellipsoids(c_con),
        "ellipsoid_projection": _ellipsoids(c_proj),
        "units": "m, rad, N, N·m; compliances in m/N, 1/N, rad/N, rad/(N·m)",
        **directional_keys({"free": c_free, "constrained": c_con, "projection": c_proj}, beta, beta_w),
    }
    if holding is not None:
        out.update(_statics(braced, qa, holding, beta))
    if stiffness_frame is not None:
        out["tool_stiffness"] = stiffness_report(
            st,
            stiffness_frame,
            preload=0.0 if holding is None else holding.preload,
            gravity=holding is not None and holding.gravity,
        )
    return out


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


def _contacts(contact: str | ContactType | Sequence[str | ContactType], count: int) -> list[ContactType]:
    """One contact type for each of `count` braces from one type or one per brace."""
    if isinstance(contact, str | ContactType):
        return [contact_type(contact)] * count
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


def evaluate_braces(
    robot: Robot,
    brace_frames: Sequence[str],
    q: ArrayLike,
    *,
    normal: ArrayLike = (0.0, 0.0, 1.0),
    contact: str | ContactType | Sequence[str | ContactType] = "frictionless_point",
    beta_x: ArrayLike | None = None,
    holding: Holding | None = None,
    beta_w: ArrayLike | None = None,
    stiffness_frame: str | ArrayLike | None = None,
) -> dict[str, Any]:
    """Several braces at q: brace i touches a surface through its b_i with normal i (world).

    `normal` is one normal (3,) for every brace or one per brace (m×3), `contact` one type or one per brace,
    in the order of `brace_frames`. The compliance is the constrained model with the stacked constraint
    G = [X_1ᵀ J_b1; X_2ᵀ J_b2; …] (:func:`~bracekit.compliance.first_order.constrained_compliance`).

    Keys (SI; as :func:`evaluate`): n, joint_names, brace_frames, tip_frame, q, e, R_e, J (= J_e, 6×n),
    C_free, C_e_constrained, k (of J), k_braced and the Πσ measures of J_e N (None where J_e N is singular),
    beta_x (default [n̂_1; 0], the first brace's normal), Ci_free, Ci_constrained, Ci_reduction_constrained,
    max_translational_*, ellipsoid_free and ellipsoid_constrained; C_e_projection, Ci_projection,
    Ci_reduction_projection and ellipsoid_projection are None with ``projection_reason``. ``braces``: per brace
    frame, contact, normal, b, R_b, H, X, J_b; ``G`` (c×n), ``G_rows`` ([brace index from 0, column of X_i]
    per row), ``G_rank``, ``G_dependent_rows`` (indices of the rows of G left out: dependent or unloaded),
    ``N`` (n×(n − rank G)) and ``braced_jacobian`` (J_e N); ``ct_*``, ``Cw_*``, ``measures`` and
    ``tool_stiffness`` as :func:`evaluate`.

    Raises InputError for statics (`holding`): one brace only for now.
    """
    if not isinstance(robot, Robot):
        raise InputError(f"evaluate needs a bracekit Robot, got {type(robot).__name__}")
    frames = _frames(brace_frames)
    if holding is not None:
        raise InputError("statics (gravity, preload, friction, tool wrenches) are supported for one brace only")
    qa = robot.check_q(q)
    normals = _normals(normal, len(frames))
    kinds = _contacts(contact, len(frames))
    probe = BracedRobot(robot, [Brace(f, Surface(np.zeros(3), n)) for f, n in zip(frames, normals, strict=True)])
    points = probe.state(qa).b_i
    braces = [Brace(f, Surface(b, n), kind) for f, b, n, kind in zip(frames, points, normals, kinds, strict=True)]
    braced = BracedRobot(robot, braces)
    st: BracedState = braced.state(qa)
    first = braces[0].surface.normal
    if beta_x is None:
        beta = np.concatenate([first, np.zeros(3)])
    else:
        beta = as_array(beta_x, "beta_x", finite=False).reshape(-1)
        unit6(beta, "beta_x")
    c_free = free_space_compliance(st)
    c_con = constrained_compliance(st)
    con = st.constraint
    ci_free, ci_con = compliance_index(c_free, beta), compliance_index(c_con, beta)
    j_n = st.braced_jacobian
    sv = _measure(singular_value_measures, j_n)
    sv_keys = {f.name: None if sv is None else getattr(sv, f.name) for f in dataclasses.fields(SingularValues)}
    return {
        "n": robot.n,
        "joint_names": list(robot.joint_names),
        "brace_frames": list(frames),
        "tip_frame": robot.tip,
        "q": qa,
        "e": st.e,
        "R_e": st.R_e,
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
            for brace, b, r_b, j_b in zip(braces, st.b_i, st.R_b_i, st.J_b_i, strict=True)
        ],
        "G": con.G,
        "G_rows": [list(r) for r in con.rows],
        "G_rank": con.rank,
        "G_dependent_rows": list(con.dependent),
        "N": st.N,
        "braced_jacobian": j_n,
        "J": st.J_e,
        "C_free": c_free,
        "C_e_constrained": c_con,
        "C_e_projection": None,
        "projection_reason": PROJECTION_ONE_BRACE,
        "k": frobenius_condition(st.J_e),
        "k_braced": _measure(frobenius_condition, j_n),
        **sv_keys,
        "beta_x": _unit(beta),
        "Ci_free": ci_free,
        "Ci_constrained": ci_con,
        "Ci_projection": None,
        "Ci_reduction_constrained": _reduction(ci_con, ci_free),
        "Ci_reduction_projection": None,
        "max_translational_free": float(np.linalg.eigvalsh(c_free[:3, :3])[-1]),
        "max_translational_constrained": float(np.linalg.eigvalsh(c_con[:3, :3])[-1]),
        "ellipsoid_free": _ellipsoids(c_free),
        "ellipsoid_constrained": _ellipsoids(c_con),
        "ellipsoid_projection": None,
        "units": "m, rad, N, N·m; compliances in m/N, 1/N, rad/N, rad/(N·m)",
        **directional_keys({"free": c_free, "constrained": c_con, "projection": None}, beta, beta_w),
        **({} if stiffness_frame is None else {"tool_stiffness": stiffness_report(st, stiffness_frame)}),
    }


def _finite(x: float | None) -> float | None:
    return None if x is None or not np.isfinite(x) else float(x)


def _statics(
    braced: BracedRobot, q: NDArray[np.float64], holding: Holding, beta: NDArray[np.float64]
) -> dict[str, Any]:
    """The statics keys of :func:`evaluate` (see its docstring)."""
    if not isinstance(holding, Holding):
        raise InputError(f"holding must be a bracekit Holding, got {type(holding).__name__}")
    resp = contact_response(braced, q, preload=holding.preload, gravity=holding.gravity, friction=holding.friction)
    cap = load_capacity(
        braced, q, holding.loads, preload=holding.preload, gravity=holding.gravity, friction=holding.friction
    )
    out: dict[str, Any] = {
        "tau0": resp.tau0,
        "q_s": resp.q_s,
        "contact_wrench": resp.f_c0,
        "torque_ratio": float(cap.peak_unloaded),
        "gravity": holding.gravity,
        "preload_N": holding.preload,
        "friction": holding.friction,
    }
    if holding.wrenches is not None:
        out.update(
            {
                "wrenches": holding.wrenches,
                "liftoff": [_finite(x) for x in cap.liftoff],
                "slip": None if cap.slip is None else [_finite(x) for x in cap.slip],
                "torque": [_finite(x) for x in cap.torque],
                "contact_wrench_loaded": cap.contact_wrench,
                "torque_ratio_loaded": [float(x) for x in cap.peak_loaded],
                "liftoff_margin": _finite(cap.liftoff_margin),
                "slip_margin": _finite(cap.slip_margin),
                "torque_margin": _finite(cap.torque_margin),
            }
        )
    if holding.gravity or holding.preload > 0.0:
        c = preloaded_compliance(braced, q, holding.preload, gravity=holding.gravity)
        out["C_e_preloaded"] = c
        out["Ci_preloaded"] = compliance_index(c, beta)
        out["ct_preloaded"] = directional_compliances(c, beta).c_t
    return out
