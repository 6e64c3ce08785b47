"""The hot paths on the paper's robot, side by side in one process: the part "core" of ``bracekit bench``.

:func:`core_benchmarks` measures (interleaved rounds, medians):

* one braced gradient-projection step, joint values in and joint velocities out, with all four terms of
  eq:objective: the fused :class:`~bracekit.resolution.GradientProjectionStep` with the analytic gradient on both
  backends (NumPy, and numba when it is installed) and with the paper's central differences (same code,
  only the gradient differs), and the reference path (``BracedGradientProjection.velocity`` on
  ``braced.state(q)``) both ways;
* the numba backend's one-off costs, each in a fresh process: compiling the kernel with an empty cache
  (full runs only) and importing numba plus loading the compiled kernel from its disk cache;
* Pinocchio's own FK + Jacobian + kinematic Hessian of the tip frame: the floor of anything that calls it;
* Robotics Toolbox for Python's ``jacob0`` / ``hessian0`` on the same URDF chain, when it is installed
  (benchmarks/bench_rtb.py);
* batch evaluation of C_e, C_i and k on both backends (benchmarks/bench_batch.py);
* the fused step at another split (a link-point brace on link 4: n1 = 4, dq1/db̃ a null space) on both backends;
* the wall time of ``bracekit run paper --no-figures --quiet`` in a fresh process (start-up included).

Timings depend on the machine and its load; the ratios are the robust part. No timing is asserted anywhere.
"""

from __future__ import annotations

import dataclasses
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin

from bracekit.contact import Brace, Surface
from bracekit.errors import InputError
from bracekit.kinematics import LWA, BracedRobot
from bracekit.objective import Objective, RegionBarrier
from bracekit.resolution import GradientProjectionStep
from bracekit.simulation import Scenario, load_scenario

#: The speed targets of the hot paths.
TARGET_STEP_US = 100.0
TARGET_STEP_RATIO = 20.0
TARGET_SCENARIO_S = 5.0
TARGET_BATCH_PER_S = 1e5
TARGET_BATCH_NUMBA_PER_S = 6e5


def _per_call(fn: Callable[[], object], calls: int) -> list[float]:
    """Wall time of each of `calls` calls, seconds."""
    out = []
    clock = time.perf_counter
    for _ in range(calls):
        t = clock()
        fn()
        out.append(clock() - t)
    return out


def _interleaved(cases: dict[str, tuple[Callable[[], object], int]], rounds: int) -> dict[str, float]:
    """Median seconds per call of each case, its calls spread over `rounds` interleaved rounds."""
    samples: dict[str, list[float]] = {name: [] for name in cases}
    for fn, _ in cases.values():  # warm up
        fn()
    for _ in range(rounds):
        for name, (fn, calls) in cases.items():
            samples[name] += _per_call(fn, calls)
    return {name: float(np.median(s)) for name, s in samples.items()}


def _scenario_cli(sc: Scenario, runs: int) -> tuple[float, int, np.ndarray]:
    """Median wall time (s) of ``bracekit run paper --no-figures --quiet`` in a new process, its exit code,
    and the gradient-projection run's first configuration (from trajectories.npz, else solved)."""
    times, code, q = [], 0, None
    with tempfile.TemporaryDirectory(prefix="bracekit-bench-") as tmp:
        for i in range(runs):
            out = Path(tmp) / f"run{i}"
            cmd = [sys.executable, "-m", "bracekit", "run", "paper", "--no-figures", "--quiet", "--out", str(out)]
            t = time.perf_counter()
            proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
            times.append(time.perf_counter() - t)
            code = proc.returncode
            if q is None and (out / "trajectories.npz").is_file():
                with np.load(out / "trajectories.npz") as data:
                    key = f"{sc.compliance_model}/braced_gradient_projection/q"
                    q = np.array(data[key][0]) if key in data else None
    if q is None:
        from bracekit.simulation import solve_start

        q = solve_start(sc.braced, sc.task.position(0.0), sc.guess, rotation=sc.task.rotation).q
    return float(np.median(times)), code, q


def _pinocchio_floor(braced: BracedRobot, q: np.ndarray, calls: int, rounds: int) -> dict[str, float]:
    model = braced.robot.model
    data = model.createData()
    tip, bid = braced.robot.tip_id, braced.brace_id

    def one() -> None:
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        pin.getFrameJacobian(model, data, tip, LWA)
        pin.computeJointKinematicHessians(model, data)
        pin.getFrameKinematicHessian(model, data, tip, LWA)

    def two() -> None:
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        pin.getFrameJacobian(model, data, tip, LWA)
        pin.getFrameJacobian(model, data, bid, LWA)
        pin.computeJointKinematicHessians(model, data)
        pin.getFrameKinematicHessian(model, data, tip, LWA)
        pin.getFrameKinematicHessian(model, data, bid, LWA)

    def jac() -> None:
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        pin.getFrameJacobian(model, data, tip, LWA)

    t = _interleaved({"one": (one, calls), "two": (two, calls), "jac": (jac, calls)}, rounds)
    return {"tip": t["one"], "both": t["two"], "jacobian": t["jac"]}


_NUMBA_COLD = """
import json, sys, time
import numpy as np
from bracekit.resolution.fused import GradientProjectionStep
from bracekit.simulation.scenario import load_scenario
sc = load_scenario("paper")
strategy = sc.strategy("braced_gradient_projection")
q, xdot = np.array(json.loads(sys.argv[1])), np.array(json.loads(sys.argv[2]))
t0 = time.perf_counter()
step = GradientProjectionStep(sc.braced, strategy, backend="numba")
t1 = time.perf_counter()
step(q, xdot)
t2 = time.perf_counter()
st = step._kernel.stats
print(json.dumps({"import_s": t1 - t0, "first_call_s": t2 - t1, "cache_hits": sum(st.cache_hits.values()),
                  "cache_misses": sum(st.cache_misses.values())}))
"""


def _numba_backend(braced: BracedRobot, strategy: Any, q: np.ndarray, xdot: np.ndarray) -> dict[str, Any]:
    """The numba-backed step of this process ("step", None without numba) and its first call's cost."""
    t0 = time.perf_counter()
    try:
        step = GradientProjectionStep(braced, strategy, backend="numba")
    except InputError as exc:
        return {"step": None, "available": False, "reason": str(exc), "version": None}
    t1 = time.perf_counter()
    step(q, xdot)
    t2 = time.perf_counter()
    stats = step._kernel.stats
    import numba

    return {
        "step": step,
        "available": True,
        "version": numba.__version__,
        "kernel_used": step.uses_kernel,
        "import_s": t1 - t0,  # ~0 if numba was already imported in this process
        "first_call_s": t2 - t1,
        "first_call_compiled": sum(stats.cache_misses.values()) > 0,
        "cache_dir": stats.cache_path,
    }


def _numba_cold(q: np.ndarray, xdot: np.ndarray, empty_cache: bool) -> dict[str, Any]:
    """A fresh process: import numba and the kernels, then the first numba step (cache load or compilation).

    ``empty_cache`` points numba at a new cache directory (NUMBA_CACHE_DIR), so the kernel compiles from
    scratch without touching the real cache; otherwise the usual cache is used (warm after this process's
    own first call).
    """
    with tempfile.TemporaryDirectory(prefix="bracekit-numba-") as tmp:
        env = dict(os.environ)
        if empty_cache:
            env["NUMBA_CACHE_DIR"] = tmp
        cmd = [sys.executable, "-c", _NUMBA_COLD, json.dumps(q.tolist()), json.dumps(xdot.tolist())]
        t = time.perf_counter()
        proc = subprocess.run(cmd, capture_output=True, text=True, check=False, env=env)
        wall = time.perf_counter() - t
    if proc.returncode != 0:
        return {"ok": False, "reason": (proc.stderr.strip().splitlines() or ["?"])[-1]}
    return {"ok": True, "process_wall_s": wall, **json.loads(proc.stdout.strip().splitlines()[-1])}


def _split_step(sc: Scenario, q: np.ndarray, xdot: np.ndarray, calls: int, rounds: int) -> dict[str, Any]:
    """The fused step with a link-point brace on link 4 (n1 = 4) of the paper's robot, both backends.

    The scenario's objective, with the bracing region centred on {b} at q (radius 1 m) and a pad direction.
    """
    robot = sc.robot.with_point_frame("pad4", "link4", (0.03, 0.02, 0.0))
    probe = BracedRobot(robot, Brace("pad4", Surface(np.zeros(3), (0.0, 0.0, 1.0))))
    b = probe.frame_placements(q).b_i[0]
    braced = BracedRobot(robot, Brace("pad4", Surface(b, (0.0, 0.0, 1.0)), region_radius=1.0, pad_axis=True))
    base = sc.strategy("braced_gradient_projection", gradient="analytic")
    objective = base.objective  # type: ignore[attr-defined]
    terms = [RegionBarrier(1.0, b) if isinstance(t, RegionBarrier) else t for t in objective.terms]
    strategy = dataclasses.replace(base, objective=Objective(terms, objective.weights))  # type: ignore[type-var]
    npb = GradientProjectionStep(braced, strategy, backend="numpy")  # type: ignore[arg-type]
    ref_q = strategy.velocity(braced.state(q, hessians=True), xdot)  # type: ignore[attr-defined]
    out: dict[str, Any] = {"n1": braced.split.n1, "numba_us": None, "kernel_used": False, "max_rel_diff_numba": None}
    cases = {"numpy": (lambda: npb(q, xdot), calls)}
    try:
        nbs = GradientProjectionStep(braced, strategy, backend="numba")  # type: ignore[arg-type]
    except InputError as exc:
        out["reason"] = str(exc)
    else:
        kernel = nbs._numba_step(q, xdot, None)
        out["kernel_used"] = kernel is not None
        out["fallback_reason"] = nbs.fallback_reason
        out["max_rel_diff_numba"] = float(np.max(np.abs(nbs(q, xdot) - ref_q)) / np.max(np.abs(ref_q)))
        cases["numba"] = (lambda: nbs(q, xdot), calls)
    t = _interleaved(cases, rounds)
    out["numpy_us"] = 1e6 * t["numpy"]
    out["max_rel_diff_numpy"] = float(np.max(np.abs(npb(q, xdot) - ref_q)) / np.max(np.abs(ref_q)))
    if "numba" in t:
        out["numba_us"] = 1e6 * t["numba"]
    return out


def core_benchmarks(quick: bool = False) -> dict[str, Any]:
    """The measurements of the part "core" (keys in :func:`bench.run_benchmarks`), without the table."""
    from bench_batch import batch_benchmarks
    from bench_rtb import rtb_benchmarks

    rounds = 3 if quick else 15
    wall0 = time.perf_counter()
    sc = load_scenario("paper")
    scenario_s, code, q = _scenario_cli(sc, 1 if quick else 3)
    braced = sc.braced
    beta = sc.beta_x(0.0)
    xdot = np.concatenate([sc.task.velocity(0.0), np.zeros(3)])

    strategies = {
        g: sc.strategy("braced_gradient_projection", gradient=g)  # type: ignore[arg-type]
        for g in ("analytic", "finite-difference")
    }
    fast = GradientProjectionStep(braced, strategies["analytic"], backend="numpy")  # type: ignore[arg-type]
    fast_fd = GradientProjectionStep(braced, strategies["finite-difference"])  # type: ignore[arg-type]
    ref, ref_fd = strategies["analytic"], strategies["finite-difference"]
    numba = _numba_backend(braced, strategies["analytic"], q, xdot)  # type: ignore[arg-type]
    fast_nb = numba.pop("step")

    def ref_step() -> np.ndarray:
        return ref.velocity(braced.state(q, hessians=True), xdot)

    def ref_fd_step() -> np.ndarray:
        return ref_fd.velocity(braced.state(q), xdot)

    ref_q = ref_step()
    step_diff = float(np.max(np.abs(fast(q, xdot) - ref_q)) / np.max(np.abs(ref_q)))
    nb_diff = None if fast_nb is None else float(np.max(np.abs(fast_nb(q, xdot) - ref_q)) / np.max(np.abs(ref_q)))
    n_fast = 60 if quick else 400
    tiny = np.ones(6)

    def twenty_ops() -> None:  # how fast this machine is right now, measured alongside the steps
        for _ in range(20):
            tiny * 2.0

    cases = {
        "ops20": (twenty_ops, n_fast),
        "fast": (lambda: fast(q, xdot), n_fast),
        "fast_fd": (lambda: fast_fd(q, xdot), max(2, n_fast // 20)),
        "ref": (ref_step, max(2, n_fast // 8)),
        "ref_fd": (ref_fd_step, max(1, n_fast // 80)),
    }
    if fast_nb is not None:
        cases["fast_nb"] = (lambda: fast_nb(q, xdot), n_fast)
    t = _interleaved(cases, rounds)
    op = t["ops20"] / 20.0
    best = min(t["fast"], t.get("fast_nb", np.inf))
    if fast_nb is not None:  # one-off costs, each in a fresh process
        numba["warm"] = _numba_cold(q, xdot, empty_cache=False)
        numba["empty_cache"] = None if quick else _numba_cold(q, xdot, empty_cache=True)
    floor = _pinocchio_floor(braced, q, 100 if quick else 1000, rounds)
    rtb = rtb_benchmarks(braced, q, 20 if quick else 200, rounds)
    batch = batch_benchmarks(braced, beta, 50_000 if quick else 400_000, 3 if quick else 7, quick)
    split = _split_step(sc, q, xdot, n_fast, rounds)
    one_model_s = None
    if not quick:
        from bracekit.simulation import run_scenario

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            t0 = time.perf_counter()
            run_scenario(sc, both_models=False)
            one_model_s = time.perf_counter() - t0

    nb_us = 1e6 * t["fast_nb"] if "fast_nb" in t else None
    warm, cold = numba.get("warm") or {}, numba.get("empty_cache") or {}
    res: dict[str, Any] = {
        "gp_step_analytic_us": 1e6 * best,
        "gp_step_analytic_backend": "numba" if "fast_nb" in t and t["fast_nb"] < t["fast"] else "numpy",
        "gp_step_analytic_numpy_us": 1e6 * t["fast"],
        "gp_step_analytic_numba_us": nb_us,
        "gp_step_fd_us": 1e6 * t["fast_fd"],
        "gp_step_fd_ratio": t["fast_fd"] / best,
        "gp_step_fd_ratio_numpy": t["fast_fd"] / t["fast"],
        "gp_step_fd_ratio_numba": t["fast_fd"] / t["fast_nb"] if "fast_nb" in t else None,
        "gp_step_analytic_reference_us": 1e6 * t["ref"],
        "gp_step_fd_reference_us": 1e6 * t["ref_fd"],
        "gp_step_fd_reference_ratio": t["ref_fd"] / best,
        "gp_step_max_rel_diff": step_diff if nb_diff is None else max(step_diff, nb_diff),
        "gp_step_max_rel_diff_numpy": step_diff,
        "gp_step_max_rel_diff_numba": nb_diff,
        "numba": numba,
        "numba_first_call_s": numba.get("first_call_s"),
        "numba_compile_s": cold.get("first_call_s")
        if cold.get("cache_misses")
        else (numba["first_call_s"] if numba.get("first_call_compiled") else None),
        "numba_import_s": warm.get("import_s"),
        "numba_cache_load_s": warm.get("first_call_s") if warm.get("cache_hits") else None,
        "numba_import_and_cache_load_s": warm["import_s"] + warm["first_call_s"] if warm.get("cache_hits") else None,
        "pinocchio_floor_us": 1e6 * floor["tip"],
        "pinocchio_two_frames_us": 1e6 * floor["both"],
        "pinocchio_jacobian_us": 1e6 * floor["jacobian"],
        "numpy_op_us": 1e6 * op,
        "gp_step_analytic_in_numpy_ops": best / op,
        "gp_step_analytic_numpy_in_numpy_ops": t["fast"] / op,
        "rtb": rtb,
        "batch_configs_per_s": batch["configs_per_s"],
        "batch_backend": batch["backend"],
        "batch_numba_configs_per_s": batch["numba_configs_per_s"],
        "batch_numba_1thread_configs_per_s": batch["numba_1thread_configs_per_s"],
        "batch_numba_1thread_cpu_configs_per_s": batch["numba_1thread_cpu_configs_per_s"],
        "batch_numpy_configs_per_s": batch["numpy_configs_per_s"],
        "batch_numba_first_call_s": batch["numba_first_call"].get("first_call_s"),
        "batch_numba_compile_s": batch["numba_compile_s"],
        "batch": batch,
        "gp_step_split_n1": split["n1"],
        "gp_step_split_numpy_us": split["numpy_us"],
        "gp_step_split_numba_us": split["numba_us"],
        "gp_step_split": split,
        "scenario_wall_s": scenario_s,
        "scenario_exit_code": code,
        "scenario_one_model_in_process_s": one_model_s,
        "quick": quick,
        "environment": {
            "python": platform.python_version(),
            "numpy": np.__version__,
            "pinocchio": pin.__version__,
            "numba": numba.get("version"),
            "cpus": os.cpu_count(),
            "load_average": list(os.getloadavg()) if hasattr(os, "getloadavg") else None,
            "machine": platform.machine(),
        },
        "benchmark_wall_s": time.perf_counter() - wall0,
    }
    res["targets_met"] = {
        f"gp step ≤ {TARGET_STEP_US:g} µs ({res['gp_step_analytic_backend']} backend)": res["gp_step_analytic_us"]
        <= TARGET_STEP_US,
        f"gp step ≥ {TARGET_STEP_RATIO:g}× faster than the same fused step with FD": res["gp_step_fd_ratio"]
        >= TARGET_STEP_RATIO,
        f"gp step ≥ {TARGET_STEP_RATIO:g}× faster than the reference FD step": res["gp_step_fd_reference_ratio"]
        >= TARGET_STEP_RATIO,
        f"scenario ≤ {TARGET_SCENARIO_S:g} s": scenario_s <= TARGET_SCENARIO_S,
        f"batch ≥ {TARGET_BATCH_PER_S:.0e} configs/s": res["batch_configs_per_s"] >= TARGET_BATCH_PER_S,
    }
    if res["batch_numba_configs_per_s"] is not None:
        res["targets_met"][f"batch (numba) ≥ {TARGET_BATCH_NUMBA_PER_S:.0e} configs/s"] = (
            res["batch_numba_configs_per_s"] >= TARGET_BATCH_NUMBA_PER_S
        )
    return res
