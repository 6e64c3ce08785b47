"""The capacity block of ``bracekit validate``: lift-off and slip scales of the scenario's wrenches in MuJoCo."""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from bracekit._linalg import show
from bracekit.errors import (
    InputError,
    MujocoValidationError,
    NumericalError,
)
from bracekit.kinematics import BracedRobot
from bracekit.simulation.holding import Holding
from bracekit.simulation.scenario_model import Scenario
from bracekit.statics import capacity_along, effort_limits
from bracekit.statics.equilibrium import wrench_list
from bracekit.validate.capacity_check import RAMP_SETTINGS, mujoco_capacity_ramp
from bracekit.validate.holding_check import HOLDING_SETTINGS
from bracekit.validate.holding_report import holding_record, scenario_holding
from bracekit.validate.inputs import Array, _configurations, _positive, _scenario
from bracekit.validate.table import _stats, aligned, fmt_rel

__all__ = ["CapacityValidationReport", "run_capacity_validation"]

_CAPACITY_STATUSES = ("ok", "disagrees", "no_limit", "failed")


@dataclass
class CapacityValidationReport:
    """Result of :func:`run_capacity_validation`.

    ``cases``: one JSON-able dict per (configuration, wrench, contact variant): ``config``, ``wrench_index``,
    ``wrench``, ``variant`` (``scenario``: the scenario's friction; ``frictionless``: the same without μ, for a
    lift-off that friction pre-empts), ``status`` (``ok``: MuJoCo failed the predicted way; ``disagrees``: it
    failed otherwise or not at all; ``no_limit``: bracekit predicts neither lift-off nor slip; ``failed``),
    ``message``, and the :meth:`CapacityRamp.to_json` fields under ``ramp`` (None unless run).
    """

    scenario: str
    holding: dict[str, Any]
    configurations: list[list[float]]
    settings: dict[str, Any]
    cases: list[dict[str, Any]] = field(default_factory=list)

    def _stats_of(self, mode: str | None = None) -> dict[str, float | int | None]:
        ok = [c["ramp"] for c in self.cases if c["status"] == "ok" and (mode is None or c["ramp"]["mode"] == mode)]
        med, mx = _stats([r["rel_err"] for r in ok])
        med_s, max_s = _stats([r["rel_err_static"] for r in ok])
        return {
            "median_rel_err": med,
            "max_rel_err": mx,
            "median_rel_err_static": med_s,
            "max_rel_err_static": max_s,
            "n_cases": len(ok),
        }

    def counts(self) -> dict[str, int]:
        """Number of cases per status."""
        return {s: sum(c["status"] == s for c in self.cases) for s in _CAPACITY_STATUSES}

    def to_json(self) -> dict[str, Any]:
        """One JSON-serialisable dict (no NaN: missing numbers are None).

        ``median_rel_err``, ``max_rel_err`` (first-order scale vs MuJoCo), ``median_rel_err_static``,
        ``max_rel_err_static`` (nonlinear statics vs MuJoCo), ``n_cases``, ``by_mode`` (the same per failure),
        ``counts``, ``holding``, ``settings``, ``configurations``, ``cases``.
        """
        return {
            **self._stats_of(),
            "by_mode": {m: self._stats_of(m) for m in ("slipped", "lifted_off")},
            "error_measure": (
                "rel_err = |s_pred - s_mujoco| / s_mujoco with s the scale of the tool wrench at which the brace lifts "
                "off or slips: s_pred first order (bracekit.statics), rel_err_static with the nonlinear statics' "
                "scale; statistics over the cases where MuJoCo failed the predicted way"
            ),
            "counts": self.counts(),
            "holding": self.holding,
            "settings": self.settings,
            "configurations": self.configurations,
            "cases": self.cases,
        }

    def table_text(self) -> str:
        """One line per case (scales: first order, nonlinear statics, MuJoCo) and the summary."""
        s = self._stats_of()
        cnt = self.counts()
        lines = [
            f"Lift-off and slip scales under a slow load ramp in MuJoCo, scenario '{self.scenario}'",
            f"{len(self.cases)} case(s): {cnt['ok']} compared, {cnt['disagrees']} disagree, {cnt['no_limit']} with "
            f"no predicted limit, {cnt['failed']} failed",
            "",
        ]
        cols = (
            "config",
            "wrench",
            "contact",
            "mode",
            "brace",
            "first order",
            "nonlinear",
            "MuJoCo",
            "error",
            "error (nl)",
        )
        rows = []
        for c in self.cases:
            r = c["ramp"]
            if r is None:
                rows.append((str(c["config"]), str(c["wrench_index"]), c["variant"], c["status"], *("–",) * 6))
                continue

            def num(x: float | None) -> str:
                return "n/a" if x is None else f"{x:.4g}"

            if r["mode"] == "held":
                mj = f"held to {r['stop_scale']:g}" if r["mujoco_outcome"] == "held" else num(r["mujoco_scale"])
            else:
                mj = num(r["mujoco_scale"])
            mj += "" if r["mujoco_outcome"] in (None, r["mode"]) else f" ({r['mujoco_outcome']})"
            rows.append(
                (
                    str(c["config"]),
                    str(c["wrench_index"]),
                    c["variant"],
                    r["mode"],
                    str(r["brace"]),
                    "∞" if r["mode"] == "held" else num(r["predicted_scale"]),
                    "∞"
                    if r["mode"] == "held" and (r["static_message"] or "").startswith("nonlinear statics hold")
                    else num(r["static_scale"]),
                    mj,
                    fmt_rel(r["rel_err"]),
                    fmt_rel(r["rel_err_static"]),
                )
            )
        tail = [
            "",
            f"first-order scale vs MuJoCo ({s['n_cases']} cases): median {fmt_rel(s['median_rel_err'])}, max "
            f"{fmt_rel(s['max_rel_err'])}; nonlinear statics vs MuJoCo: median {fmt_rel(s['median_rel_err_static'])}, "
            f"max {fmt_rel(s['max_rel_err_static'])}",
        ]
        notes = [
            f"  config {c['config']}, wrench {c['wrench_index']} ({c['variant']}): {c['message']}"
            for c in self.cases
            if c["status"] in ("failed", "disagrees", "no_limit")
        ]
        return "\n".join([*lines, *aligned(cols, rows, left=(2, 3)), *tail, *notes])


def _capacity_entry(
    braced: BracedRobot, q: Array, holding: Holding, w: Array, index: int, j: int, variant: str, ramp_time: float
) -> dict[str, Any]:
    entry: dict[str, Any] = {
        "config": index,
        "wrench_index": j,
        "wrench": w.tolist(),
        "variant": variant,
        "status": "ok",
        "message": None,
        "ramp": None,
    }
    try:
        r = mujoco_capacity_ramp(braced, q, holding, w, ramp_time=ramp_time)
    except (MujocoValidationError, NumericalError) as exc:
        entry["status"], entry["message"] = "failed", str(exc)
        return entry
    entry["ramp"] = r.to_json()
    if r.mode == "held":  # neither lift-off nor slip at any scale: shown by ramping to stop_scale × w
        entry["status"] = "no_limit" if r.mujoco_outcome == "held" else "disagrees"
        what = (
            "held"
            if r.mujoco_outcome == "held"
            else f"{str(r.mujoco_outcome).replace('_', ' ')} at s = {r.mujoco_scale:.4g}"
        )
        entry["message"] = f"holds at any scale; ramped to {r.stop_scale:g}x in MuJoCo, {what}"
        if r.static_message is not None:
            entry["message"] += f"; {r.static_message}"
        return entry
    if r.mujoco_outcome != r.mode or r.mujoco_brace != r.brace:
        entry["status"] = "disagrees"
        what = "did not fail" if r.mujoco_outcome is None else f"{r.mujoco_outcome.replace('_', ' ')}"
        entry["message"] = (
            f"bracekit predicts brace {r.brace} {r.mode.replace('_', ' ')} first, MuJoCo {what}"
            f"{'' if r.mujoco_brace is None else f' at brace {r.mujoco_brace}'} up to s = {r.stop_scale:.4g}"
        )
    elif r.static_message is not None:
        entry["message"] = f"nonlinear statics: {r.static_message}"
    return entry


def run_capacity_validation(
    scenario: Scenario | str | os.PathLike[str],
    configs: int | Sequence[ArrayLike] = 1,
    *,
    wrenches: ArrayLike | None = None,
    frictionless_liftoff: bool = True,
    ramp_time: float = RAMP_SETTINGS["ramp_time_tau"],
    holding: Holding | None = None,
    progress: Callable[[int], None] | None = None,
) -> CapacityValidationReport:
    """Check bracekit's lift-off and slip scales against MuJoCo under a slow load ramp.

    For each configuration and tool wrench w, :func:`~bracekit.validate.capacity_check.mujoco_capacity_ramp`
    ramps s·w slowly (s reaches the predicted scale after ``ramp_time`` damping time constants) from the
    settled preloaded state (the scenario's gravity, preload and friction) and records the scale at which
    MuJoCo's contact opens or reaches the Coulomb cone; it is compared with bracekit's first-order scale
    (:func:`bracekit.statics.capacity_of`) and with the nonlinear statics' scale. With ``frictionless_liftoff``,
    a wrench predicted to slip before it would lift off is also ramped on the frictionless brace (same preload
    and gravity) to check its lift-off scale. A wrench with neither limit holds at any scale: it is ramped to
    10 × w in MuJoCo (status ``no_limit`` when it held, ``disagrees`` otherwise). About 1 s per case.

    Args:
        scenario: a Scenario, a shipped name or a TOML path; frictionless point contact, rigid surface, a
            preload P > 0 ([brace] preload).
        configs: number of configurations (:func:`validation_configurations`) or the configurations.
        wrenches: tool wrenches (m×6, [f; m] at the tip, world axes, N and N·m); default the scenario's
            [loads] wrenches.
        frictionless_liftoff: also check lift-off without friction where friction pre-empts it.
        ramp_time: time for s to reach the predicted scale, in damping time constants τ (> 0).
        holding: the holding statics to check instead of the scenario's (e.g.
            :func:`~bracekit.validate.holding_report.default_holding`).
        progress: called with 1 after each wrench.

    Raises:
        InputError: bad scenario (no preload), configs, wrenches or ramp_time; no wrenches to check.
    """
    sc = _scenario(scenario)
    h = scenario_holding(sc, holding)
    count = len(sc.braced.braces)
    preloads = list(h.brace_preloads(count))
    if not max(preloads) > 0.0:
        raise InputError(
            f"scenario '{sc.name}' has no preload: set [brace] preload (N) > 0 so that the brace can carry a load"
        )
    if wrenches is None:
        if h.wrenches is None:
            raise InputError(f"scenario '{sc.name}' lists no [loads] wrenches; give the tool wrenches to check")
        ws = np.asarray(h.wrenches, dtype=float)
    else:
        ws = wrench_list(wrenches)
    ramp_time = _positive(ramp_time, "ramp_time", "damping time constants")
    if not isinstance(frictionless_liftoff, bool):
        raise InputError(f"frictionless_liftoff must be True or False, got {show(frictionless_liftoff)}")
    qs = _configurations(sc, configs)
    frictions = [m if m else None for m in h.brace_frictions(count)]
    bare = Holding(gravity=h.gravity, preloads=tuple(preloads))
    report = CapacityValidationReport(
        scenario=sc.name,
        holding=holding_record(h, count, ws, holding is None),
        configurations=[np.asarray(q, dtype=float).tolist() for q in qs],
        settings={**HOLDING_SETTINGS, **RAMP_SETTINGS, "ramp_time_tau": ramp_time},
    )
    effort = effort_limits(sc.robot)
    for i, q in enumerate(qs):
        try:
            cap = capacity_along(
                sc.braced, q, ws, preload=preloads, gravity=h.gravity, friction=frictions, effort=effort
            )
        except NumericalError as exc:
            report.cases.extend(
                {
                    "config": i,
                    "wrench_index": j,
                    "wrench": w.tolist(),
                    "variant": "scenario",
                    "status": "failed",
                    "message": str(exc),
                    "ramp": None,
                }
                for j, w in enumerate(ws)
            )
            continue
        for j, w in enumerate(ws):
            liftoff = float(cap.liftoff[0, j])
            slip = np.inf if cap.slip is None else float(cap.slip[0, j])
            report.cases.append(_capacity_entry(sc.braced, q, h, w, i, j, "scenario", ramp_time))
            if frictionless_liftoff and any(frictions) and np.isfinite(liftoff) and slip < liftoff:
                report.cases.append(_capacity_entry(sc.braced, q, bare, w, i, j, "frictionless", ramp_time))
            if progress is not None:
                progress(1)
    return report
