"""Batch screening: each candidate's link clearance at the start, and its braced C_i and k along the free-space path.

The free-space minimum-norm path of a task does not depend on the brace, so it is computed once per task
context; each candidate's braced model (its point on its link, a plane with the spec's normal through it) is
evaluated at those configurations in one call of :func:`bracekit.compliance.batch.evaluate_batch`. A candidate
passes when, in this order:

1. its links clear the surface's solid at the reference start by ``feasibility.min_clearance`` (the braced runs
   start there when the start solve keeps the reference start, so a candidate failing this fails feasibility);
2. its largest braced k along the path is at most ``screen.k_max``;
3. its mean C_i along the path is among the best ``screen.keep_fraction`` of its task context's candidates
   (of all of them, counting those dropped by 1 and 2).

(Below the free-space C_i is no test: a brace never raises the compliance of the constrained model.) Only the
candidates that pass are simulated; the others still get a row, ``screened_out`` True with the reason.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from bracekit.compliance.batch import evaluate_batch
from bracekit.compliance.preloaded import simulated_model
from bracekit.contact import Brace, Surface, contact_type
from bracekit.errors import BracekitError
from bracekit.kinematics import BracedRobot
from bracekit.kinematics.clearance import link_clearance
from bracekit.studies.sweep.candidates import Candidate
from bracekit.studies.sweep.collector import collector_paused
from bracekit.studies.sweep.context import TaskContext, context_scenario
from bracekit.studies.sweep.evaluate import single_thread
from bracekit.studies.sweep.scenario import point_offset
from bracekit.studies.sweep.spec import POINT_FRAME, SweepSpec

Array = NDArray[np.float64]


@dataclass(frozen=True)
class Screened:
    """A candidate's screening (None where unknown).

    Mean C_i (m/N) and largest k of J̃ along the free-space path; the least link clearance from the surface's
    solid at the reference start (m).
    """

    candidate: str
    Ci_mean: float | None
    k_max: float | None
    failure: str | None = None
    clearance: float | None = None


def screen_context(spec: SweepSpec, context: TaskContext, candidates: list[Candidate]) -> list[Screened]:
    """Screen the candidates of one task context (all of them share its free-space path), each on its own.

    Python's garbage collector is held off meanwhile (:mod:`.collector`).
    """
    single_thread()
    if context.q_ref is None:
        return [Screened(c.id, None, None, context.failure) for c in candidates]
    with collector_paused():
        return _screen(spec, context, context.q_ref, candidates)


def _screen(spec: SweepSpec, context: TaskContext, q_ref: Array, candidates: list[Candidate]) -> list[Screened]:
    sc = context_scenario(spec, context.inputs)
    robot = sc.robot
    normal = np.asarray(spec.normal if spec.normal is not None else sc.braced.brace.surface.normal, dtype=float)
    kind = contact_type(spec.contact or sc.braced.brace.contact)
    region = spec.region_radius if spec.region_radius is not None else sc.braced.brace.region_radius
    model = simulated_model(sc.compliance_model)
    out = []
    for c in candidates:
        try:
            point = robot.with_point_frame(POINT_FRAME, c.inputs["link"], point_offset(spec, robot, c.inputs))
            placement, _ = point.frame_kinematics(q_ref, [point.frame_id(POINT_FRAME)])[0]
            centre = placement[:3, 3] + np.asarray(c.inputs.get("region_offset", [0.0, 0.0, 0.0]), dtype=float)
            brace = Brace(
                POINT_FRAME, Surface(centre, normal), kind, region_radius=region, surface_radius=spec.surface_radius
            )
            braced = BracedRobot(point, brace)
            clearance = float(link_clearance(braced.state(q_ref))[0])
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                ev = evaluate_batch(braced, context.Q, context.beta, models=(model,), errors="nan", k_braced=True)
        except (BracekitError, ArithmeticError, np.linalg.LinAlgError) as exc:
            out.append(Screened(c.id, None, None, f"screening: {exc}"))
            continue
        kb = ev.k_braced if ev.k_braced is not None else np.array([np.nan])
        k = float(np.max(kb)) if np.all(np.isfinite(kb)) else math.inf
        out.append(
            Screened(
                c.id,
                float(np.mean(ev.Ci[model])),
                k if math.isfinite(k) else None,
                clearance=clearance if math.isfinite(clearance) else None,
            )
        )
    return out


def select(spec: SweepSpec, screened: list[Screened]) -> dict[str, str | None]:
    """Candidate id → None if it passes the screen of its task context, else the reason it does not."""
    s = spec.screening
    out: dict[str, str | None] = {}
    ok = []
    for r in screened:
        if r.failure is not None:
            out[r.candidate] = None  # simulated: the run says what fails
        elif r.clearance is not None and r.clearance < spec.feasibility.min_clearance:
            out[r.candidate] = (
                f"screened out: a link comes {r.clearance:.3g} m from the surface at the start "
                f"(< {spec.feasibility.min_clearance:g} m)"
            )
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
