"""The preload's second-order effect: the first-order error against the preload and the load (docs/validation.md)."""

from __future__ import annotations

import os
from collections.abc import Sequence
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike

from bracekit._linalg import show
from bracekit.compliance.preloaded import preloaded_compliance
from bracekit.errors import (
    InputError,
    MujocoValidationError,
    StaticSolveError,
)
from bracekit.simulation.scenario_model import Scenario
from bracekit.validate.compliance_check import _config
from bracekit.validate.contacts import plane_contacts
from bracekit.validate.inputs import FORCE_DIRECTIONS, _directions, _positive, _scenario, validation_configurations
from bracekit.validate.mujoco_check import mujoco_static_deflection
from bracekit.validate.statics import solve_statics
from bracekit.validate.table import _rel_err, _stats

__all__ = ["preload_study"]


def preload_study(
    scenario: Scenario | str | os.PathLike[str],
    preloads: Sequence[float] = (0.1, 0.3, 1.0, 3.0, 10.0, 30.0, 50.0),
    loads: Sequence[float] = (0.05, 0.5, 2.0),
    *,
    config: ArrayLike | None = None,
    directions: Sequence[tuple[str, ArrayLike]] | Sequence[ArrayLike] = FORCE_DIRECTIONS,
    reference: Literal["static", "mujoco"] = "static",
) -> dict[str, Any]:
    """Error of the first-order ``constrained`` model vs the preload P (N) and the load magnitude (N).

    Physics: with a preload the contact pushes on b with P n̂ through the configuration-dependent J_b,
    so the equilibrium K (q − rest) = J_eᵀ w + J_b,vᵀ n̂ λ has the tangent stiffness
    K_t = K − P ∂(J_b,vᵀ n̂)/∂q: a geometric (conservative-congruence) stiffness −∂(J_bᵀ n̂ P)/∂q that the
    first-order models, built on K alone, neglect. Its error is first order in w and grows about linearly
    with P / k (at fixed load); the dead load's own geometric term −∂(J_eᵀ w)/∂q adds an error growing
    linearly with |w| (at fixed P). ``corrected`` is the constrained model with K_t
    (:func:`bracekit.compliance.preloaded_compliance`): it removes the preload term and leaves the load term.

    The reference is the nonlinear static solve with a bilateral contact (every (P, load) pair
    comparable; ``would_open`` counts the cases where a unilateral contact would have opened), or MuJoCo
    (unilateral; opened cases excluded). Loads are pure forces of magnitude ``loads`` along ``directions``
    at the start configuration unless ``config`` is given.

    Returns a JSON-able dict; the arrays are indexed ``[preload][load]``: ``median_rel_err``, ``max_rel_err``
    (constrained), ``median_rel_err_corrected``, ``max_rel_err_corrected``, ``would_open``, ``failed``;
    errors in the L-weighted norm of :func:`run_validation`, None where no case contributes.
    """
    sc = _scenario(scenario)
    if reference not in ("static", "mujoco"):
        raise InputError(f"reference must be 'static' or 'mujoco', got {show(reference)}")
    ps = [_positive(p, "preload", "N", zero_ok=True) for p in preloads]
    fs = [_positive(f, "load", "N") for f in loads]
    if not ps or not fs:
        raise InputError("preloads and loads must each hold at least one value")
    labelled = _directions(directions)
    q = validation_configurations(sc, 1)[0] if config is None else sc.robot.check_q(config)
    cfg = _config(sc.braced, q, 0)
    c_first = cfg.compliances["constrained"]
    robot = sc.robot
    shape = (len(ps), len(fs))
    med, mx = np.full(shape, None, dtype=object), np.full(shape, None, dtype=object)
    med_c, mx_c = np.full(shape, None, dtype=object), np.full(shape, None, dtype=object)
    opened, failed = np.zeros(shape, dtype=int), np.zeros(shape, dtype=int)
    messages: list[str] = []
    for i, p in enumerate(ps):
        c_corr = preloaded_compliance(sc.braced, q, p)
        args = (robot.model, q, robot.stiffness, robot.tip_id, plane_contacts(sc.braced, p, environment=False))
        for j, f in enumerate(fs):
            errs, errs_c = [], []
            for label, d in labelled:
                w = np.concatenate([d[:3] * f, d[3:] * f * cfg.length])  # a moment part: f·L N·m
                try:
                    if reference == "static":
                        rs = solve_statics(*args, w, bilateral=True)
                        is_open, dx = rs.contact_force < 0.0, rs.deflection
                    else:
                        rm = mujoco_static_deflection(*args, w)
                        is_open, dx = rm.contact_opened, rm.deflection
                except (StaticSolveError, MujocoValidationError, ValueError, np.linalg.LinAlgError) as exc:
                    failed[i, j] += 1
                    messages.append(f"P = {p:g} N, |f| = {f:g} N, {label}: {exc}")
                    continue
                opened[i, j] += int(is_open)
                if is_open and reference == "mujoco":
                    continue
                ref = np.asarray(dx, dtype=float)
                errs.append(_rel_err(c_first @ w, ref, cfg.length))
                errs_c.append(_rel_err(c_corr @ w, ref, cfg.length))
            med[i, j], mx[i, j] = _stats(errs)
            med_c[i, j], mx_c[i, j] = _stats(errs_c)
    return {
        "scenario": sc.name,
        "reference": reference,
        "contact": "bilateral" if reference == "static" else "unilateral (opened cases excluded)",
        "config": np.asarray(q, dtype=float).tolist(),
        "length_scale_m": cfg.length,
        "preloads_N": ps,
        "loads_N": fs,
        "directions": [{"label": lab, "direction": d.tolist()} for lab, d in labelled],
        "median_rel_err": med.tolist(),
        "max_rel_err": mx.tolist(),
        "median_rel_err_corrected": med_c.tolist(),
        "max_rel_err_corrected": mx_c.tolist(),
        "would_open": opened.tolist(),
        "failed": failed.tolist(),
        "messages": messages,
    }
