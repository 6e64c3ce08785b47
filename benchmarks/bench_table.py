"""The text table of ``bracekit bench``: one row per measurement, with its note, then the targets met."""

from __future__ import annotations

from typing import Any


def _machine(r: dict[str, Any]) -> str:
    m = r.get("machine") or {}
    load = m.get("load_average") or [float("nan")]
    after = m.get("load_average_after") or [float("nan")]
    return (
        f"{m.get('cores', '?')} cores ({m.get('cpu_model', '?')}), load {load[0]:.2f} → {after[0]:.2f}, "
        f"{m.get('date_utc', '?')}, commit {(m.get('commit') or '?')[:12]}"
    )


def extra_table(r: dict[str, Any]) -> str:
    """Rows of the whole runs, the sweep and the figures, headed by the machine."""
    rows: list[tuple[str, str, str]] = []
    runs = (("paper", "run_paper_s"), ("two-braces", "run_two_braces_s"), ("panda", "run_panda_s"))
    for name, key in runs:
        if key in r:
            cpu = r.get(key.removesuffix("_s") + "_cpu_s")
            rows.append(
                (f"run_scenario('{name}'), in process", f"{r[key]:.2f} s", f"median; CPU {cpu:.2f} s" if cpu else "")
            )
    if "run_step_braces_ratio" in r:
        rows += [
            ("Run step, paper (one brace, gradient projection)", f"{r['run_step_one_brace_us']:.0f} µs", "median"),
            ("Run step, two-braces (gradient projection)", f"{r['run_step_two_braces_us']:.0f} µs", "median"),
            (
                "run_step_braces_ratio",
                f"{r['run_step_braces_ratio']:.2f}",
                "two / one brace per step (goal ≤ 2)",
            ),
        ]
    elif "run_step_failed" in r:
        rows.append(("Run step, one and two braces", "-", r["run_step_failed"]))
    floors = "pinocchio_floor_two_braces_us" in r  # the part "runs" measured its floors
    if "step_gp_us" in r:
        ratio = f"{r['step_gp_in_floors']:.1f}× the Pinocchio floor" if "step_gp_in_floors" in r else ""
        rows.append((f"GradientProjectionStep, paper ({r['step_gp_backend']})", f"{r['step_gp_us']:.1f} µs", ratio))
    for key, label, floor in (
        ("control_step_us", "Control step, paper (one brace)", "control_step_in_floors"),
        ("control_step_two_braces_us", "Control step, two-braces", "control_step_two_braces_in_floors"),
    ):
        if key in r:
            note = f"{r[floor]:.1f}× its floor (goal ≤ 10)" if floor in r else ""
            rows.append((label, f"{r[key]:.1f} µs", note))
    for key in ("control_step_skipped", "control_step_failed", "control_step_two_braces_failed", "step_gp_failed"):
        if key in r:
            rows.append((key.replace("_", " "), "-", r[key]))
    for key, label in (
        ("pinocchio_floor_us", "Pinocchio FK + J + H, tip (floor)"),
        ("pinocchio_floor_two_frames_us", "Pinocchio FK + J + H, tip and brace"),
        ("pinocchio_floor_two_braces_us", "Pinocchio FK + J + H, two-braces: tip and 2 braces"),
    ):
        if floors and key in r:
            rows.append((label, f"{r[key]:.1f} µs", "same process, same start guess"))
    if "pinocchio_floor_failed" in r:
        rows.append(("Pinocchio floor", "-", r["pinocchio_floor_failed"]))
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
    if not rows:
        return ""
    w0 = max(len(a) for a, _, _ in rows)
    w1 = max(len(b) for _, b, _ in rows)
    lines = [f"Whole runs, sweep, figures; {_machine(r)}", ""]
    return "\n".join(lines + [f"{a:<{w0}}  {b:>{w1}}  {c}" for a, b, c in rows])


def core_table(r: dict[str, Any]) -> str:
    """The table of the part "core", then its targets (met or not)."""
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
