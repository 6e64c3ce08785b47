"""The tracking check's report: measured against predicted compliance along β_x at each check point of each run.

:class:`TrackingReport` holds one :class:`TrackingStrategy` per strategy (its :class:`TrackingPoint` records),
the paper's ranking (``PAPER_RANKING``, most compliant first) as predicted and as measured in MuJoCo, and the
points whose measured compliance differs from the prediction by more than ``TRACKING_TOL``.
:func:`~bracekit.validate.tracking.run_tracking_validation` fills it.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from bracekit.validate.table import aligned

__all__ = ["PAPER_RANKING", "TRACKING_TOL", "TrackingPoint", "TrackingReport", "TrackingStrategy"]

Array = NDArray[np.float64]

#: The paper's claim, most compliant first.
PAPER_RANKING = ("free_space_min_norm", "braced_min_norm", "braced_gradient_projection")


@dataclass(frozen=True, eq=False)
class TrackingPoint:
    """One check point of a run: the path state, and measured against predicted compliance along β_x.

    Compliances are deflections along β_x per unit force along β_x (m/N for a translational β_x).

    Attributes:
        index: sample index in the run. t: the run's time there, s.
        q: the commanded configuration (n,), rad. beta_x: the unit twist (6,).
        tracking_error: ‖e_MuJoCo − e(q)‖ of the tip when the path reached the point, before settling, m.
        joint_error: max |q_MuJoCo − q| at the same moment, rad.
        normal_force: the brace's mean normal force over the path segment that ends at the point, N (None free).
        measured: MuJoCo, frictionless pad (braced) or no contact (free space).
        predicted: first order: β_xᵀ C_e β_x (``constrained``) braced, β_xᵀ J K⁻¹ Jᵀ β_x free.
        predicted_projection: β_xᵀ C_e β_x of the ``projection`` model (braced; None free).
        predicted_tangent: the same as ``predicted`` on the tangent stiffness of the preload and gravity.
        measured_sticking, predicted_sticking: the pad sticking with μ, and the constrained model of a sticking
            point on the tangent stiffness (braced; None free).
        ci: the run's C_i at the sample (‖β_xᵀ C‖, the model of the run's C_i series), m/N.
        rel_err: |measured − predicted| / predicted. rel_err_sticking: the same for the sticking pad.
        contact_opened: the contact opened under ±f with the frictionless pad (the point does not count).
        slip: largest tangential motion of b under ±f, sticking pad, m (None free).
        slipped: slip > 1e-5 m, the contact opened, or the chain still moved after 20τ with the sticking pad
            (the sticking value does not count).
        predicted_slip: bracekit's first-order contact force under ±f leaves the cone ‖f_t‖ ≤ μ f_n or pulls
            (:func:`~bracekit.statics.contact_response` with μ; None free).
    """

    index: int
    t: float
    q: Array
    beta_x: Array
    tracking_error: float
    joint_error: float
    normal_force: float | None
    measured: float
    predicted: float
    predicted_projection: float | None
    predicted_tangent: float
    measured_sticking: float | None
    predicted_sticking: float | None
    ci: float | None
    rel_err: float
    rel_err_sticking: float | None
    contact_opened: bool
    slip: float | None
    slipped: bool
    predicted_slip: bool | None

    def to_json(self) -> dict[str, Any]:
        """JSON-able dict (no NaN)."""
        return {
            "index": self.index,
            "t_s": self.t,
            "q": self.q.tolist(),
            "beta_x": self.beta_x.tolist(),
            "tracking_error_m": self.tracking_error,
            "joint_error_rad": self.joint_error,
            "normal_force_N": self.normal_force,
            "measured": self.measured,
            "predicted": self.predicted,
            "predicted_projection": self.predicted_projection,
            "predicted_tangent": self.predicted_tangent,
            "measured_sticking": self.measured_sticking,
            "predicted_sticking": self.predicted_sticking,
            "Ci": self.ci,
            "rel_err": self.rel_err,
            "rel_err_sticking": self.rel_err_sticking,
            "contact_opened": self.contact_opened,
            "slip_m": self.slip,
            "slipped": self.slipped,
            "predicted_slip": self.predicted_slip,
        }


def _mean(xs: list[float]) -> float | None:
    return float(np.mean(xs)) if xs else None


def _rel(a: float | None, b: float | None) -> float | None:
    return None if a is None or b is None or b == 0.0 else abs(a - b) / abs(b)


@dataclass(frozen=True, eq=False)
class TrackingStrategy:
    """The check points of one strategy's run and their means (over the points that count).

    Attributes:
        strategy: the run's name. braced: whether it is braced.
        points: the check points. wall_time: s.
        path: the brace's contact while the set points moved (braced): ``steps``, ``open_fraction`` (steps
            with no contact force), ``normal_force_mean_N``, ``normal_force_max_N``, ``friction`` (μ on).
    """

    strategy: str
    braced: bool
    points: list[TrackingPoint]
    wall_time: float
    path: dict[str, Any] | None = None

    def _counted(self) -> list[TrackingPoint]:
        return [p for p in self.points if not p.contact_opened]

    def _sticking(self) -> list[TrackingPoint]:
        return [p for p in self._counted() if p.measured_sticking is not None and not p.slipped]

    def summary(self) -> dict[str, Any]:
        """Means of measured and predicted compliance along β_x, their relative error and the worst point."""
        ok, st = self._counted(), self._sticking()
        measured = _mean([p.measured for p in ok])
        predicted = _mean([p.predicted for p in ok])
        out: dict[str, Any] = {
            "braced": self.braced,
            "points": len(self.points),
            "counted": len(ok),
            "measured_mean": measured,
            "predicted_mean": predicted,
            "rel_err_of_mean": _rel(measured, predicted),
            "max_rel_err": max((p.rel_err for p in ok), default=None),
            "predicted_projection_mean": _mean([p.predicted_projection for p in ok if p.predicted_projection]),
            "predicted_tangent_mean": _mean([p.predicted_tangent for p in ok]),
            "max_rel_err_tangent": max(
                (abs(p.measured - p.predicted_tangent) / p.predicted_tangent for p in ok), default=None
            ),
            "Ci_mean": _mean([p.ci for p in ok if p.ci is not None]),
            "max_tracking_error_m": max((p.tracking_error for p in self.points), default=None),
            "wall_time_s": self.wall_time,
        }
        if self.braced:
            out["path_contact"] = self.path
            ms = _mean([p.measured_sticking for p in st if p.measured_sticking is not None])
            ps = _mean([p.predicted_sticking for p in st if p.predicted_sticking is not None])
            out |= {
                "sticking_counted": len(st),
                "measured_sticking_mean": ms,
                "predicted_sticking_mean": ps,
                "rel_err_sticking_of_mean": _rel(ms, ps),
                "max_rel_err_sticking": max((p.rel_err_sticking or 0.0 for p in st), default=None),
                "slipped": sum(p.slipped for p in self.points),
                "slip_as_predicted": sum(p.slipped == p.predicted_slip for p in self.points),
                "min_normal_force_N": min((p.normal_force or 0.0 for p in self.points), default=None),
            }
        return out

    def to_json(self) -> dict[str, Any]:
        """JSON-able dict: the summary and the points."""
        return {**self.summary(), "check_points": [p.to_json() for p in self.points]}


#: Largest relative error of a check point (measured against predicted compliance) that still agrees.
TRACKING_TOL = 0.05


@dataclass(frozen=True, eq=False)
class TrackingReport:
    """Result of :func:`run_tracking_validation`: one :class:`TrackingStrategy` per run, and the ranking."""

    scenario: str
    compliance_model: str
    settings: dict[str, Any]
    strategies: dict[str, TrackingStrategy] = field(default_factory=dict)
    wall_time: float = 0.0

    def ranking(self, key: str = "measured_mean") -> dict[str, Any]:
        """Whether the strategies of the paper's ranking are ordered as the paper says by `key` (a summary key).

        Returns ``{"order": [most compliant first], "holds": bool | None, "violations": [lines]}``; ``holds``
        is None when fewer than two of the paper's strategies have a value.
        """
        values = {n: s.summary().get(key) for n, s in self.strategies.items() if n in PAPER_RANKING}
        ranked = [n for n in PAPER_RANKING if values.get(n) is not None]
        order = sorted(ranked, key=lambda n: -float(values[n] or 0.0))
        bad = [
            f"{b} ({values[b]:.4g}) is not stiffer than {a} ({values[a]:.4g})"
            for a, b in itertools.pairwise(ranked)
            if float(values[b] or 0.0) >= float(values[a] or 0.0)
        ]
        return {"order": order, "holds": None if len(ranked) < 2 else not bad, "violations": bad}

    def disagreements(self, tol: float = TRACKING_TOL) -> list[str]:
        """Where MuJoCo disagrees with bracekit; empty when physics agrees.

        A strategy whose worst point is off by more than `tol` (relative), or a measured ordering of the
        strategies other than the predicted one.
        """
        out = []
        for name, st in self.strategies.items():
            worst = st.summary().get("max_rel_err")
            if worst is not None and worst > tol:
                out.append(f"{name}: measured compliance off the prediction by {100 * worst:.2g} % (> {100 * tol:g} %)")
        predicted, measured = self.ranking("predicted_mean"), self.ranking("measured_mean")
        if predicted["holds"] is not None and measured["order"] != predicted["order"]:
            out.append(
                f"MuJoCo orders the strategies {' > '.join(measured['order'])}, bracekit predicts "
                f"{' > '.join(predicted['order'])}"
            )
        return out

    def to_json(self) -> dict[str, Any]:
        """The ``tracking`` JSON block (no NaN)."""
        return {
            "scenario": self.scenario,
            "tolerance": TRACKING_TOL,
            "disagreements": self.disagreements(),
            "compliance_model": self.compliance_model,
            "quantity": (
                "compliance along beta_x: beta_x^T dx / f under the tool force f*beta_x (m/N for a translational "
                "beta_x); predicted beta_x^T C beta_x; rel_err = |measured - predicted| / predicted"
            ),
            "paper_ranking": list(PAPER_RANKING),
            "ranking": {
                "predicted": self.ranking("predicted_mean"),
                "measured": self.ranking("measured_mean"),
                "measured_sticking": self.ranking("measured_sticking_mean"),
            },
            "settings": self.settings,
            "wall_time_s": self.wall_time,
            "strategies": {n: s.to_json() for n, s in self.strategies.items()},
        }

    def table_text(self) -> str:
        """Aligned text table: per strategy, measured and predicted mean compliance along β_x and the ranking."""
        s = self.settings
        head = [
            f"Tracking check in MuJoCo, scenario '{self.scenario}' ({self.compliance_model} runs)",
            f"{s['points']} point(s) per run, tool force {s['force_N']:g} N along β_x; brace preload "
            f"P = {s['preload_N']:g} N, μ = {s['friction']:g}, gravity {'on' if s['gravity'] else 'off'}",
            "compliance along β_x per unit force (1e-3 m/N); error = |measured − predicted| / predicted",
            "'max, K_t': worst point against the same model on the tangent stiffness of the preload and gravity",
            "",
        ]
        cols = (
            "strategy", "measured", "predicted", "error", "max error", "max, K_t",
            "sticking", "predicted", "error", "track",
        )  # fmt: skip
        rows = []
        for name, st in self.strategies.items():
            m = st.summary()
            rows.append(
                (
                    name,
                    _milli(m["measured_mean"]),
                    _milli(m["predicted_mean"]),
                    _pct(m["rel_err_of_mean"]),
                    _pct(m["max_rel_err"]),
                    _pct(m["max_rel_err_tangent"]),
                    _milli(m.get("measured_sticking_mean")),
                    _milli(m.get("predicted_sticking_mean")),
                    _pct(m.get("rel_err_sticking_of_mean")),
                    "n/a" if m["max_tracking_error_m"] is None else f"{1e3 * m['max_tracking_error_m']:.2g} mm",
                )
            )
        lines = [*head, *aligned(cols, rows), ""]
        for label, key in (
            ("predicted", "predicted_mean"),
            ("MuJoCo, frictionless pad", "measured_mean"),
            ("MuJoCo, sticking pad", "measured_sticking_mean"),
        ):
            rk = self.ranking(key)
            if rk["holds"] is None:
                continue
            verdict = "holds" if rk["holds"] else "does not hold: " + "; ".join(rk["violations"])
            lines.append(f"paper's ranking, {label}: {' > '.join(rk['order'])}: {verdict}")
        lines.append(f"wall time {self.wall_time:.1f} s")
        return "\n".join(lines)


def _milli(x: float | None) -> str:
    return "n/a" if x is None else f"{1e3 * x:.4g}"


def _pct(x: float | None) -> str:
    return "n/a" if x is None else f"{100.0 * x:.2g} %"
