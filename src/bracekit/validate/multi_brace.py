"""Validation of the stacked compliance of several braces against MuJoCo and the nonlinear static solve.

At one configuration q of a :class:`~bracekit.kinematics.BracedRobot` with one or several rigid frictionless
point braces, the tip deflection predicted by the stacked constrained compliance
(:func:`~bracekit.compliance.first_order.stacked_compliance`), Δx_pred = C_e w, is compared for a set of
small tip wrenches w with two independent references:

* MuJoCo (:func:`~bracekit.validate.mujoco_check.mujoco_static_deflection_multi`): a frictionless sphere at
  every {b_i} on its own plane (unilateral), each contact preloaded with P_i through the springs' set points
  q_s = q − K⁻¹ Σ_i J_b_iᵀ [P_i n̂_i; 0], settled quasi-statically;
* the nonlinear static equilibrium (:func:`~bracekit.validate.statics.solve_static_equilibrium_multi`), Newton
  on the stacked KKT system with the same set points and bilateral contacts.

Error measure as in :mod:`bracekit.validate.runner`: ‖Δx_pred − Δx_ref‖_L / ‖Δx_ref‖_L with
‖[Δp; Δθ]‖_L = ‖[Δp; L·Δθ]‖, here L = min_i ‖e − b_i‖ (m), the lever from the brace nearest to the tip.
A case in which a contact would open (MuJoCo loses it, or the bilateral static solve pulls on it) is
reported with status ``contact_opened`` and kept out of the statistics; a failed reference gives status
``failed`` with its message. Statistics are ``None`` (never NaN) when no case contributes.
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Sequence
from dataclasses import replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from bracekit.compliance.first_order import stacked_compliance
from bracekit.errors import InputError, MujocoValidationError, RedundantContactWarning, StaticSolveError
from bracekit.kinematics import BracedRobot
from bracekit.validate.mujoco_check import MultiMujocoResult, mujoco_static_deflection_multi
from bracekit.validate.runner import DEFAULT_DIRECTIONS, MUJOCO_SETTINGS, _directions, _positive, _rel_err
from bracekit.validate.statics import _per_brace, solve_static_equilibrium_multi

__all__ = ["validate_several_braces"]

Array = NDArray[np.float64]

#: Largest distance (m) of a brace point from its surface accepted at the configuration.
_GAP_TOL = 1e-8
#: MuJoCo timesteps (s) tried in turn until the chain settles.
_TIMESTEPS = (1e-3, 5e-4, 2.5e-4)


def _stats(values: list[float]) -> dict[str, float | int | None]:
    if not values:
        return {"median": None, "max": None, "n": 0}
    return {"median": float(np.median(values)), "max": float(np.max(values)), "n": len(values)}


def _mujoco_run(
    model: Any,
    q: Array,
    K: Array,
    ids: list[int],
    tip: int,
    surfaces: list[tuple[Array, Array]],
    w: Array,
    P: Array,
    max_steps: int,
) -> tuple[MultiMujocoResult | None, float | None, str]:
    """MuJoCo at the default timestep (1 ms), then at 0.5 ms and 0.25 ms if it does not settle.

    Several stiff contacts can keep bouncing in a limit cycle at one timestep and settle at another.
    Returns (result or None, timestep used in s or None, error message or "").
    """
    error = ""
    for step in _TIMESTEPS:
        try:
            result = mujoco_static_deflection_multi(
                model, q, K, ids, tip, surfaces, w, preload=P, max_steps=max_steps, timestep=step,
                sphere_radius=MUJOCO_SETTINGS["sphere_radius_m"],
            )  # fmt: skip
        except MujocoValidationError as exc:
            error = str(exc)
            if "did not settle" not in error:
                break
            continue
        return result, step, ""
    return None, None, error


def _check_braces(braced: BracedRobot) -> None:
    if not isinstance(braced, BracedRobot):
        raise InputError(f"validate_several_braces needs a BracedRobot, got {type(braced).__name__}")
    for i, brace in enumerate(braced.braces):
        if brace.kind.name != "frictionless_point":
            raise InputError(
                f"braces[{i}] uses '{brace.kind.name}': the validation supports frictionless point contacts only "
                "(what MuJoCo and the static solve model)"
            )
        if brace.environment_stiffness is not None:
            raise InputError(f"braces[{i}] sets environment_stiffness: the validation assumes rigid surfaces")


def validate_several_braces(
    braced: BracedRobot,
    q: ArrayLike,
    *,
    loads: Sequence[tuple[str, ArrayLike]] | Sequence[ArrayLike] = DEFAULT_DIRECTIONS,
    force: float = 0.5,
    moment: float = 0.05,
    preload: float | Sequence[float] = 1.0,
    mujoco: bool = True,
    max_steps: int = 100_000,
) -> dict[str, Any]:
    """Compare the stacked constrained C_e·w with MuJoCo and the nonlinear static solve at one configuration.

    Args:
        braced: robot with one or several braces, each a rigid frictionless point contact.
        q: (n,) rad, a configuration at which every b_i lies on its surface (within 1e-8 m).
        loads: load directions, (label, [f̂; m̂]) pairs or bare 6-vectors (world axes); each non-zero part is
            scaled to ``force`` / ``moment``. Default: the ten directions of ``bracekit validate``.
        force: magnitude of the force part of each load, N (> 0).
        moment: magnitude of the moment part, N·m (> 0).
        preload: contact force P_i ≥ 0 (N) of each brace at q: one for all or one per brace.
        mujoco: also run MuJoCo (False: the static solve only).
        max_steps: MuJoCo step budget per load.

    Returns:
        A JSON-ready dict: ``braces`` (frame, surface point and normal, preload), ``configuration``,
        ``length_scale_m`` (L), ``settings``, ``cases`` (per load: label, wrench, status, message, the three
        deflections [Δp; Δθ], the errors ``rel_err_static``, ``rel_err_mujoco``, ``mujoco_vs_static`` and the
        contact forces of both references), ``summary`` with ``constrained_vs_static``,
        ``constrained_vs_mujoco`` and ``mujoco_vs_static`` ({median, max, n} over the ``ok`` cases),
        ``n_ok``, ``n_opened``, ``n_failed`` and ``run_time_s``.

    Raises:
        InputError: other contact types or compliant surfaces, a b_i off its surface at q, dependent contact
            constraints (the static solve needs independent ones), bad loads or numbers.
    """
    start = time.perf_counter()
    _check_braces(braced)
    robot = braced.robot
    qa = np.asarray(robot.check_q(q), dtype=float)
    force = _positive(force, "force", "N")
    moment = _positive(moment, "moment", "N·m")
    if not isinstance(mujoco, bool):
        raise InputError(f"mujoco must be True or False, got {mujoco!r}")
    if isinstance(max_steps, bool) or not isinstance(max_steps, int) or max_steps < 1:
        raise InputError(f"max_steps must be a whole number >= 1, got {max_steps!r}")
    P = _per_brace(preload, len(braced.braces))
    labelled = _directions(loads)

    with warnings.catch_warnings():
        warnings.simplefilter("error", RedundantContactWarning)
        try:
            st = braced.stacked_state(qa)
            c_e = stacked_compliance(st)
        except RedundantContactWarning as exc:
            raise InputError(f"the braces constrain dependent motions at q ({exc}); give independent contacts") from exc
    if st.constraint.dependent:
        raise InputError("a contact carries no load at q (rows dropped from G); give contacts the joints can load")
    surfaces = [(b.surface.point, b.surface.normal) for b in braced.braces]
    for i, (brace, b) in enumerate(zip(braced.braces, st.b_i, strict=True)):
        gap = brace.surface.signed_distance(b)
        if abs(gap) > _GAP_TOL:
            raise InputError(f"braces[{i}]: b_i is {gap:.3e} m from its surface at q; give a braced configuration")
    length = float(min(np.linalg.norm(st.e - b) for b in st.b_i))
    scale = np.array([force] * 3 + [moment] * 3)
    model, K, ids, tip = robot.model, robot.stiffness, list(braced.brace_ids), robot.tip_id

    cases: list[dict[str, Any]] = []
    for label, direction in labelled:
        w = direction * scale
        pred = c_e @ w
        messages: list[str] = []
        static = mj = None
        try:
            static = solve_static_equilibrium_multi(model, qa, K, ids, tip, surfaces, w, preload=P)
        except (StaticSolveError, np.linalg.LinAlgError) as exc:
            messages.append(f"static solve failed: {exc}")
        step = None
        if mujoco:
            mj, step, error = _mujoco_run(model, qa, K, ids, tip, surfaces, w, P, max_steps)
            if error:
                messages.append(f"MuJoCo failed: {error}")
        opened = bool(
            (static is not None and np.any(static.contact_forces < 0.0)) or (mj is not None and any(mj.contact_opened))
        )
        if messages:
            status = "failed"
        elif opened:
            status = "contact_opened"
            messages.append("a contact opens under this load (it pulls more than its preload): not in the statistics")
        else:
            status = "ok"
        d_static = None if static is None else static.deflection
        d_mj = None if mj is None else mj.deflection
        cases.append(
            {
                "label": label,
                "wrench": w.tolist(),
                "status": status,
                "message": "; ".join(messages),
                "predicted": pred.tolist(),
                "static": None if d_static is None else d_static.tolist(),
                "mujoco": None if d_mj is None else d_mj.tolist(),
                "rel_err_static": _rel_err(pred, d_static, length),
                "rel_err_mujoco": _rel_err(pred, d_mj, length),
                "mujoco_vs_static": None if d_mj is None else _rel_err(d_mj, d_static, length),
                "contact_forces_static": None if static is None else static.contact_forces.tolist(),
                "contact_forces_mujoco": None if mj is None else mj.contact_forces.tolist(),
                "mujoco_timestep_s": step,
            }
        )

    ok = [c for c in cases if c["status"] == "ok"]

    def pick(key: str) -> list[float]:
        return [float(c[key]) for c in ok if c[key] is not None]

    return {
        "braces": [
            {
                "frame": brace.frame,
                "surface_point": brace.surface.point.tolist(),
                "surface_normal": brace.surface.normal.tolist(),
                "preload_N": float(p),
            }
            for brace, p in zip(braced.braces, P, strict=True)
        ],
        "configuration": qa.tolist(),
        "length_scale_m": length,
        "settings": {
            "force_N": force,
            "moment_Nm": moment,
            "length_scale": "L = min_i |e - b_i| at the configuration (m)",
            "static_solve": "Newton on the stacked KKT system, bilateral contacts, tol 1e-12",
            "mujoco": {**MUJOCO_SETTINGS, "max_steps": max_steps, "contacts": "one sphere and plane per brace"}
            if mujoco
            else None,
        },
        "cases": cases,
        "summary": {
            "constrained_vs_static": _stats(pick("rel_err_static")),
            "constrained_vs_mujoco": _stats(pick("rel_err_mujoco")),
            "mujoco_vs_static": _stats(pick("mujoco_vs_static")),
        },
        "n_ok": len(ok),
        "n_opened": sum(c["status"] == "contact_opened" for c in cases),
        "n_failed": sum(c["status"] == "failed" for c in cases),
        "run_time_s": time.perf_counter() - start,
    }


def run_several_braces_validation(scenario: Any, configs: int = 3) -> dict[str, Any]:
    """:func:`validate_several_braces` at `configs` configurations of a several-brace scenario's braced path.

    The configurations are evenly spaced samples of the scenario's braced minimum-norm run (every contact kept).
    Returns ``{"scenario", "configurations", "reports", "summary"}``: the summary pools the closed-contact
    cases of every configuration (median and max relative error of the stacked constrained C_e·w against the
    static solve and MuJoCo, and of MuJoCo against the static solve) and counts ``n_ok``, ``n_opened``,
    ``n_failed``.
    """
    from bracekit.simulation.run import run_scenario  # the runs sit above the validation

    path_only = replace(scenario, strategies=("braced_min_norm",))  # only the braced path is needed
    result = run_scenario(path_only, both_models=False)
    run = result.trajectories["constrained"]["braced_min_norm"]
    index = np.unique(np.linspace(0, run.q.shape[0] - 1, max(1, int(configs))).round().astype(int))
    reports = [validate_several_braces(scenario.braced, run.q[k]) for k in index]
    cases = [c for r in reports for c in r["cases"] if c["status"] == "ok"]

    def pool(key: str) -> dict[str, float | int | None]:
        return _stats([c[key] for c in cases if c.get(key) is not None])

    return {
        "scenario": scenario.name,
        "not_checked": (
            "with several braces only the stacked constrained compliance is validated (1 N per contact, no "
            "gravity): not the scenario's statics, the tracking check or a figure"
        ),
        "configurations": [run.q[k].tolist() for k in index],
        "reports": reports,
        "summary": {
            "constrained_vs_static": pool("rel_err_static"),
            "constrained_vs_mujoco": pool("rel_err_mujoco"),
            "mujoco_vs_static": pool("mujoco_vs_static"),
            "n_ok": sum(r["n_ok"] for r in reports),
            "n_opened": sum(r["n_opened"] for r in reports),
            "n_failed": sum(r["n_failed"] for r in reports),
        },
    }


def several_braces_text(data: dict[str, Any]) -> str:
    """A few lines for the command line: the pooled errors of :func:`run_several_braces_validation`."""
    s = data["summary"]

    def pct(stats: dict[str, Any]) -> str:
        if stats["median"] is None:
            return "no case"
        return f"median {100 * stats['median']:.3g} %, max {100 * stats['max']:.3g} % ({stats['n']} cases)"

    return "\n".join(
        [
            f"Validation of the stacked constrained compliance, scenario '{data['scenario']}' "
            f"({len(data['configurations'])} configuration(s) of the braced path, every contact in MuJoCo)",
            f"cases: {s['n_ok']} compared, {s['n_opened']} with a contact opened, {s['n_failed']} failed",
            f"constrained vs static solve: {pct(s['constrained_vs_static'])}",
            f"constrained vs MuJoCo:       {pct(s['constrained_vs_mujoco'])}",
            f"MuJoCo vs static solve:      {pct(s['mujoco_vs_static'])}",
            f"not checked: {data['not_checked']}",
        ]
    )
