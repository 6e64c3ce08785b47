"""braced_qp and bracekit.pink: per-step cost and the strategies compared on the shipped scenarios.

``python benchmarks/bench_qp.py`` prints the per-step medians (:func:`qp_benchmarks`, also ``bracekit bench
--only qp``); ``--compare`` runs braced minimum norm, gradient projection and braced_qp on every shipped scenario
(:func:`compare_strategies`) and prints the Markdown table of docs/qp.md. Needs bracekit[qp,pink].
"""

from __future__ import annotations

import argparse
import time
import timeit
import warnings
from typing import Any

import numpy as np

SCENARIOS = ("paper", "panda", "panda-holding", "two-braces")
COMPARED = ("braced_min_norm", "braced_gradient_projection", "braced_qp")


def _median_us(fn: Any, number: int, repeat: int) -> float:
    return 1e6 * float(np.median(timeit.repeat(fn, number=number, repeat=repeat))) / number


def qp_benchmarks(quick: bool = False) -> dict[str, Any]:
    """Medians (µs) of one step: pink's FrameTask alone, + BraceTask (hard equality), + ComplianceTask, + barriers
    (the Panda on its post), and braced_qp beside the reference gradient-projection step (paper robot and Panda)."""
    import pinocchio as pin
    from pink.tasks import FrameTask

    import pink
    from bracekit.pink import BraceRegionBarrier, BraceTask, ComplianceTask, LinkClearanceBarrier
    from bracekit.simulation.scenario import load_scenario
    from bracekit.simulation.simulate import solve_start

    number, repeat = (20, 3) if quick else (100, 7)
    out: dict[str, Any] = {}
    sc = load_scenario("panda")
    braced = sc.braced
    start = solve_start(braced, sc.task.position(0.0), sc.guess, rotation=sc.task.rotation)
    model = braced.robot.model
    config = pink.Configuration(model, model.createData(), start.q)
    tool = FrameTask(braced.robot.tip, position_cost=1000.0, orientation_cost=0.0)
    tool.set_target(pin.SE3(start.R_e, sc.task.position(0.002)))
    brace = BraceTask(braced, config)
    compliance = ComplianceTask(braced, sc.beta_x(0.0), cost=5.0)
    barriers = [BraceRegionBarrier(braced), LinkClearanceBarrier(braced, config)]
    dt = 0.002
    cases = {
        "pink_frame_task_step_us": lambda: pink.solve_ik(config, [tool], dt, solver="daqp"),
        "pink_brace_step_us": lambda: pink.solve_ik(config, [tool], dt, solver="daqp", constraints=[brace]),
        "pink_brace_compliance_step_us": lambda: pink.solve_ik(
            config, [tool, compliance], dt, solver="daqp", constraints=[brace]
        ),
        "pink_brace_compliance_barriers_step_us": lambda: pink.solve_ik(
            config, [tool, compliance], dt, solver="daqp", constraints=[brace], barriers=barriers
        ),
    }
    for key, fn in cases.items():
        fn()
        out[key] = _median_us(fn, number, repeat)
    for name in ("paper", "panda"):
        sc = load_scenario(name)
        st = solve_start(sc.braced, sc.task.position(0.0), sc.guess, rotation=sc.task.rotation)
        xdot = np.concatenate([sc.task.velocity(0.0), np.zeros(3)])
        for strategy_name in ("braced_gradient_projection", "braced_qp"):
            strategy = sc.strategy(strategy_name)
            q = st.q

            def step(strategy: Any = strategy, q: Any = q, sc: Any = sc, xdot: Any = xdot) -> Any:
                return strategy.velocity(sc.braced.state(q, hessians=strategy.needs_hessians), xdot)

            step()
            out[f"{name}_{strategy_name}_step_us"] = _median_us(step, number // 2 or 1, repeat)
    return out


def qp_table(r: dict[str, Any]) -> list[tuple[str, str, str]]:
    """Rows (what, value, note) for `bracekit bench`."""
    frame = r["pink_frame_task_step_us"]
    rows = [("pink step, FrameTask only (Panda, daqp)", f"{frame:.0f} µs", "pink's own task")]
    for key, label in (
        ("pink_brace_step_us", "+ BraceTask as a hard equality"),
        ("pink_brace_compliance_step_us", "+ ComplianceTask (analytic ∂C_i/∂q)"),
        ("pink_brace_compliance_barriers_step_us", "+ region and clearance barriers"),
    ):
        rows.append((label, f"{r[key]:.0f} µs", f"{r[key] / frame:.1f}× the FrameTask step"))
    for name in ("paper", "panda"):
        gp, qp = r[f"{name}_braced_gradient_projection_step_us"], r[f"{name}_braced_qp_step_us"]
        rows.append((f"{name}: GP step (reference path, with its state)", f"{gp:.0f} µs", ""))
        rows.append((f"{name}: braced_qp step (with its state)", f"{qp:.0f} µs", f"{qp / gp:.1f}× the GP step"))
    return rows


def _limit_margin(robot: Any, q: np.ndarray) -> float:
    """The least distance (rad) of any sample's joint from its URDF range's nearer end (negative: outside)."""
    return float(np.min(np.minimum(q - robot.lower, robot.upper - q)))


def compare_strategies(scenarios: tuple[str, ...] = SCENARIOS) -> list[dict[str, Any]]:
    """One row per scenario and strategy: mean C_i, least link clearance, least joint-limit margin, time per step."""
    import dataclasses

    from bracekit.simulation.run import run_scenario
    from bracekit.simulation.scenario import load_scenario

    rows = []
    for name in scenarios:
        sc = load_scenario(name)
        for strategy in COMPARED:
            one = dataclasses.replace(sc, strategies=[strategy])
            t0 = time.perf_counter()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                res = run_scenario(one, both_models=False)
            wall = time.perf_counter() - t0
            model = next(iter(res.trajectories))
            tr = res.trajectories[model][strategy]
            s = res.summary["strategies"][strategy]
            rows.append(
                {
                    "scenario": name,
                    "strategy": strategy,
                    "completed": bool(s["completed"]),
                    "Ci_mean": s["Ci_mean"],
                    "min_link_clearance_m": s["min_link_clearance_m"],
                    "limit_margin_rad": _limit_margin(sc.braced.robot, tr.q),
                    "max_contact_violation_m": s["max_contact_violation_m"],
                    "ms_per_step": 1e3 * wall / max(tr.steps, 1),
                    "steps": tr.steps,
                }
            )
    return rows


def markdown(rows: list[dict[str, Any]]) -> str:
    """The comparison as a Markdown table."""
    head = (
        "| scenario | strategy | completed | mean C_i (mm/N) | least link clearance (m) | least joint-limit margin "
        "(rad) | contact violation (m) | ms per step |\n|---|---|---|---|---|---|---|---|"
    )
    lines = [head]
    for r in rows:
        clear = "–" if r["min_link_clearance_m"] is None else f"{r['min_link_clearance_m']:.4f}"
        lines.append(
            f"| {r['scenario']} | {r['strategy']} | {'yes' if r['completed'] else 'no'} | {1e3 * r['Ci_mean']:.3f} | "
            f"{clear} | {r['limit_margin_rad']:.3f} | {r['max_contact_violation_m']:.1e} | {r['ms_per_step']:.1f} |"
        )
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--compare", action="store_true", help="run the strategies on every shipped scenario")
    args = ap.parse_args()
    if args.compare:
        print(markdown(compare_strategies()))
        return
    for what, value, note in qp_table(qp_benchmarks(args.quick)):
        print(f"{what:<52} {value:>10}  {note}")


if __name__ == "__main__":
    main()
