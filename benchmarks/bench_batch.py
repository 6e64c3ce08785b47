"""Batch evaluation of C_e (both models), C_i and k (:mod:`bracekit.compliance.batch`) against the single path.

Both backends (numba on all of numba's threads and on one, and NumPy), throughput and the largest relative
difference from the one-configuration-at-a-time path, with the numba kernel's first call (cache load or
compilation) apart.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
import warnings
from collections.abc import Callable
from typing import Any

import numpy as np

from bracekit.compliance import COMPLIANCE_MODELS, compliance_index, end_effector_compliance, frobenius_condition
from bracekit.compliance.batch import BatchEvaluator
from bracekit.errors import BracekitError, InputError
from bracekit.kinematics import BracedRobot


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


def batch_benchmarks(braced: BracedRobot, beta: np.ndarray, size: int, rounds: int, quick: bool) -> dict[str, Any]:
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
