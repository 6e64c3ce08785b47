"""The numbers behind docs/model.md sections 11 and 12: what C_i, c_t and C_e[2,2] say, and the tool stiffness.

Usage: ``python tools/directional_numbers.py [SCENARIO ...]`` (default: paper panda). For each scenario:

* along every strategy's run (the constrained model): mean C_i = ‖β_xᵀC_e‖ (the paper's index, mixed units),
  mean c_t = β_xᵀC_ttβ_x (m/N) and mean C_e[2,2] (vertical force → vertical displacement), in mm/N;
* at the start configuration: the first-order and the preloaded (P = 20 N, gravity, a dead tool force and
  moment) tool stiffness, its asymmetry before the symmetrisation, ‖K_x C − I‖ against the compliance it
  inverts, the relative error of K_x⁻¹ against central differences (±10 mN, ±10 mN·m) of the nonlinear
  static solve, and a world → tool → world round trip.
"""

from __future__ import annotations

import sys

import numpy as np

from bracekit.compliance import end_effector_compliance, free_space_compliance, preloaded_compliance
from bracekit.compliance.directional import directional_compliances
from bracekit.compliance.stiffness import tool_stiffness
from bracekit.simulation import load_scenario, solve_start
from bracekit.simulation.run import run_scenario
from bracekit.validate.statics import solve_static_equilibrium

TOOL = np.array([3.0, -2.0, -5.0, 0.3, 0.2, -0.4])  # N, N·m
H = 1e-2


def path_means(name: str) -> None:
    """Mean C_i, c_t and C_e[2,2] (mm/N) along each strategy's run of the scenario, constrained model."""
    result = run_scenario(name, compliance_model="constrained", both_models=False)
    sc = result.scenario
    print(f"{name}: along the task (constrained model; free space: J K⁻¹ Jᵀ), mm/N")
    print(f"  {'strategy':<28} {'mean C_i':>9} {'mean c_t':>9} {'mean C_e[2,2]':>14}")
    for strategy, tr in result.trajectories["constrained"].items():
        rows = []
        for t, q in zip(tr.t, tr.q, strict=True):
            st = sc.braced.state(q)
            c = end_effector_compliance(st) if tr.braced else free_space_compliance(st)
            d = directional_compliances(c, sc.beta_x(float(t)))
            rows.append((d.Ci, np.nan if d.c_t is None else d.c_t, c[2, 2]))
        m = 1e3 * np.nanmean(np.array(rows), axis=0)
        print(f"  {strategy:<28} {m[0]:9.4f} {m[1]:9.4f} {m[2]:14.4f}")


def static_compliance(braced, q, preload: float, gravity: bool, tool: np.ndarray | None) -> np.ndarray:
    """Central differences of the nonlinear static solve's tip deflection (6×6, world axes)."""
    robot, brace = braced.robot, braced.brace
    args = (robot.model, q, robot.stiffness, braced.brace_id, robot.tip_id, brace.surface.point, brace.surface.normal)
    kw = {"preload": preload, "gravity": gravity, "base_wrench": tool, "constraint_wrenches": braced.split.X}
    plus = [solve_static_equilibrium(*args, H * e, **kw).deflection for e in np.eye(6)]
    minus = [solve_static_equilibrium(*args, -H * e, **kw).deflection for e in np.eye(6)]
    return (np.array(plus) - np.array(minus)).T / (2 * H)


def rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.linalg.norm(a - b) / np.linalg.norm(b))


def stiffness_checks(name: str) -> None:
    """The tool stiffness at the scenario's start: symmetry, inverse, static-solve FD and frame round trip."""
    sc = load_scenario(name)
    q = solve_start(sc.braced, sc.task.position(0.0), sc.guess).q
    st = sc.braced.state(q)
    print(f"{name}: tool stiffness at the start configuration")
    for label, kw in (
        ("first order", {}),
        ("P = 20 N, gravity", {"preload": 20.0, "gravity": True}),
        ("P = 20 N, gravity, tool f and m", {"preload": 20.0, "gravity": True, "wrench": TOOL}),
    ):
        k = tool_stiffness(st, **kw)
        p, g, w = kw.get("preload", 0.0), kw.get("gravity", False), kw.get("wrench")
        c = (
            end_effector_compliance(st)
            if not kw
            else preloaded_compliance(sc.braced, q, float(p), gravity=bool(g), wrench=w)  # type: ignore[arg-type]
        )
        c_fd = static_compliance(sc.braced, q, float(p), bool(g), w)  # type: ignore[arg-type]
        tool = k.in_frame("tool", st.R_e)
        print(
            f"  {label:<32} asymmetry {k.asymmetry:.2e}  |K C − I| {np.linalg.norm(k.K @ c - np.eye(6)):.1e}  "
            f"K⁻¹ vs static FD {rel(np.linalg.inv(k.K), c_fd):.1e}  K_sym⁻¹ vs static FD "
            f"{rel(np.linalg.inv(k.K_sym), c_fd):.1e}  round trip {rel(tool.in_frame('world').K, k.K):.1e}"
        )


if __name__ == "__main__":
    for scenario in sys.argv[1:] or ["paper", "panda"]:
        path_means(scenario)
        stiffness_checks(scenario)
