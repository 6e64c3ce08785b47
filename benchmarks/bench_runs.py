"""Whole runs, a sweep and the step, through bracekit's stable entry points only, so two versions compare fairly.

Every call here exists unchanged in every version since the speed baseline (``run_scenario``,
``load_scenario``, ``bracekit.resolution.GradientProjectionStep``, the ``bracekit`` command line and Dask's own
``LocalCluster``): ``bracekit bench`` and tools/bench_baseline.py (which runs this module against an older
checkout) make the same calls, so the ratios of :mod:`bench_compare` are new/old of the same work. A call a
version no longer has is reported by name (``*_failed``) and the rest still run. Timings depend on the machine and
its load: every result carries :func:`machine`.

* ``run_paper_s``, ``run_two_braces_s``, ``run_panda_s``: median wall time of ``run_scenario(NAME)`` in this
  process (the default call: every strategy, and for one brace gradient projection under both compliance
  models; no figures), after one warm-up call (imports, numba's kernels loaded or compiled), and the process's
  CPU seconds of the same calls (``run_paper_cpu_s`` …: what other load on the machine changes least);
* ``sweep_candidates_per_s_1`` and ``_2``: ``bracekit sweep paper-links --limit N --no-screen --no-refine
  --no-figures`` in this process against a local Dask cluster of 1, then 2 worker processes (one thread each),
  started and warmed (every worker runs the ``paper`` scenario once) before the clock starts; and where its time
  went: ``sweep_candidate_s_1`` and ``_2`` (a candidate's mean seconds on a worker) and ``sweep_fixed_s_1`` and
  ``_2`` (the rest of the command's time);
* ``step_gp_us``: one braced gradient-projection step (``GradientProjectionStep`` of the ``paper`` scenario's
  strategy, numba backend when installed), joint values in and joint velocities out;
* ``pinocchio_floor_us``: Pinocchio's FK + Jacobian + kinematic Hessian of the tip frame (and
  ``pinocchio_floor_two_frames_us``: tip and brace frames), the floor of any step.
"""

from __future__ import annotations

import datetime
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

#: The scenarios of the whole-run measurements (shipped names) and their result keys.
SCENARIOS = {"paper": "run_paper_s", "two-braces": "run_two_braces_s", "panda": "run_panda_s"}
#: What a local sweep worker runs with (as ``bracekit sweep --workers N`` does): one thread for numba and BLAS.
WORKER_ENV = {"NUMBA_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
#: Warms a worker: imports bracekit and loads (or compiles) its numba kernels with one short run.
_WARM_WORKER = "from bracekit import run_scenario\nrun_scenario('paper', both_models=False)"


def _cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text(encoding="utf-8").splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def _commit(path: Path) -> str | None:
    """The git commit checked out at `path` (a work tree), with "+dirty" when it has uncommitted changes."""
    try:
        head = subprocess.run(
            ["git", "-C", str(path), "rev-parse", "HEAD"], capture_output=True, text=True, check=True
        ).stdout.strip()
        dirty = subprocess.run(
            ["git", "-C", str(path), "status", "--porcelain", "--untracked-files=no"],
            capture_output=True,
            text=True,
            check=True,
        ).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return None
    return head + ("+dirty" if dirty else "")


def machine() -> dict[str, Any]:
    """Where and when: cores, load averages (1, 5, 15 min), CPU model, UTC date, versions, bracekit's commit."""
    import numpy as np
    import pinocchio as pin

    import bracekit

    try:
        import numba

        numba_version: str | None = numba.__version__
    except ImportError:
        numba_version = None
    source = Path(bracekit.__file__).resolve().parent
    return {
        "cores": os.cpu_count(),
        "load_average": [round(x, 2) for x in os.getloadavg()] if hasattr(os, "getloadavg") else None,
        "cpu_model": _cpu_model(),
        "date_utc": datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "platform": platform.platform(),
        "python": platform.python_version(),
        "numpy": np.__version__,
        "pinocchio": pin.__version__,
        "numba": numba_version,
        "bracekit_version": getattr(bracekit, "__version__", None),
        "bracekit_path": str(source),
        "commit": _commit(source),
    }


def _median_of(fn: Callable[[], object], rounds: int) -> tuple[float, list[float]]:
    times = []
    for _ in range(rounds):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times), times


def scenario_runs(rounds: int = 3, names: tuple[str, ...] = tuple(SCENARIOS)) -> dict[str, Any]:
    """Median seconds of ``run_scenario(name)`` for each shipped scenario, interleaved rounds after a warm-up."""
    from bracekit import run_scenario

    samples: dict[str, list[float]] = {name: [] for name in names}
    cpu: dict[str, list[float]] = {name: [] for name in names}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for name in names:  # warm-up: imports, numba kernels, caches of the process
            run_scenario(name)
        for _ in range(rounds):
            for name in names:
                c, t = time.process_time(), time.perf_counter()
                run_scenario(name)
                samples[name].append(time.perf_counter() - t)
                cpu[name].append(time.process_time() - c)
    out: dict[str, Any] = {SCENARIOS[name]: statistics.median(samples[name]) for name in names}
    # CPU seconds of the process: what other load on the machine changes least
    out.update({SCENARIOS[name].removesuffix("_s") + "_cpu_s": statistics.median(cpu[name]) for name in names})
    out["run_samples_s"] = samples
    return out


#: The scenarios of the per-step comparison: one brace, then several (their result-key stems).
PER_STEP = {"paper": "run_step_one_brace_us", "two-braces": "run_step_two_braces_us"}


def per_step_runs(rounds: int = 3) -> dict[str, Any]:
    """µs per step of a gradient-projection run of ``paper`` (one brace) and of ``two-braces`` (two), and their ratio.

    ``run_scenario`` of the scenario with its braced gradient-projection strategy only (one compliance model),
    divided by the run's steps (samples − 1): the whole step of a run, correction, guards and measures included.
    ``run_step_braces_ratio`` is two-braces over paper (goal ≤ 2: a several-brace run no slower per step than
    twice a one-brace run). Interleaved rounds after a warm-up, medians.
    """
    import dataclasses

    from bracekit import load_scenario, run_scenario

    out: dict[str, Any] = {}
    try:
        cases = {
            name: dataclasses.replace(load_scenario(name), strategies=("braced_gradient_projection",))
            for name in PER_STEP
        }
    except Exception as exc:  # a version whose Scenario has no strategies field: said, not hidden
        return {"run_step_failed": f"{type(exc).__name__}: {exc}"}
    samples: dict[str, list[float]] = {name: [] for name in cases}
    steps: dict[str, int] = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for name, sc in cases.items():  # warm-up, and the steps of each run
            result = run_scenario(sc, both_models=False)
            (traj,) = (t for runs in result.trajectories.values() for t in runs.values())
            steps[name] = max(1, len(traj.t) - 1)
        for _ in range(rounds):
            for name, sc in cases.items():
                t = time.perf_counter()
                run_scenario(sc, both_models=False)
                samples[name].append(time.perf_counter() - t)
    for name, key in PER_STEP.items():
        out[key] = 1e6 * statistics.median(samples[name]) / steps[name]
    out["run_step_braces_ratio"] = out["run_step_two_braces_us"] / out["run_step_one_brace_us"]
    return out


def _sweep_split(out: Path, workers: int, candidates: int, elapsed: float) -> dict[str, float]:
    """Where a sweep's time went, from its summary.json: a candidate's mean seconds on a worker, and the rest.

    ``candidate_s``: the mean wall time of a candidate's evaluation on its worker (the rows' ``wall_s``);
    ``fixed_s``: the command's time beyond its candidates' share of the workers (elapsed − candidates ×
    candidate_s / workers): the command's own work, the task contexts, Dask's round trips, the writes and the
    workers' uneven ends. Empty when this version's summary does not say.
    """
    import json

    try:
        summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
        per = float(summary["screening"]["mean_simulation_wall_s"])
    except (OSError, ValueError, KeyError, TypeError):
        return {}
    return {"candidate_s": per, "fixed_s": elapsed - candidates * per / workers}


def _sweep_once(workers: int, candidates: int) -> tuple[float, float, dict[str, float]]:
    """(candidates per second, cluster start-up and warm-up s, :func:`_sweep_split`) of one ``bracekit sweep``.

    On a new local cluster of `workers` processes."""
    import logging

    from distributed import Client, LocalCluster

    from bracekit.cli import main

    began = time.perf_counter()
    cluster = LocalCluster(
        n_workers=workers,
        threads_per_worker=1,
        processes=True,
        host="127.0.0.1",
        dashboard_address=None,
        scheduler_kwargs={"dashboard_address": ":0"},
        silence_logs=logging.ERROR,
        env=WORKER_ENV,
    )
    try:
        with Client(cluster) as client, tempfile.TemporaryDirectory(prefix="bracekit-bench-sweep-") as tmp:
            client.run(exec, _WARM_WORKER)
            address = cluster.scheduler_address
            ready = time.perf_counter()
            argv = ["sweep", "paper-links", "--out", str(Path(tmp) / "sweep"), "--scheduler", address]
            argv += ["--limit", str(candidates), "--no-screen", "--no-refine", "--no-figures", "--quiet"]
            with open(os.devnull, "w") as sink:
                saved = sys.stdout
                sys.stdout = sink
                try:
                    code = main(argv)
                finally:
                    sys.stdout = saved
            elapsed = time.perf_counter() - ready
            split = _sweep_split(Path(tmp) / "sweep", workers, candidates, elapsed) if code == 0 else {}
    finally:
        cluster.close()
    if code != 0:
        raise RuntimeError(f"bracekit {' '.join(argv)} exited with {code}")
    return candidates / elapsed, ready - began, split


def sweep_runs(candidates: int = 16, rounds: int = 1) -> dict[str, Any]:
    """Candidates per second of ``bracekit sweep`` on 1 then 2 local workers (medians of `rounds`), and scaling.

    With where the time went (:func:`_sweep_split`): ``sweep_candidate_s_N``, a candidate's mean seconds on a
    worker, and ``sweep_fixed_s_N``, the rest of the command's time, when the version's summary says.
    """
    import importlib.util

    missing = [m for m in ("distributed", "pyarrow") if importlib.util.find_spec(m) is None]
    if missing:
        return {"sweep_skipped": f"{', '.join(missing)} not installed: pip install 'bracekit[sweep]'"}
    out: dict[str, Any] = {"sweep_candidates": candidates}
    for workers in (1, 2):
        rates, starts = [], []
        splits: dict[str, list[float]] = {}
        for _ in range(rounds):
            rate, start, split = _sweep_once(workers, candidates)
            rates.append(rate)
            starts.append(start)
            for key, value in split.items():
                splits.setdefault(key, []).append(value)
        out[f"sweep_candidates_per_s_{workers}"] = statistics.median(rates)
        out[f"sweep_cluster_start_s_{workers}"] = statistics.median(starts)
        out.update({f"sweep_{key}_{workers}": statistics.median(values) for key, values in splits.items()})
    out["sweep_scaling_1_to_2"] = out["sweep_candidates_per_s_2"] / out["sweep_candidates_per_s_1"]
    return out


def floor_call(braced: Any, q: Any, frames: tuple[int, ...]) -> Callable[[], None]:
    """Pinocchio's FK + Jacobians + kinematic Hessians of `frames` (Pinocchio frame ids) at `q`: a step's floor."""
    import pinocchio as pin

    model = braced.robot.model
    data = model.createData()
    lwa = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED

    def call() -> None:
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        for f in frames:
            pin.getFrameJacobian(model, data, f, lwa)
        pin.computeJointKinematicHessians(model, data)
        for f in frames:
            pin.getFrameKinematicHessian(model, data, f, lwa)

    return call


def _interleaved(cases: dict[str, Callable[[], object]], calls: dict[str, int], rounds: int) -> dict[str, float]:
    """Median seconds of one call of each case, over `rounds` interleaved rounds of `calls[case]` calls each.

    Every call is timed on its own and the median taken (as the part "core" does): a call the operating system
    pre-empted is an outlier, not an average's share, so a loaded machine changes the result little. Every case
    runs in each round, so all see the same load; one warm-up call each first.
    """
    for fn in cases.values():
        fn()
    clock = time.perf_counter
    samples: dict[str, list[float]] = {key: [] for key in cases}
    for _ in range(rounds):
        for key, fn in cases.items():
            out = samples[key]
            for _ in range(calls[key]):
                t = clock()
                fn()
                out.append(clock() - t)
    return {key: statistics.median(s) for key, s in samples.items()}


def _gp_step(sc: Any) -> tuple[Callable[[Any, Any], Any], str]:
    """The paper scenario's gradient-projection step, numba backend when installed; and the backend's name."""
    from bracekit.resolution import GradientProjectionStep

    strategy = sc.strategy("braced_gradient_projection")
    try:
        return GradientProjectionStep(sc.braced, strategy, backend="numba"), "numba"
    except Exception:  # numba missing: the NumPy backend
        return GradientProjectionStep(sc.braced, strategy, backend="numpy"), "numpy"


def _control_step(sc: Any) -> Callable[[Any, Any], Any] | None:
    """The control-rate step of a version that has one (q and the task twist in, q̇ with the brace kept out).

    ``ControlStep(braced, strategy)`` exported by bracekit or its resolution package, called as ``step(q, xdot)``
    like ``GradientProjectionStep``; None when this version has none. The one place to adapt when that changes.
    """
    import bracekit
    import bracekit.resolution

    factory = getattr(bracekit, "ControlStep", None) or getattr(bracekit.resolution, "ControlStep", None)
    if factory is None:
        return None
    return factory(sc.braced, sc.strategy("braced_gradient_projection"))  # type: ignore[no-any-return]


def _frames(braced: Any) -> tuple[int, tuple[int, ...]]:
    """Pinocchio frame ids of the tip and of every brace's {b}."""
    ids = getattr(braced, "brace_ids", None)
    if ids is None:
        ids = (braced.brace_id,)
    return braced.robot.tip_id, tuple(ids)


def _start(sc: Any) -> tuple[Any, Any]:
    """The start guess and the task twist at t = 0 of a scenario."""
    import numpy as np

    q = np.asarray(sc.guess, dtype=float)
    v = np.asarray(sc.task.velocity(0.0), dtype=float)
    return q, (np.concatenate([v, np.zeros(3)]) if v.size == 3 else v)


def step_runs(calls: int = 2000, rounds: int = 7) -> dict[str, Any]:
    """The steps of ``paper`` (and ``two-braces``) and Pinocchio's floors at the scenarios' start guesses, µs.

    ``pinocchio_floor_us``: the tip frame of the paper robot; ``pinocchio_floor_two_frames_us``: its tip and
    brace frames; ``pinocchio_floor_two_braces_us``: the tip and both brace frames of ``two-braces``.
    ``step_gp_us``: ``GradientProjectionStep``; ``control_step_us`` and ``control_step_two_braces_us``: the
    control-rate step, when the version has one. A step that fails says why (``*_failed``), the others run.
    """
    from bracekit import load_scenario

    one, two = load_scenario("paper"), load_scenario("two-braces")
    out: dict[str, Any] = {}
    cases: dict[str, Callable[[], object]] = {}
    q, xdot = _start(one)
    q2, xdot2 = _start(two)
    try:
        tip, braces = _frames(one.braced)
        tip2, braces2 = _frames(two.braced)
        cases["pinocchio_floor_us"] = floor_call(one.braced, q, (tip,))
        cases["pinocchio_floor_two_frames_us"] = floor_call(one.braced, q, (tip, *braces))
        cases["pinocchio_floor_two_braces_us"] = floor_call(two.braced, q2, (tip2, *braces2))
    except Exception as exc:  # the robot's frames are reached another way in this version: said, not hidden
        out["pinocchio_floor_failed"] = f"{type(exc).__name__}: {exc}"
    try:
        gp, out["step_gp_backend"] = _gp_step(one)
        cases["step_gp_us"] = lambda: gp(q, xdot)
    except Exception as exc:  # an API this version changed: said, not hidden
        out["step_gp_failed"] = f"{type(exc).__name__}: {exc}"
    for key, sc, qq, xd in (("control_step_us", one, q, xdot), ("control_step_two_braces_us", two, q2, xdot2)):
        try:
            step = _control_step(sc)
        except Exception as exc:
            out[key.replace("_us", "_failed")] = f"{type(exc).__name__}: {exc}"
            continue
        if step is None:
            out["control_step_skipped"] = "this version exports no ControlStep"
            break
        cases[key] = lambda step=step, qq=qq, xd=xd: step(qq, xd)
    counts = {key: calls if key.startswith("pinocchio") else max(1, calls // 4) for key in cases}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        out.update({key: 1e6 * t for key, t in _interleaved(cases, counts, rounds).items()})
    if "pinocchio_floor_us" not in out:
        return out
    for key in ("step_gp_us", "control_step_us"):
        if key in out:
            out[key.replace("_us", "_in_floors")] = out[key] / out["pinocchio_floor_us"]
    if "control_step_two_braces_us" in out:
        out["control_step_two_braces_in_floors"] = (
            out["control_step_two_braces_us"] / out["pinocchio_floor_two_braces_us"]
        )
    return out


def whole_runs(
    quick: bool = False, sweep: bool = True, scenarios: tuple[str, ...] = tuple(SCENARIOS)
) -> dict[str, Any]:
    """Every measurement of this module, the machine before and after (its load may change meanwhile)."""
    before = machine()
    res: dict[str, Any] = {}
    res.update(step_runs(calls=400 if quick else 2000, rounds=3 if quick else 7))
    res.update(scenario_runs(rounds=1 if quick else 5, names=scenarios))
    res.update(per_step_runs(rounds=1 if quick else 3))
    if sweep:
        res.update(sweep_runs(candidates=4 if quick else 16))
    after = machine()
    before["load_average_after"] = after["load_average"]
    res["machine"] = before
    return res
