"""Ratios between two benchmark results (two versions, or two machines), and the speed goals as pass/fail rows.

:func:`compare` takes two JSON objects written by ``bracekit bench --json`` or tools/bench_baseline.py and returns
a :class:`Comparison`: for every number both hold under the same key, new, old and new/old (for a time, below 1
is faster; for a rate, above 1), both machines (cores, load, CPU model, date, commit), and the goals of
:data:`GOALS` that the two results can decide. A ratio between two machines, or two loads, says as much about
the machines as about the versions: the machines are printed above the ratios for that reason.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any, NamedTuple

#: Keys that are not measurements (their numbers are settings or bookkeeping).
NOT_MEASURED = frozenset(
    {"quick", "rounds", "sweep_candidates", "scenario_exit_code", "gp_step_split_n1", "benchmark_wall_s"}
)


class Goal(NamedTuple):
    """A speed goal: `key` of the new result against `reference` (a key of the old, or of the new) and a bound."""

    name: str
    key: str
    reference: str
    against_old: bool  # True: reference is read from the old result (a speed-up); False: from the new one
    speedup: bool  # True: old/new for times (or new/old for rates) ≥ bound; False: new/reference ≤ bound
    bound: float


#: The speed goals: whole runs (wall, and CPU seconds) and the sweep ×5 against the old result, the sweep's scaling
#: from 1 to 2 workers, the control-rate step within 10× Pinocchio's FK + J + Hessian floor (one brace; two
#: braces when measured), and a step of a two-brace run at most twice a step of a one-brace run.
GOALS = (
    Goal("paper run ×5 faster (wall)", "run_paper_s", "run_paper_s", True, True, 5.0),
    Goal("two-braces run ×5 faster (wall)", "run_two_braces_s", "run_two_braces_s", True, True, 5.0),
    # the same in CPU seconds of the process, which the machine's other load changes least
    Goal("paper run ×5 faster (CPU)", "run_paper_cpu_s", "run_paper_cpu_s", True, True, 5.0),
    Goal("two-braces run ×5 faster (CPU)", "run_two_braces_cpu_s", "run_two_braces_cpu_s", True, True, 5.0),
    Goal("sweep on 2 workers ×5 faster", "sweep_candidates_per_s_2", "sweep_candidates_per_s_2", True, True, 5.0),
    Goal("sweep scaling 1 → 2 workers ≥ 1.8", "sweep_candidates_per_s_2", "sweep_candidates_per_s_1", False, True, 1.8),
    Goal("control step ≤ 10× Pinocchio floor", "control_step_us", "pinocchio_floor_us", False, False, 10.0),
    Goal(
        "control step, two braces ≤ 10× floor",
        "control_step_two_braces_us",
        "pinocchio_floor_two_braces_us",
        False,
        False,
        10.0,
    ),
    Goal(
        "two-braces run step ≤ 2× a one-brace run step",
        "run_step_two_braces_us",
        "run_step_one_brace_us",
        False,
        False,
        2.0,
    ),
)


class Row(NamedTuple):
    key: str
    new: float
    old: float
    ratio: float  # new / old


class GoalRow(NamedTuple):
    name: str
    value: float  # the speed-up (old/new of a time, new/old of a rate) or the ratio to the reference
    bound: float
    at_least: bool  # the goal is value ≥ bound (else value ≤ bound)
    passed: bool


class Comparison(NamedTuple):
    rows: list[Row]
    goals: list[GoalRow]
    new_machine: dict[str, Any]
    old_machine: dict[str, Any]


def load(path: Path) -> dict[str, Any]:
    """A result written by ``bracekit bench --json`` or tools/bench_baseline.py; InputError in one line if not."""
    from bracekit.errors import InputError

    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise InputError(f"cannot read {path}: {exc.strerror or exc}") from None
    except json.JSONDecodeError as exc:
        msg = f"{path} is not JSON ({exc.msg} at line {exc.lineno}); give a file of bracekit bench --json"
        raise InputError(msg) from None
    if not isinstance(data, dict):
        raise InputError(f"{path} holds no benchmark object; give a bracekit bench --json file")
    return data


def numbers(result: dict[str, Any]) -> dict[str, float]:
    """The top-level measurements of a result: finite positive numbers (not booleans, not settings)."""
    out = {}
    for key, value in result.items():
        if key in NOT_MEASURED or isinstance(value, bool) or not isinstance(value, int | float):
            continue
        if math.isfinite(value) and value > 0:
            out[key] = float(value)
    return out


def _is_rate(key: str) -> bool:
    return "_per_s" in key


def _goal(goal: Goal, new: dict[str, float], old: dict[str, float]) -> GoalRow | None:
    ref_side = old if goal.against_old else new
    if goal.key not in new or goal.reference not in ref_side:
        return None
    value, ref = new[goal.key], ref_side[goal.reference]
    if goal.speedup:
        factor = value / ref if _is_rate(goal.key) else ref / value
        return GoalRow(goal.name, factor, goal.bound, True, factor >= goal.bound)
    factor = value / ref
    return GoalRow(goal.name, factor, goal.bound, False, factor <= goal.bound)


def compare(new: dict[str, Any], old: dict[str, Any]) -> Comparison:
    """Ratios new/old of every measurement both results hold, and the goals they decide."""
    a, b = numbers(new), numbers(old)
    rows = [Row(k, a[k], b[k], a[k] / b[k]) for k in sorted(a.keys() & b.keys())]
    goals = [g for g in (_goal(goal, a, b) for goal in GOALS) if g is not None]
    return Comparison(rows, goals, dict(new.get("machine") or {}), dict(old.get("machine") or {}))


def as_dict(c: Comparison) -> dict[str, Any]:
    """The comparison as JSON-ready lists of objects (for ``bracekit bench --json``)."""
    return {
        "ratios": [r._asdict() for r in c.rows],
        "goals": [g._asdict() for g in c.goals],
        "old_machine": c.old_machine,
    }


def _machine_line(label: str, m: dict[str, Any]) -> str:
    if not m:
        return f"{label}: machine not recorded"
    load = m.get("load_average")
    after = m.get("load_average_after")
    loads = f"load {load[0]:.2f}" if load else "load ?"
    if after:
        loads += f" → {after[0]:.2f}"
    commit = (m.get("commit") or "?")[:12]
    where = f"{m.get('cores', '?')} cores, {loads}, {m.get('cpu_model', '?')}"
    return f"{label}: commit {commit}, {m.get('date_utc', '?')}, {where}"


def table(c: Comparison, new_label: str = "new", old_label: str = "old") -> str:
    """The comparison as text: both machines, one row per common key, then the goals with pass/fail."""
    lines = [_machine_line(new_label, c.new_machine), _machine_line(old_label, c.old_machine), ""]
    if c.rows:
        w = max(len(r.key) for r in c.rows)
        lines.append(f"| {'key':<{w}} | {new_label:>12} | {old_label:>12} | {'new/old':>8} |")
        lines.append(f"|{'-' * (w + 2)}|{'-' * 13}:|{'-' * 13}:|{'-' * 9}:|")
        lines += [f"| {r.key:<{w}} | {r.new:>12.4g} | {r.old:>12.4g} | {r.ratio:>8.3f} |" for r in c.rows]
        lines.append("(times: new/old below 1 is faster; rates, *_per_s: above 1 is faster)")
    else:
        lines.append("no measurement in common")
    if c.goals:
        lines.append("")
        for g in c.goals:
            sign = "≥" if g.at_least else "≤"
            lines.append(f"{'PASS' if g.passed else 'FAIL'}: {g.name}: {g.value:.2f} (goal {sign} {g.bound:g})")
    return "\n".join(lines)
