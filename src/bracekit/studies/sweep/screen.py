"""Batch screening: each candidate's braced C_i and k along the free-space path of its task, in one batch call.

The free-space minimum-norm path of a task does not depend on the brace, so it is computed once per task
context; each candidate's braced model (its point on its link, a plane with the spec's normal through it) is
evaluated at those configurations by :func:`bracekit.compliance.batch.evaluate_batch`. A candidate passes when
its largest braced k along the path is at most ``screen.k_max`` and its mean C_i is among the best
``screen.keep_fraction`` of its task context's candidates. (Below the free-space C_i is no test: a brace never
raises the compliance of the constrained model.) Only candidates that pass are simulated; the others still get
a row, ``screened_out`` True with the reason.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np

from bracekit.compliance.batch import evaluate_batch
from bracekit.compliance.preloaded import simulated_model
from bracekit.contact import Brace, Surface, contact_type
from bracekit.errors import BracekitError
from bracekit.kinematics import BracedRobot
from bracekit.studies.sweep.candidates import Candidate
from bracekit.studies.sweep.context import TaskContext, context_scenario
from bracekit.studies.sweep.evaluate import single_thread
from bracekit.studies.sweep.scenario import point_offset
from bracekit.studies.sweep.spec import POINT_FRAME, SweepSpec


@dataclass(frozen=True)
class Screened:
    """A candidate's screening: mean C_i (m/N) and largest k of J̃ along the free-space path (None if unknown)."""

    candidate: str
    Ci_mean: float | None
    k_max: float | None
    failure: str | None = None


def screen_context(spec: SweepSpec, context: TaskContext, candidates: list[Candidate]) -> list[Screened]:
    """Screen the candidates of one task context (all of them share its free-space path)."""
    single_thread()
    if context.q_ref is None:
        return [Screened(c.id, None, None, context.failure) for c in candidates]
    sc = context_scenario(spec, context.inputs)
    robot = sc.robot
    normal = np.asarray(spec.normal if spec.normal is not None else sc.braced.brace.surface.normal, dtype=float)
    kind = contact_type(spec.contact or sc.braced.brace.contact)
    model = simulated_model(sc.compliance_model)
    out = []
    for c in candidates:
        try:
            point = robot.with_point_frame(POINT_FRAME, c.inputs["link"], point_offset(spec, robot, c.inputs))
            braced = BracedRobot(point, Brace(POINT_FRAME, Surface(np.zeros(3), normal), kind))
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                ev = evaluate_batch(braced, context.Q, context.beta, models=(model,), errors="nan", k_braced=True)
        except (BracekitError, ArithmeticError, np.linalg.LinAlgError) as exc:
            out.append(Screened(c.id, None, None, f"screening: {exc}"))
            continue
        kb = ev.k_braced if ev.k_braced is not None else np.array([np.nan])
        k = float(np.max(kb)) if np.all(np.isfinite(kb)) else math.inf
        out.append(Screened(c.id, float(np.mean(ev.Ci[model])), k if math.isfinite(k) else None))
    return out


def select(spec: SweepSpec, screened: list[Screened]) -> dict[str, str | None]:
    """Candidate id → None if it passes the screen of its task context, else the reason it does not."""
    s = spec.screening
    out: dict[str, str | None] = {}
    ok = []
    for r in screened:
        if r.failure is not None:
            out[r.candidate] = None  # simulated: the run says what fails
        elif r.k_max is None:
            out[r.candidate] = "screened out: J̃ singular on the free-space path"
        elif r.k_max > s.k_max:
            out[r.candidate] = f"screened out: k of J̃ reaches {r.k_max:.3g} > {s.k_max:g} on the free-space path"
        else:
            ok.append(r)
    keep = math.ceil(s.keep_fraction * len(screened))
    ranked = sorted(ok, key=lambda r: (r.Ci_mean, r.candidate))
    for i, r in enumerate(ranked):
        out[r.candidate] = (
            None
            if i < keep
            else f"screened out: C_i {r.Ci_mean:.4g} m/N not among the best {s.keep_fraction:.0%} on the free path"
        )
    return out
