"""The holding block of ``bracekit validate``: the scenario's holding statics in MuJoCo at its configurations."""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from bracekit.errors import (
    InputError,
    MujocoValidationError,
    NumericalError,
)
from bracekit.simulation.holding import Holding
from bracekit.simulation.scenario_model import Scenario
from bracekit.validate.holding_check import (
    DEFAULT_FRACTIONS,
    FAIL_ABOVE,
    HOLD_BELOW,
    HOLDING_SETTINGS,
    mujoco_holding_check,
)
from bracekit.validate.inputs import Array, _configurations, _positive, _scenario
from bracekit.validate.table import _stats, fmt_rel
from bracekit.validate.tracking import DEFAULT_FRICTION, DEFAULT_PRELOAD

__all__ = ["DEFAULT_WRENCHES", "HoldingValidationReport", "default_holding", "run_holding_validation"]

#: Tool wrenches of the holding and capacity blocks for a scenario without [loads] wrenches: a 10 N pull along
#: +z and a 10 N drag along +x (N, N·m, world axes, at the tip); scaled to each brace's margin by the checks.
DEFAULT_WRENCHES = ((0.0, 0.0, 10.0, 0.0, 0.0, 0.0), (10.0, 0.0, 0.0, 0.0, 0.0, 0.0))


@dataclass
class HoldingValidationReport:
    """Result of :func:`run_holding_validation`.

    ``checks``: one JSON-able dict per (configuration, listed wrench): ``config`` and ``wrench_index``,
    ``status`` (``ok`` | ``failed``), ``message``, and the :meth:`HoldingCheck.to_json` fields (``check``; None
    when it failed).
    """

    scenario: str
    holding: dict[str, Any]
    configurations: list[list[float]]
    settings: dict[str, Any]
    checks: list[dict[str, Any]] = field(default_factory=list)

    def _cases(self) -> list[dict[str, Any]]:
        return [c for ch in self.checks if ch["check"] is not None for c in ch["check"]["cases"]]

    def summary(self) -> dict[str, Any]:
        """Agreement in numbers: unloaded force, loaded force and torque errors, outcomes against the margins."""
        done = [ch["check"] for ch in self.checks if ch["check"] is not None]
        cases = self._cases()
        med_n, max_n = _stats([c["unloaded_normal_rel_err"] for c in done])
        med_f, max_f = _stats([c["rel_err"] for c in cases])
        med_c, max_c = _stats([c["rel_err_change"] for c in cases])
        med_t, max_t = _stats([c["torque_rel_err"] for c in cases])
        judged = [c for c in cases if c["agrees"] is not None]
        tangential = [c["unloaded_tangential_N"] for c in done]
        return {
            "unloaded_normal_median_rel_err": med_n,
            "unloaded_normal_max_rel_err": max_n,
            "unloaded_tangential_max_N": max(tangential) if tangential else None,
            "force_median_rel_err": med_f,
            "force_max_rel_err": max_f,
            "force_change_median_rel_err": med_c,
            "force_change_max_rel_err": max_c,
            "torque_median_rel_err": med_t,
            "torque_max_rel_err": max_t,
            "n_force_cases": sum(c["rel_err"] is not None for c in cases),
            "margin_cases": len(judged),
            "margin_agree": sum(bool(c["agrees"]) for c in judged),
            "margin_disagreements": [
                {
                    "fraction_of_margin": c["fraction_of_margin"],
                    "expected": c["expected"],
                    "mujoco": c["outcome"],  # every brace together
                    "brace": c["brace"],  # the brace judged above the band (predicted to fail first)
                    "mujoco_brace": c["braces"][c["brace"]]["outcome"],
                    "settled": c["settled"],  # False: still moving when the settling budget ran out
                }
                for c in judged
                if not c["agrees"]
            ],
            "max_creep_m": max((ch["creep_m"] for ch in done), default=None),
            "counts": {s: sum(ch["status"] == s for ch in self.checks) for s in ("ok", "failed")},
        }

    def to_json(self) -> dict[str, Any]:
        """One JSON-serialisable dict (no NaN: missing numbers and infinite margins are None)."""
        return {
            "scenario": self.scenario,
            "holding": self.holding,
            "error_measure": (
                "rel_err = |f_mujoco - f_pred| / |f_pred| (contact force on the robot at b, N, world axes), "
                "f_pred = f_c0 + s*df_c(w) first order; rel_err_change divides by |s*df_c(w)|; statistics over the "
                "cases predicted and found to hold"
            ),
            "summary": self.summary(),
            "settings": self.settings,
            "configurations": self.configurations,
            "checks": self.checks,
        }

    def table_text(self) -> str:
        """A few aligned lines: unloaded force, loaded force errors, margin agreement, creep."""
        s = self.summary()
        h = self.holding
        mu = "none" if h["friction"] is None else f"{h['friction']:g}"
        cnt = s["counts"]
        creep = "n/a" if s["max_creep_m"] is None else f"{s['max_creep_m']:.2g} m"
        tang = "n/a" if s["unloaded_tangential_max_N"] is None else f"{s['unloaded_tangential_max_N']:.2g} N"
        lines = [
            f"Validation of the holding statics in MuJoCo, scenario '{self.scenario}'",
            f"{h['source']}: gravity {'on' if h['gravity'] else 'off'}, preload P = "
            f"{', '.join(f'{p:g}' for p in h['preloads_N'])} N, friction μ = {mu}; "
            f"{len(self.configurations)} configuration(s), {len(self.checks)} check(s): {cnt['ok']} ran, "
            f"{cnt['failed']} failed",
            f"unloaded normal force vs P: median {fmt_rel(s['unloaded_normal_median_rel_err'])}, "
            f"max {fmt_rel(s['unloaded_normal_max_rel_err'])}; tangential at most {tang}",
            f"loaded contact force vs first order ({s['n_force_cases']} cases): median "
            f"{fmt_rel(s['force_median_rel_err'])}, max {fmt_rel(s['force_max_rel_err'])} "
            f"(of the load's change: median {fmt_rel(s['force_change_median_rel_err'])}, "
            f"max {fmt_rel(s['force_change_max_rel_err'])}); joint torques median "
            f"{fmt_rel(s['torque_median_rel_err'])}, max {fmt_rel(s['torque_max_rel_err'])}",
            f"slip / lift-off against the predicted margin (hold below 0.8×, fail above 1.2×): "
            f"{s['margin_agree']} of {s['margin_cases']} agree; tangential creep of sticking contacts ≤ {creep}",
        ]
        creeping = sum(not d["settled"] for d in s["margin_disagreements"] if d["expected"] == "held")
        if creeping:
            lines.append(
                f"  {creeping} case(s) below 0.8× still creeping when the settling budget ran out: not shown to hold"
            )
        fails = [
            f"  config {ch['config']}, wrench {ch['wrench_index']}: {ch['message']}"
            for ch in self.checks
            if ch["status"] == "failed"
        ]
        return "\n".join([*lines, *(["failed checks:", *fails] if fails else [])])


def run_holding_validation(
    scenario: Scenario | str | os.PathLike[str],
    configs: int | Sequence[ArrayLike] = 1,
    *,
    fractions: Sequence[float] = DEFAULT_FRACTIONS,
    holding: Holding | None = None,
    progress: Callable[[int], None] | None = None,
) -> HoldingValidationReport:
    """Check the scenario's holding statics (``sc.holding``: gravity, preload, friction, wrenches) in MuJoCo.

    At each configuration and for each listed wrench w, :func:`~bracekit.validate.holding_check.mujoco_holding_check`
    settles the preloaded chain and loads it with s·w at ``fractions`` of the predicted slip / lift-off margin
    (a wrench with no finite margin: s = 0.5, 1). Without listed wrenches only the unloaded state is checked.
    About 1 s of wall time per wrench and configuration (plus solving the configurations).

    Args:
        scenario: a Scenario, a shipped name or a TOML path (one brace or several); contact types MuJoCo
            models, rigid surfaces, and a holding that is active ([robot] gravity, [brace] preload or friction,
            or [loads] wrenches) unless ``holding`` is given.
        configs: number of configurations (:func:`validation_configurations`) or the configurations.
        fractions: fractions of the predicted margin to load each wrench to.
        holding: the holding statics to check instead of the scenario's (e.g. :func:`default_holding`).
        progress: called with 1 after each check.

    Raises:
        InputError: bad scenario, a scenario without holding statics, bad configs or fractions.
    """
    sc = _scenario(scenario)
    h = scenario_holding(sc, holding)
    fr = [_positive(f, "each fraction of the margin", "", zero_ok=True) for f in fractions]
    if not fr:
        raise InputError("fractions must hold at least one fraction of the margin")
    qs = _configurations(sc, configs)
    wrenches: list[Array] = [np.zeros(6)] if h.wrenches is None else list(h.wrenches)
    report = HoldingValidationReport(
        scenario=sc.name,
        holding=holding_record(h, len(sc.braced.braces), h.wrenches, holding is None),
        configurations=[np.asarray(q, dtype=float).tolist() for q in qs],
        settings={**HOLDING_SETTINGS, "fractions_of_margin": fr, "hold_below": HOLD_BELOW, "fail_above": FAIL_ABOVE},
    )
    for i, q in enumerate(qs):
        for j, w in enumerate(wrenches):
            entry: dict[str, Any] = {"config": i, "wrench_index": j, "status": "ok", "message": None, "check": None}
            try:
                chk = mujoco_holding_check(sc.braced, q, h, w, scales=[] if h.wrenches is None else None, fractions=fr)
                entry["check"] = chk.to_json()
            except (MujocoValidationError, NumericalError) as exc:
                entry["status"], entry["message"] = "failed", str(exc)
            report.checks.append(entry)
            if progress is not None:
                progress(1)
    return report


def default_holding(sc: Scenario) -> Holding:
    """The holding statics the checks use for a scenario without any (the tracking check's preload and μ).

    The scenario's gravity, each brace pressed with P = 5 N and friction μ = 0.8, and :data:`DEFAULT_WRENCHES`.
    """
    count = len(sc.braced.braces)
    return Holding(
        gravity=sc.holding.gravity,
        preloads=(DEFAULT_PRELOAD,) * count,
        frictions=(DEFAULT_FRICTION,) * count,
        wrenches=np.array(DEFAULT_WRENCHES),
    )


def scenario_holding(sc: Scenario, holding: Holding | None) -> Holding:
    """``holding``, else the scenario's holding statics; InputError when neither is given."""
    if holding is not None:
        if not isinstance(holding, Holding):
            raise InputError(f"holding must be a bracekit.simulation.holding.Holding, got {type(holding).__name__}")
        return holding
    if not sc.holding.active:
        raise InputError(
            f"scenario '{sc.name}' has no holding statics to check: set [robot] gravity, [brace] preload or "
            "friction, or [loads] wrenches"
        )
    return sc.holding


def holding_record(h: Holding, count: int, wrenches: ArrayLike | None, from_scenario: bool) -> dict[str, Any]:
    """The reports' record of the holding checked: gravity, P_i, μ_i, the wrenches and where they come from."""
    preloads = h.brace_preloads(count)
    frictions = h.brace_frictions(count)
    return {
        "source": "the scenario's holding statics" if from_scenario else "the checks' own holding statics",
        "gravity": h.gravity,
        "preload_N": max(preloads),
        "preloads_N": list(preloads),
        "friction": frictions[0],
        "frictions": list(frictions),
        "wrenches": None if wrenches is None else np.asarray(wrenches, dtype=float).tolist(),
    }
