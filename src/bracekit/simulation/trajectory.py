"""The result of one strategy's run: its samples, measures, and the Table I metrics of :meth:`Trajectory.summary`."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from bracekit._text_table import text_rows
from bracekit.simulation.samples import Samples

Array = NDArray[np.float64]

__all__ = ["Trajectory"]


@dataclass
class Trajectory:
    """One strategy's run: samples at times t (N,), joint values q (N×n) and named measures (N,).

    ``measures`` holds the per-sample series under their file names (:meth:`Samples.as_dict`, plus what the
    statics add); ``samples`` the same typed. ``failure`` says why a run that did not complete stopped: the
    step and time, and what failed (a joint jump, a singular matrix, a barrier, a correction that did not
    converge). ``braces``: each brace's contact summary, with several braces.
    """

    strategy: str
    braced: bool
    t: Array
    q: Array
    measures: dict[str, Array]
    completed: bool
    failure: str | None = None
    warnings: list[str] = field(default_factory=list)
    substeps: int = 0
    task_space: str = "pose"
    redundancy: int | None = None
    braces: list[dict[str, float]] | None = None
    samples: Samples | None = None

    @property
    def steps(self) -> int:
        """Steps taken (samples − 1)."""
        return int(self.t.size - 1)

    def ci_key(self, model: str) -> str:
        """The C_i series of this run: free-space compliance for the unbraced run, else C_e of `model`.

        With the run model ``preloaded`` it is ``Ci_preloaded`` for every run (the statics' own series, with
        gravity and the preload; in free space with gravity).
        """
        if model == "preloaded":
            return "Ci_preloaded"
        return f"Ci_{model}" if self.braced else "Ci_free"

    def summary(self, model: str = "constrained") -> dict[str, Any]:
        """The Table I metrics and run checks (SI units)."""
        m = self.measures
        # a model undefined for the run (projection with several braces) has no series: None below
        ci = m.get(self.ci_key(model), np.array([np.inf]))
        finite = bool(np.all(np.isfinite(ci)))  # a preloaded C_i is inf where the equilibrium is unstable
        return {
            "Ci_mean": float(np.mean(ci)) if finite else None,
            "Ci_min": float(np.min(ci)) if finite else None,
            **{key: float(reduce(m[name])) for key, reduce, name in _SERIES},
            "min_link_clearance_m": _finite_or_none(float(np.min(m["link_clearance"]))),
            "steps": self.steps,
            "substeps": self.substeps,
            "completed": self.completed,
            "failure": self.failure,
            "task_space": self.task_space,
            "redundancy": self.redundancy,
        } | ({} if self.braces is None else {"braces": self.braces})


#: Table I and the run checks: summary key, reduction over the run, measure series; in the summary's order.
_SERIES_TABLE = """
prod_sigma_t_mean              | mean | prod_sigma_t
prod_sigma_o_mean              | mean | prod_sigma_o
sigma_t_min                    | min  | sigma_t_min
sigma_o_min                    | min  | sigma_o_min
k_mean                         | mean | k
k_free_mean                    | mean | k_free
theta_z_max_rad                | max  | theta_z
max_task_error_m               | max  | task_error
max_contact_violation_m        | max  | contact_violation
max_region_radius_m            | max  | region_radius
min_surface_distance_m         | min  | surface_distance
max_joint_limit_violation_rad  | max  | joint_limit_violation
max_joint_step_rad             | max  | joint_step
"""
_REDUCE: dict[str, Callable[[Array], Any]] = {"mean": np.mean, "min": np.min, "max": np.max}
_SERIES = tuple((key, _REDUCE[how], name) for key, how, name in text_rows(_SERIES_TABLE, 3))


def _finite_or_none(value: float) -> float | None:
    """`value`, or None where it is not finite (JSON holds no inf)."""
    return value if np.isfinite(value) else None
