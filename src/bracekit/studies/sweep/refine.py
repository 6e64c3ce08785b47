"""Refinement: the best feasible candidates' fraction along their link, optimised by a bounded scalar search.

For each of the ``refine.top`` best feasible candidates (lowest mean C_i of gradient projection), SciPy's
bounded Brent search (``minimize_scalar(method="bounded")``) varies the fraction between the neighbouring grid
values (±0.1 with random sampling), every evaluation a whole-task run of gradient projection
(:func:`.evaluate.evaluate_candidate`).
The objective is the mean C_i of gradient projection; an infeasible evaluation counts as PENALTY. The best
feasible evaluation is reported (the grid candidate itself if none is better).
"""

from __future__ import annotations

import hashlib
import json
import threading
from collections.abc import Callable
from concurrent.futures import CancelledError
from typing import Any

from bracekit.studies.sweep.candidates import Candidate, candidate_id
from bracekit.studies.sweep.context import TaskContext
from bracekit.studies.sweep.evaluate import SEARCH_STRATEGIES, evaluate_candidate, finite
from bracekit.studies.sweep.spec import SweepSpec
from bracekit.studies.sweep.store import RowStore

#: The objective of an infeasible evaluation (m/N): far above any mean C_i of a braced run.
PENALTY = 1.0
#: Half-width of the search interval with random sampling (fraction of the link).
RANDOM_HALF_WIDTH = 0.1


def usable(row: dict[str, Any]) -> bool:
    """Whether a row is feasible with a finite mean C_i of gradient projection (a value to minimise)."""
    return bool(row.get("feasible")) and finite(row.get("Ci_mean_gp"))


def interval(spec: SweepSpec, fraction: float) -> tuple[float, float]:
    """The search interval of a candidate at `fraction`: between its neighbours on the fraction grid."""
    axis = spec.axis("fraction")
    if spec.mode == "random" or axis is None:
        return max(0.0, fraction - RANDOM_HALF_WIDTH), min(1.0, fraction + RANDOM_HALF_WIDTH)
    grid = sorted(axis.grid())
    lower = [g for g in grid if g < fraction]
    upper = [g for g in grid if g > fraction]
    return (lower[-1] if lower else 0.0), (upper[0] if upper else 1.0)


def refine_candidate(
    spec: SweepSpec,
    candidate: Candidate,
    context: TaskContext | None,
    low: float,
    high: float,
    evaluate: Callable[[Candidate], dict[str, Any]] | None = None,
) -> dict[str, Any]:
    """Search the fraction in [low, high] for the candidate's link; return the best feasible evaluation.

    `evaluate`: a candidate's row, :func:`.evaluate.evaluate_candidate` of `context` with gradient projection's
    run only (the default, in this process: the search reads nothing of minimum norm's) or the same call on a
    Dask worker (:func:`refine_best`).
    """
    from scipy.optimize import minimize_scalar

    evaluations: list[dict[str, Any]] = []

    def objective(x: float) -> float:
        inputs = dict(candidate.inputs) | {"fraction": float(x)}
        c = Candidate(-1, candidate_id(inputs), inputs)
        if evaluate is None:
            row = evaluate_candidate(spec, c, context, SEARCH_STRATEGIES)  # type: ignore[arg-type]
        else:
            row = evaluate(c)
        evaluations.append(row)
        return float(row["Ci_mean_gp"]) if usable(row) else PENALTY

    r = spec.refinement
    minimize_scalar(
        objective, bounds=(low, high), method="bounded", options={"xatol": r.xatol, "maxiter": r.max_evaluations}
    )
    feasible = [e for e in evaluations if usable(e)]
    best = min(feasible, key=lambda e: (e["Ci_mean_gp"], e["fraction"])) if feasible else None
    return {
        "candidate": candidate.id,
        "link": candidate.inputs["link"],
        "fraction": candidate.inputs["fraction"],
        "interval": [low, high],
        "evaluations": len(evaluations),
        "refined_fraction": None if best is None else best["fraction"],
        "refined_Ci_mean_gp": None if best is None else best["Ci_mean_gp"],
        "refined_k_mean_gp": None if best is None else best["k_mean_gp"],
        "refined_point": None if best is None else [best["point_x"], best["point_y"], best["point_z"]],
    }


def refinement_key(spec: SweepSpec, candidate: Candidate, low: float, high: float) -> str:
    """The key a refinement is saved under: the candidate, the search settings and the feasibility bounds."""
    f = spec.feasibility
    bounds = [f.k_max, f.min_clearance, f.joint_limit_tolerance, f.min_margin]
    text = json.dumps([low, high, spec.refinement.max_evaluations, spec.refinement.xatol, bounds])
    return f"{candidate.id}-{hashlib.sha256(text.encode()).hexdigest()[:8]}"


def refine_best(
    spec: SweepSpec,
    rows: list[dict[str, Any]],
    candidates: list[Candidate],
    contexts: dict[str, Any],
    client: Any,
    store: RowStore,
    futures: list[Any],
    *,
    shared_spec: Any = None,
) -> list[dict[str, Any]]:
    """Refine the best feasible rows on the Dask client (saved refinements are reused); in rank order.

    Each refinement's search runs in a thread of this process, each of its evaluations a task on the cluster
    (`contexts`: the task contexts' futures; `shared_spec`: the spec scattered to the workers, else `spec`), so
    the searches share the workers evaluation by evaluation: three searches on two workers keep both busy. The
    evaluations and their order within a search are those of :func:`refine_candidate` in one process.
    """
    from concurrent.futures import ThreadPoolExecutor

    by_id = {c.id: c for c in candidates}
    feasible = [r for r in rows if usable(r)]
    best = sorted(feasible, key=lambda r: (r["Ci_mean_gp"], r["index"]))[: spec.refinement.top]
    saved = store.refined()
    on_workers = spec if shared_spec is None else shared_spec
    stop = threading.Event()
    # Held by a search around its stop check and its submit, and by the interrupt around the stop and the
    # cancel: no evaluation is submitted after the stop, and every evaluation submitted is cancelled.
    submitting = threading.Lock()

    def search(c: Candidate, low: float, high: float) -> dict[str, Any]:
        context = contexts[c.context_key]

        def remote(cand: Candidate) -> dict[str, Any]:
            with submitting:
                if stop.is_set():  # interrupted: no new evaluation
                    raise CancelledError
                fut = client.submit(evaluate_candidate, on_workers, cand, context, SEARCH_STRATEGIES, pure=False)
                futures.append(fut)
            return fut.result()  # type: ignore[no-any-return]

        return refine_candidate(spec, c, None, low, high, evaluate=remote)

    out: list[Any] = []
    with ThreadPoolExecutor(max_workers=max(1, len(best)), thread_name_prefix="bracekit-refine") as pool:
        try:
            for row in best:
                c = by_id[row["candidate"]]
                low, high = interval(spec, float(c.inputs["fraction"]))
                key = refinement_key(spec, c, low, high)
                if key in saved:
                    out.append(saved[key])
                    continue
                out.append((key, pool.submit(search, c, low, high), row))
            result = [item if not isinstance(item, tuple) else _settled(store, *item) for item in out]
        except BaseException:
            with submitting:  # a search between its check and its submit has submitted: cancelled below
                stop.set()
                client.cancel(futures)  # the searches' waits end with the evaluations cancelled
            pool.shutdown(wait=False, cancel_futures=True)
            raise
    return result


def _settled(store: RowStore, key: str, search: Any, row: dict[str, Any]) -> dict[str, Any]:
    """A finished search's refinement (the grid candidate's values when no evaluation beat it), saved."""
    data: dict[str, Any] = search.result() | {"grid_Ci_mean_gp": row["Ci_mean_gp"]}
    better = data["refined_Ci_mean_gp"] is not None and data["refined_Ci_mean_gp"] < row["Ci_mean_gp"]
    data["improved"] = better
    if not better:  # the grid candidate stays the best
        data |= {
            "refined_fraction": row["fraction"],
            "refined_Ci_mean_gp": row["Ci_mean_gp"],
            "refined_k_mean_gp": row["k_mean_gp"],
            "refined_point": [row["point_x"], row["point_y"], row["point_z"]],
        }
    store.save_refined(key, data)
    return data
