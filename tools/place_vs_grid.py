"""The placement against the grid sweep, side by side: the commands' wall and CPU times and bests, and the searches'.

    python tools/place_vs_grid.py SPEC --rounds 3 [--workers 2] [--place-source DIR] [--json FILE]
    python tools/place_vs_grid.py SPEC --rounds 3 --searches

Commands (default): each round runs ``bracekit sweep SPEC --out G --workers W --quiet --no-figures`` and
``bracekit place SPEC --out P --workers W --no-figures`` as new processes, each into a fresh folder, the order
alternating between rounds so both see the same load; it reports each command's wall time, the CPU time of the
command and its workers (user + system, from the children's resource usage), the ratio place / grid of each
round, the load average before and after, and each command's best feasible mean C_i of gradient projection
(the grid's over its simulated and refined rows, the placement's ``best``). ``--place-source DIR`` runs the
placement of another source tree (DIR/src on PYTHONPATH), e.g. a worktree of an earlier commit.

Searches (``--searches``): in one process, one local cluster of W workers forked from it after the modules are
imported (as ``bracekit place`` starts its own), then per round :func:`bracekit.studies.sweep.engine.run_sweep`
(into a fresh folder) and :func:`bracekit.studies.place.engine.run_place` with :func:`~bracekit.studies.place.
engine.prepare`, alternating, after one warm-up round of each: the searches' own wall times, without the start-up
both commands pay (Python, the imports, numba's start, the cluster). Medians over the rounds.

``--json FILE`` writes either result with the machine's cores, the load average before and after, the commit
(``git rev-parse --short HEAD``) and the UTC date.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any


def _cpu_children() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def _grid_best(out: Path) -> float:
    """The least mean C_i of gradient projection of the grid's feasible simulated rows and refinements (m/N)."""
    best = math.inf
    with (out / "results.csv").open(encoding="utf-8") as fh:
        for row in csv.DictReader(fh):
            if row["feasible"] == "True" and row["Ci_mean_gp"]:
                best = min(best, float(row["Ci_mean_gp"]))
    refined = out / "refined.csv"
    if refined.is_file():
        with refined.open(encoding="utf-8") as fh:
            for row in csv.DictReader(fh):
                if row.get("refined_Ci_mean_gp"):
                    best = min(best, float(row["refined_Ci_mean_gp"]))
    return best


def _place_best(out: Path) -> float:
    best = json.loads((out / "summary.json").read_text(encoding="utf-8")).get("best")
    return math.inf if not best else float(best["Ci_mean_gp"])


def _command(kind: str, spec: str, workers: int, out: Path, env: dict[str, str]) -> dict[str, Any]:
    args = ["sweep", spec, "--out", str(out), "--workers", str(workers), "--quiet", "--no-figures"]
    if kind == "place":
        args = ["place", spec, "--out", str(out), "--workers", str(workers), "--no-figures"]
    cpu0, began = _cpu_children(), time.perf_counter()
    proc = subprocess.run(
        [sys.executable, "-m", "bracekit", *args], env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE
    )
    wall, cpu = time.perf_counter() - began, _cpu_children() - cpu0
    if proc.returncode not in (0, 1):
        raise SystemExit(f"bracekit {kind} failed (exit {proc.returncode}): {proc.stderr.decode()[-400:]}")
    best = _grid_best(out) if kind == "grid" else _place_best(out)
    return {"wall_s": wall, "cpu_s": cpu, "best_Ci_mean_gp": best}


def commands(spec: str, rounds: int, workers: int, place_source: Path | None) -> dict[str, Any]:
    """Both commands `rounds` times, alternating (see the module)."""
    env = dict(os.environ)
    place_env = dict(env)
    if place_source is not None:
        place_env["PYTHONPATH"] = os.pathsep.join([str(place_source.resolve() / "src"), env.get("PYTHONPATH", "")])
    out: dict[str, Any] = {"spec": spec, "workers": workers, "rounds": []}
    with tempfile.TemporaryDirectory(prefix="place-vs-grid-") as tmp:
        for i in range(rounds):
            load0 = os.getloadavg()[0]
            order = ("grid", "place") if i % 2 == 0 else ("place", "grid")
            row: dict[str, Any] = {}
            for kind in order:
                run_env = env if kind == "grid" else place_env
                row[kind] = _command(kind, spec, workers, Path(tmp) / f"{kind}{i}", run_env)
            row["ratio"] = row["place"]["wall_s"] / row["grid"]["wall_s"]
            row["load"] = [load0, os.getloadavg()[0]]
            out["rounds"].append(row)
            print(
                f"round {i + 1}: grid {row['grid']['wall_s']:.2f} s (CPU {row['grid']['cpu_s']:.2f}), place "
                f"{row['place']['wall_s']:.2f} s (CPU {row['place']['cpu_s']:.2f}): {row['ratio']:.2f}; bests "
                f"{1e3 * row['grid']['best_Ci_mean_gp']:.3f} / {1e3 * row['place']['best_Ci_mean_gp']:.3f} mm/N; "
                f"load {load0:.2f}–{row['load'][1]:.2f}",
                flush=True,
            )
    ratios = [r["ratio"] for r in out["rounds"]]
    out["median_ratio"] = statistics.median(ratios)
    return out


def searches(spec_name: str, rounds: int, workers: int) -> dict[str, Any]:
    """The two searches on one warm local cluster, `rounds` times after a warm-up (see the module)."""
    import importlib

    place_cli = importlib.import_module("bracekit.cli.place")
    from bracekit.studies.place.engine import PlaceSettings, prepare, run_place
    from bracekit.studies.place.inner import InnerSettings
    from bracekit.studies.place.spec import default_surface, load_place_spec
    from bracekit.studies.place.workers import WorkerThreads
    from bracekit.studies.sweep.engine import dask_client, run_sweep
    from bracekit.studies.sweep.spec import load_spec

    spec = load_spec(spec_name)
    pspec = load_place_spec(spec_name)
    settings = PlaceSettings(inner=InnerSettings(surface=default_surface(pspec)))
    times: dict[str, list[float]] = {"grid": [], "place": []}
    bests: dict[str, float] = {}
    with tempfile.TemporaryDirectory(prefix="place-vs-grid-") as tmp, place_cli._forked_workers() as fork:
        prepared = prepare(pspec, settings, context=fork)
        with dask_client(workers) as client:
            client.register_plugin(WorkerThreads())
            for i in range(rounds + 1):
                for kind in ("grid", "place") if i % 2 == 0 else ("place", "grid"):
                    began = time.perf_counter()
                    if kind == "grid":
                        run = run_sweep(spec, Path(tmp) / f"g{i}", client, progress=False)
                        feasible = [r["Ci_mean_gp"] for r in run.rows if r.get("feasible")]
                        bests["grid"] = min(feasible, default=math.inf)
                    else:
                        # the reference start and the task context in this process, as the command computes them
                        result = run_place(
                            pspec, client, settings, prepare(pspec, settings, context=True) if i else prepared
                        )
                        bests["place"] = math.inf if result.best is None else float(result.best["Ci_mean_gp"])
                    if i:  # round 0 warms both up
                        times[kind].append(time.perf_counter() - began)
    grid, place = statistics.median(times["grid"]), statistics.median(times["place"])
    print(
        f"searches on one warm cluster of {workers} workers, medians of {rounds}: grid {grid:.2f} s, place "
        f"{place:.2f} s: {place / grid:.2f} (bests, simulated rows: grid {1e3 * bests['grid']:.3f}, place "
        f"{1e3 * bests['place']:.3f} mm/N)"
    )
    return {"spec": spec_name, "workers": workers, "times": times, "ratio": place / grid, "bests": bests}


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("spec")
    p.add_argument("--rounds", type=int, default=3)
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--place-source", type=Path, default=None)
    p.add_argument("--searches", action="store_true")
    p.add_argument("--json", type=Path, default=None)
    a = p.parse_args()
    load_before = os.getloadavg()[0]
    res = searches(a.spec, a.rounds, a.workers) if a.searches else commands(a.spec, a.rounds, a.workers, a.place_source)
    res["cores"] = os.cpu_count()
    res["load_before"], res["load_after"] = load_before, os.getloadavg()[0]
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True, check=False)
    res["commit"] = commit.stdout.strip() or None
    res["date_utc"] = time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())
    if a.json is not None:
        a.json.write_text(json.dumps(res, indent=2) + "\n", encoding="utf-8")


if __name__ == "__main__":
    main()
