"""Speed of the hot paths on the paper's robot, for ``bracekit bench`` and ``benchmarks/run.py``.

:func:`run_benchmarks` measures, in one process and side by side (interleaved rounds, medians):

* one braced gradient-projection step, joint values in and joint velocities out, with all four terms of
  eq:objective: the fused :class:`~bracekit.resolution.GradientProjectionStep` with the analytic gradient on both
  backends (NumPy, and numba when it is installed) and with the paper's central differences (same code,
  only the gradient differs), and the reference path (``BracedGradientProjection.velocity`` on
  ``braced.state(q)``) both ways;
* the numba backend's one-off costs, each in a fresh process: compiling the kernel with an empty cache
  (full runs only) and importing numba plus loading the compiled kernel from its disk cache;
* Pinocchio's own FK + Jacobian + kinematic Hessian of the tip frame: the floor of anything that calls it;
* Robotics Toolbox for Python's ``jacob0`` / ``hessian0`` on the same URDF chain, when it is installed;
* batch evaluation (:mod:`bracekit.compliance.batch`) of C_e in both models, C_i and k on both backends (numba on
  all of numba's threads and on one, and NumPy), against the single-configuration path (throughput and the largest
  relative difference), with the numba kernel's first call (cache load or compilation) apart;
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

from bracekit.compliance import COMPLIANCE_MODELS, compliance_index, end_effector_compliance, frobenius_condition
from bracekit.compliance.batch import BatchEvaluator
from bracekit.contact import Brace, Surface
from bracekit.errors import BracekitError, InputError
from bracekit.kinematics import LWA, BracedRobot
from bracekit.model import model_path
from bracekit.objective import Objective, RegionBarrier
from bracekit.resolution import GradientProjectionStep
from bracekit.simulation import Scenario, load_scenario

#: The parts of :func:`run_benchmarks`.
PARTS = ("core", "sweep", "figures", "qp")
#: The speed targets (README, Speed).
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


def _rtb(braced: BracedRobot, q: np.ndarray, calls: int, rounds: int) -> dict[str, Any]:
    """Robotics Toolbox for Python on the same URDF chain, if it is installed (never a dependency)."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            import roboticstoolbox as rtb
    except Exception as exc:  # ImportError, or a broken install
        return {"available": False, "reason": f"roboticstoolbox not importable ({type(exc).__name__})"}
    try:
        path = model_path("paper-robot")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:  # roboticstoolbox ≥ 1.2
                from roboticstoolbox.models.URDF.URDFRobot import URDF_read

                links, name, *_ = URDF_read(str(path))
                robot = rtb.Robot(links, name=name)
            except ImportError:  # older releases
                robot = rtb.Robot.URDF(str(path))
        tip = braced.robot.tip
        state = braced.state(q, hessians=True)
        j0 = np.asarray(robot.jacob0(q, end=tip))
        h0 = np.asarray(robot.hessian0(q, end=tip))  # (n, 6, n): [k, :, i] = ∂J[:, i]/∂q_k
        diff = max(float(np.max(np.abs(j0 - state.J_e))), float(np.max(np.abs(h0.transpose(1, 2, 0) - state.dJ_e))))
        t = _interleaved(
            {
                "jacob0": (lambda: robot.jacob0(q, end=tip), calls),
                "hessian0": (lambda: robot.hessian0(q, end=tip), calls),
            },
            rounds,
        )
        return {
            "available": True,
            "version": getattr(rtb, "__version__", "?"),
            "jacob0_us": 1e6 * t["jacob0"],
            "hessian0_us": 1e6 * t["hessian0"],
            "max_abs_diff_vs_pinocchio": diff,
        }
    except Exception as exc:
        return {"available": False, "reason": f"roboticstoolbox failed on the URDF: {type(exc).__name__}: {exc}"}


def _single_path(
    braced: BracedRobot, q: np.ndarray, beta: np.ndarray
) -> tuple[dict[str, np.ndarray], dict[str, float], float]:
    """What the batch computes, one configuration at a time: C_e and C_i in both models, k."""
    st = braced.state(q)
    c_e = {m: end_effector_compliance(st, m) for m in COMPLIANCE_MODELS}  # type: ignore[arg-type]
    return c_e, {m: compliance_index(c, beta) for m, c in c_e.items()}, frobenius_condition(st.J_e)


_BATCH_COLD = """
import json, time
import numpy as np
from bracekit.compliance.batch import BatchEvaluator
from bracekit.simulation.scenario import load_scenario
sc = load_scenario("paper")
t0 = time.perf_counter()
ev = BatchEvaluator(sc.braced, backend="numba")
t1 = time.perf_counter()
ev(np.tile(sc.guess, (4, 1)), sc.beta_x(0.0), errors="nan")
t2 = time.perf_counter()
st = ev._kernels.evaluate.stats
print(json.dumps({"import_s": t1 - t0, "first_call_s": t2 - t1, "cache_misses": sum(st.cache_misses.values())}))
"""


def _batch_cold() -> dict[str, Any]:
    """The batch kernel's compilation in a fresh process with an empty numba cache (NUMBA_CACHE_DIR)."""
    with tempfile.TemporaryDirectory(prefix="bracekit-numba-") as tmp:
        env = {**os.environ, "NUMBA_CACHE_DIR": tmp}
        proc = subprocess.run([sys.executable, "-c", _BATCH_COLD], capture_output=True, text=True, check=False, env=env)
    if proc.returncode != 0:
        return {"ok": False, "reason": (proc.stderr.strip().splitlines() or ["?"])[-1]}
    return {"ok": True, **json.loads(proc.stdout.strip().splitlines()[-1])}


def _batch(braced: BracedRobot, beta: np.ndarray, size: int, rounds: int, quick: bool) -> dict[str, Any]:
    """Batch throughput on both backends, interleaved rounds (medians), and the agreement with the single path."""
    rng = np.random.default_rng(5)
    lo, hi = braced.robot.lower, braced.robot.upper
    Q = rng.uniform(lo, hi, size=(size, braced.n))
    ev = BatchEvaluator(braced, backend="numpy")
    nb: BatchEvaluator | None = None
    first: dict[str, Any] = {}
    try:
        t0 = time.perf_counter()
        nb = BatchEvaluator(braced, backend="numba")
        t1 = time.perf_counter()
        nb(Q[:4], beta, errors="nan")  # the first call: loads the kernel from numba's cache, or compiles it
        t2 = time.perf_counter()
        stats = nb._kernels.evaluate.stats  # type: ignore[union-attr]
        first = {
            "import_s": t1 - t0,
            "first_call_s": t2 - t1,
            "first_call_compiled": sum(stats.cache_misses.values()) > 0,
        }
    except InputError as exc:
        first = {"reason": str(exc)}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ev(Q[:256], beta, errors="nan")  # warm up
        cases: dict[str, Callable[[], Any]] = {"numpy": lambda: ev(Q, beta, errors="nan")}
        if nb is not None:
            cases["numba"] = lambda: nb(Q, beta, errors="nan")
            cases["numba_1thread"] = lambda: nb(Q, beta, errors="nan", threads=1)
        times: dict[str, list[float]] = {name: [] for name in cases}
        cpu: list[float] = []  # CPU seconds of the one-thread numba call (its time on a core, whatever the load)
        results: dict[str, Any] = {}
        for _ in range(rounds):
            for name, fn in cases.items():
                c, t = time.thread_time(), time.perf_counter()
                results[name] = fn()
                times[name].append(time.perf_counter() - t)
                if name == "numba_1thread":
                    cpu.append(time.thread_time() - c)
        # equal to the single-configuration path
        worst = {name: 0.0 for name in results}
        checked = 0
        for i in range(0, size, max(1, size // 64)):
            try:
                c_e, ci, k = _single_path(braced, Q[i], beta)
            except BracekitError:
                continue
            checked += 1
            for name, res in results.items():
                for m in COMPLIANCE_MODELS:
                    diff = float(np.max(np.abs(res.C_e[m][i] - c_e[m])) / np.max(np.abs(c_e[m])))
                    worst[name] = max(worst[name], diff, abs(res.Ci[m][i] - ci[m]) / ci[m])
                worst[name] = max(worst[name], abs(res.k[i] - k) / k)
        singles = []
        for i in range(min(size, 200)):
            t = time.perf_counter()
            try:
                _single_path(braced, Q[i], beta)
            except BracekitError:
                pass
            singles.append(time.perf_counter() - t)
    rate = {name: size / float(np.median(ts)) for name, ts in times.items()}
    numba_threads = None
    if nb is not None:
        import numba

        numba_threads = numba.get_num_threads()
    compile_s = first.get("first_call_s") if first.get("first_call_compiled") else None
    cold = None
    if nb is not None and not quick:
        cold = _batch_cold()
        if cold.get("ok") and cold.get("cache_misses"):
            compile_s = cold["first_call_s"]
    res = results["numpy"]
    return {
        "configs": size,
        "configs_per_s": rate.get("numba", rate["numpy"]),
        "backend": "numba" if nb is not None else "numpy",
        "numba_configs_per_s": rate.get("numba"),
        "numba_1thread_configs_per_s": rate.get("numba_1thread"),
        "numba_1thread_cpu_configs_per_s": size / float(np.median(cpu)) if cpu else None,
        "numba_threads": numba_threads,
        "numpy_configs_per_s": rate["numpy"],
        "numba_first_call": first,
        "numba_compile_s": compile_s,
        "numba_compile_fresh_process": cold,
        "single_configs_per_s": 1.0 / float(np.median(singles)),
        "max_rel_diff": max(worst.values()),
        "max_rel_diff_numba": worst.get("numba"),
        "max_rel_diff_numpy": worst["numpy"],
        "checked": checked,
        "jacobians": "product of exponentials" if ev.kinematics.exact else "Pinocchio loop",
        "singular": int(np.sum(~np.isfinite(res.k))),
    }


def _split_step(sc: Scenario, q: np.ndarray, xdot: np.ndarray, calls: int, rounds: int) -> dict[str, Any]:
    """The fused step with a link-point brace on link 4 (n1 = 4) of the paper's robot, both backends.

    The scenario's objective, with the bracing region centred on {b} at q (radius 1 m) and a pad direction.
    """
    robot = sc.robot.with_point_frame("pad4", "link4", (0.03, 0.02, 0.0))
    probe = BracedRobot(robot, Brace("pad4", Surface(np.zeros(3), (0.0, 0.0, 1.0))))
    b = probe.placements(q)[0]
    braced = BracedRobot(robot, Brace("pad4", Surface(b, (0.0, 0.0, 1.0)), region_radius=1.0, pad_axis=True))
    base = sc.strategy("braced_gradient_projection", gradient="analytic")
    objective = base.objective  # type: ignore[attr-defined]
    terms = [RegionBarrier(1.0, b) if isinstance(t, RegionBarrier) else t for t in objective.terms]
    strategy = dataclasses.replace(base, objective=Objective(terms, objective.weights))  # type: ignore[type-var]
    npb = GradientProjectionStep(braced, strategy, backend="numpy")  # type: ignore[arg-type]
    ref_q = strategy.velocity(braced.state(q, hessians=True), xdot)  # type: ignore[attr-defined]
    out: dict[str, Any] = {"n1": braced.n1, "numba_us": None, "kernel_used": False, "max_rel_diff_numba": None}
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


def run_benchmarks(quick: bool = False, parts: tuple[str, ...] = PARTS) -> dict[str, Any]:
    """Measure the hot paths on the paper's robot; a JSON-serialisable dict with a "table" string.

    Keys (SI, medians): ``gp_step_analytic_us`` (the faster backend, named by ``gp_step_analytic_backend``),
    ``gp_step_analytic_numpy_us`` and ``gp_step_analytic_numba_us`` (None without numba), ``gp_step_fd_us``
    (the same fused step with central differences), ``gp_step_fd_reference_us`` and
    ``gp_step_analytic_reference_us`` (the reference path), their ratios (``gp_step_fd_ratio`` against the
    faster backend, ``gp_step_fd_ratio_numpy`` / ``_numba`` against each), ``numba_compile_s`` (the kernel's
    compilation, in a fresh process with an empty cache; None in a quick run unless this process compiled),
    ``numba_import_s`` + ``numba_cache_load_s`` = ``numba_import_and_cache_load_s`` (what every new process
    pays), ``pinocchio_floor_us``, ``batch_configs_per_s`` (the numba backend when installed, else NumPy;
    ``batch_backend`` says which) beside ``batch_numpy_configs_per_s``, ``batch_numba_configs_per_s`` and
    ``batch_numba_1thread_configs_per_s`` (one thread; ``batch_numba_1thread_cpu_configs_per_s`` per second of
    that thread's CPU time, which other load on the machine changes little), ``batch_numba_first_call_s`` and
    ``batch_numba_compile_s`` (the kernel's first call and compilation, not in the throughput),
    ``gp_step_split_numpy_us`` and ``gp_step_split_numba_us`` (the fused step at the split ``gp_step_split_n1`` = 4),
    ``scenario_wall_s`` and more.
    ``quick`` takes fewer rounds and a smaller batch (a few seconds plus one scenario run, and one short
    process for numba's cache load when numba is installed).
    ``parts``: "core" (all of the above), "sweep" (``sweep_candidates_per_s_1`` and ``_2``: benchmarks/bench_sweep.py,
    1 then 2 local Dask workers on the same candidates; needs bracekit[sweep]) and "figures"
    (``figures_overhead_ratio`` = ``bracekit run paper`` with figures / with ``--no-figures``, interleaved
    processes: benchmarks/bench_figures.py).
    """
    for part in parts:
        if part not in PARTS:
            raise InputError(f"unknown benchmark part '{part}'; choose from {', '.join(PARTS)}")
    extra: dict[str, Any] = {}
    if "figures" in parts:  # first: whole processes, before this one loads the machine's caches with the rest
        extra.update(_sibling("bench_figures").figures_benchmarks(quick))
    if "sweep" in parts:
        extra.update(_sweep(quick))
    if "qp" in parts:
        extra.update(_qp(quick))
    if "core" not in parts:
        extra["table"] = _extra_table(extra)
        return extra
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
    rtb = _rtb(braced, q, 20 if quick else 200, rounds)
    batch = _batch(braced, beta, 50_000 if quick else 400_000, 3 if quick else 7, quick)
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
    res.update(extra)
    if "figures_overhead_ratio" in extra:
        res["targets_met"]["figures overhead ≤ 2× the run without figures"] = extra["figures_overhead_ratio"] <= 2.0
    res["table"] = _table(res) + ("\n" + _extra_table(extra) if extra else "")
    return res


def _sibling(name: str) -> Any:
    """benchmarks/NAME.py, loaded by path (this file is itself loaded by path by `bracekit bench`)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location(f"bracekit_benchmarks_{name}", Path(__file__).with_name(f"{name}.py"))
    if spec is None or spec.loader is None:  # pragma: no cover
        raise InputError(f"benchmarks/{name}.py is missing from this clone")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _sweep(quick: bool) -> dict[str, Any]:
    """The sweep benchmark, or the reason it was skipped (dask or pyarrow missing)."""
    import importlib.util

    missing = [m for m in ("distributed", "pyarrow") if importlib.util.find_spec(m) is None]
    if missing:
        return {"sweep_skipped": f"{', '.join(missing)} not installed: pip install 'bracekit[sweep]'"}
    return dict(_sibling("bench_sweep").sweep_benchmarks(quick))


def _qp(quick: bool) -> dict[str, Any]:
    """braced_qp and bracekit.pink per step (benchmarks/bench_qp.py), or why they were skipped."""
    import importlib.util

    missing = [m for m in ("qpsolvers", "pink") if importlib.util.find_spec(m) is None]
    if missing:
        return {"qp_skipped": f"{', '.join(missing)} not installed: pip install 'bracekit[pink]'"}
    return dict(_sibling("bench_qp").qp_benchmarks(quick))


def _extra_table(r: dict[str, Any]) -> str:
    """Rows of the sweep, figures and QP benchmarks."""
    rows: list[tuple[str, str, str]] = []
    if "pink_frame_task_step_us" in r:
        rows += _sibling("bench_qp").qp_table(r)
    elif "qp_skipped" in r:
        rows.append(("braced_qp and bracekit.pink", "skipped", r["qp_skipped"]))
    if "sweep_candidates_per_s_1" in r:
        one, two = r["sweep_candidates_per_s_1"], r["sweep_candidates_per_s_2"]
        rows += [
            (
                "bracekit sweep, 1 local Dask worker",
                f"{one:.2f} candidates/s",
                f"{r['sweep_candidates']:.0f} whole-task candidates (paper-links), no screening",
            ),
            ("Same, 2 local Dask workers", f"{two:.2f} candidates/s", f"{two / one:.2f}× one worker"),
        ]
    elif "sweep_skipped" in r:
        rows.append(("bracekit sweep", "skipped", r["sweep_skipped"]))
    if "figures_overhead_ratio" in r:
        rows += [
            ("bracekit run paper, with figures and animation", f"{r['run_figures_s']:.2f} s", "new process"),
            ("Same, --no-figures", f"{r['run_no_figures_s']:.2f} s", "interleaved with the above"),
            (
                "figures_overhead_ratio",
                f"{r['figures_overhead_ratio']:.2f}",
                f"target ≤ 2; CPU {r['run_figures_cpu_s']:.1f} s / {r['run_no_figures_cpu_s']:.1f} s",
            ),
        ]
    w0 = max((len(a) for a, _, _ in rows), default=0)
    w1 = max((len(b) for _, b, _ in rows), default=0)
    return "\n".join(f"{a:<{w0}}  {b:>{w1}}  {c}" for a, b, c in rows)


def _table(r: dict[str, Any]) -> str:
    env = r["environment"]
    load = env["load_average"]
    head = (
        f"bracekit bench: the paper's robot (11 joints, brace after joint 6), "
        f"Python {env['python']}, NumPy {env['numpy']}, Pinocchio {env['pinocchio']}"
        + (f", numba {env['numba']}" if env["numba"] else "")
        + f", {env['cpus']} CPUs"
        + (f", load {load[0]:.2f}" if load else "")
        + ("; quick run" if r["quick"] else "")
        + "; medians, measured side by side in one process"
    )
    nb = r["numba"]
    np_us, nb_us = r["gp_step_analytic_numpy_us"], r["gp_step_analytic_numba_us"]
    rows = []
    if nb_us is not None:
        rows.append(
            (
                "GP step, analytic ∇g (fused, numba backend)",
                f"{nb_us:.1f} µs",
                f"target ≤ 100 µs; numba {nb['version']}; max rel. diff {r['gp_step_max_rel_diff_numba']:.1e}",
            )
        )
    rows.append(
        (
            "GP step, analytic ∇g (fused, NumPy backend)",
            f"{np_us:.1f} µs",
            ("target ≤ 100 µs; " if nb_us is None else f"{np_us / nb_us:.1f}× the numba step; ")
            + f"max rel. diff {r['gp_step_max_rel_diff_numpy']:.1e}",
        )
    )
    if nb_us is None:
        rows.append(("GP step, analytic ∇g (fused, numba backend)", "skipped", "numba not installed (bracekit[fast])"))
    fd_vs = f"{r['gp_step_fd_ratio_numpy']:.1f}× the NumPy step"
    ref_vs = f"{r['gp_step_fd_reference_us'] / np_us:.1f}× the NumPy step"
    if nb_us is not None:
        fd_vs = f"{r['gp_step_fd_ratio_numba']:.0f}× the numba step, " + fd_vs
        ref_vs = f"{r['gp_step_fd_reference_us'] / nb_us:.0f}× the numba step, " + ref_vs
    rows += [
        ("GP step, central-difference ∇g (same fused step)", f"{r['gp_step_fd_us']:.0f} µs", fd_vs),
        ("GP step, central-difference ∇g (reference path)", f"{r['gp_step_fd_reference_us']:.0f} µs", ref_vs),
        (
            "GP step, analytic ∇g (reference path)",
            f"{r['gp_step_analytic_reference_us']:.0f} µs",
            f"{r['gp_step_analytic_reference_us'] / np_us:.1f}× the NumPy step",
        ),
    ]
    if nb_us is not None:
        if r["numba_compile_s"] is not None:
            where = "a fresh process, empty cache" if nb.get("empty_cache") else "this process (cache was empty)"
            rows.append(
                ("numba kernel: compilation", f"{r['numba_compile_s']:.1f} s", f"once, then cached on disk; {where}")
            )
        if r["numba_import_and_cache_load_s"] is not None:
            rows.append(
                (
                    "numba: import + kernel cache load",
                    f"{r['numba_import_and_cache_load_s']:.2f} s",
                    f"every new process; import {r['numba_import_s']:.2f} s + load {r['numba_cache_load_s']:.2f} s",
                )
            )
    rows += [
        ("Pinocchio FK + J + Hessian, tip frame (floor)", f"{r['pinocchio_floor_us']:.1f} µs", "pinocchio only"),
        (
            "Pinocchio FK + J + Hessian, tip and brace frames",
            f"{r['pinocchio_two_frames_us']:.1f} µs",
            "what a step needs",
        ),
        ("Pinocchio FK + J, tip frame", f"{r['pinocchio_jacobian_us']:.1f} µs", "what one g of the FD needs"),
        (
            "One tiny NumPy operation (6-vector × 2)",
            f"{1e3 * r['numpy_op_us']:.0f} ns",
            f"machine speed now; the fused step costs {r['gp_step_analytic_in_numpy_ops']:.0f} of them"
            + (f" ({r['gp_step_analytic_numpy_in_numpy_ops']:.0f} with NumPy)" if nb_us is not None else ""),
        ),
    ]
    rtb = r["rtb"]
    if rtb.get("available"):
        rows += [
            ("Robotics Toolbox jacob0, tip", f"{rtb['jacob0_us']:.1f} µs", f"RTB {rtb['version']}, same URDF chain"),
            (
                "Robotics Toolbox hessian0, tip",
                f"{rtb['hessian0_us']:.1f} µs",
                f"J and H equal Pinocchio's to {rtb['max_abs_diff_vs_pinocchio']:.0e}",
            ),
        ]
    else:
        rows.append(("Robotics Toolbox jacob0 / hessian0", "skipped", rtb.get("reason", "")))
    sp = r["gp_step_split"]
    if sp["numba_us"] is not None:
        rows.append(
            (
                f"GP step at n1 = {sp['n1']} (link-point brace), numba",
                f"{sp['numba_us']:.1f} µs",
                ("kernel" if sp["kernel_used"] else "NumPy code (kernel declined)")
                + f"; max rel. diff {sp['max_rel_diff_numba']:.1e}",
            )
        )
    rows.append(
        (
            f"GP step at n1 = {sp['n1']} (link-point brace), NumPy",
            f"{sp['numpy_us']:.1f} µs",
            (f"{sp['numpy_us'] / sp['numba_us']:.1f}× the numba step; " if sp["numba_us"] else "")
            + f"max rel. diff {sp['max_rel_diff_numpy']:.1e}",
        )
    )
    b = r["batch"]
    if b["numba_configs_per_s"] is not None:
        rows += [
            (
                "Batch C_e (2 models) + C_i + k, numba",
                f"{b['numba_configs_per_s'] / 1e3:.0f} k configs/s",
                f"target ≥ 600 k/s; {b['numba_threads']} threads; {b['configs']} configs; "
                f"max rel. diff {b['max_rel_diff_numba']:.1e}",
            ),
            (
                "Same, numba on one thread",
                f"{b['numba_1thread_configs_per_s'] / 1e3:.0f} k configs/s",
                f"threads=1 (or NUMBA_NUM_THREADS=1); "
                f"{b['numba_1thread_cpu_configs_per_s'] / 1e3:.0f} k per second of CPU time",
            ),
        ]
        if b["numba_compile_s"] is not None:
            rows.append(
                ("Batch numba kernel: compilation", f"{b['numba_compile_s']:.1f} s", "once, then cached on disk")
            )
        fc = b["numba_first_call"]
        if not fc.get("first_call_compiled"):
            rows.append(
                (
                    "Batch numba kernel: first call",
                    f"{fc['first_call_s']:.2f} s",
                    "kernel loaded from disk; not in the throughput",
                )
            )
    rows += [
        (
            "Batch C_e (2 models) + C_i + k, NumPy",
            f"{b['numpy_configs_per_s'] / 1e3:.0f} k configs/s",
            f"target ≥ 100 k/s; {b['configs']} configs; max rel. diff {b['max_rel_diff_numpy']:.1e}",
        ),
        ("Same, single-configuration path", f"{b['single_configs_per_s'] / 1e3:.1f} k configs/s", "one at a time"),
        (
            "bracekit run paper --no-figures --quiet",
            f"{r['scenario_wall_s']:.2f} s",
            "target ≤ 5 s; new process, start-up included",
        ),
    ]
    if r["scenario_one_model_in_process_s"] is not None:
        rows.append(
            ("run_scenario(both_models=False), in process", f"{r['scenario_one_model_in_process_s']:.2f} s", "3 runs")
        )
    w0 = max(len(a) for a, _, _ in rows)
    w1 = max(len(b_) for _, b_, _ in rows)
    lines = [head, "", f"| {'what':<{w0}} | {'median':>{w1}} | note |", f"|{'-' * (w0 + 2)}|{'-' * (w1 + 1)}:|------|"]
    lines += [f"| {a:<{w0}} | {b_:>{w1}} | {c} |" for a, b_, c in rows]
    met = [f"{'met' if ok else 'NOT met'}: {name}" for name, ok in r["targets_met"].items()]
    return "\n".join([*lines, "", *met])
