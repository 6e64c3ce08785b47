"""Shared fixtures (the helpers they use live in helpers.py), and the markers of the slow groups.

Every test is marked here, once, by what it uses (see :func:`pytest_collection_modifyitems`), so a test file
never lists its own groups:

* ``mujoco``: MuJoCo simulations (the module imports mujoco or bracekit.validate beyond its statics, or the test
  runs ``bracekit validate``); ``dask``: a Dask cluster (``bracekit sweep`` on workers); ``browser``: Chromium
  through Playwright; ``docs``: the documentation's commands and site (mkdocs, the tutorial as printed);
  ``numba``: numba-compiled kernels (compiled once per machine into the user cache, then loaded);
* ``slow``: every test of the groups mujoco, dask, browser and docs, and the tests listed in :data:`SLOW` (measured
  with ``--durations=0``: each over about two seconds on 2 cores under load). numba alone is not slow: the
  kernels compile once per machine (about a minute, into the user cache), every later process loads them.

``python -m pytest -m "not slow"`` is the command a developer runs often; CI runs the whole suite.
"""

from __future__ import annotations

import ast
import inspect
import os
import re
from functools import cache
from pathlib import Path

import pytest
from hypothesis import settings

from helpers import random_chain_urdf, scenario_text

# CI runs the property-based tests on a fixed sequence of examples (reproducible); local runs explore anew.
settings.register_profile("ci", derandomize=True)
if os.environ.get("CI"):
    settings.load_profile("ci")

TESTS = Path(__file__).resolve().parent
#: The groups that make a test slow by themselves.
SLOW_GROUPS = ("mujoco", "dask", "browser", "docs")
#: Modules whose import puts every test of the importing module in a group (a prefix matches submodules).
MODULE_GROUPS = {
    "mujoco": ("mujoco", "bracekit.validate"),
    "dask": ("distributed", "dask"),
    "browser": ("playwright",),
    "docs": ("mkdocs",),
}
#: Modules that do not put a test in the group of a longer prefix above (pure NumPy/Pinocchio statics).
MODULE_EXCEPTIONS = ("bracekit.validate.statics",)
#: What in a test's source (or its fixtures' source) puts it in a group.
SOURCE_GROUPS = {
    "mujoco": re.compile(r"\bmujoco\b|\[\s*\"validate\"|run_validation\b|validate_several_braces|run_\w+_validation"),
    "dask": re.compile(r"\bdask_client\(|\bLocalCluster\b|\bclient2\b|\"--workers\"|sweep_runs\("),
    "browser": re.compile(r"\bplaywright\b|\bchromium\b"),
    "docs": re.compile(r"\bmkdocs\b|exec\(compile\(|_tutorial_commands\(|\bEXAMPLES\b"),
    "numba": re.compile(r"backend=\"numba\"|importorskip\(\"(numba|bracekit\.\w+\._numba\w*)\"\)|\bnumba_step\b"),
}
#: Tests slow on their own (a prefix of file::name), measured with --durations=0 (2 cores, load 5–9, warm numba
#: cache; seconds in the comments): whole runs with every figure and the animation, the benchmark's smoke test.
SLOW: tuple[str, ...] = (
    "tests/report/test_figures.py::test_the_animation_drawn_in_a_child_process_is_the_one_drawn_in_process",  # 18.6
    "tests/report/test_figures.py::test_every_shipped_scenario_is_drawn",  # 4.7–11.4 each of 4
    "tests/report/test_figures.py::test_a_failure_in_the_child_is_raised_and_nothing_is_written",  # 6.5, 8.0
    "tests/report/test_figures.py::test_ellipsoid_figure_has_metric_axes_and_no_overlapping_text",  # 3.4
    "tests/report/test_figures.py::test_a_run_that_stopped_early_and_a_single_strategy_are_drawn",  # 2.2
    "tests/report/test_report.py::test_write_run_writes_every_file_and_summary_matches_the_result",  # 7.4
    "tests/report/test_report.py::test_a_rerun_without_figures_removes_the_previous_runs_figures",  # 7.4
    "tests/report/test_report.py::test_capacity_figure_is_drawn_for_a_run_with_statics",  # 2.6
    "tests/test_bench.py::test_run_benchmarks_returns_positive_finite_numbers_and_a_table",  # 30 with its fixture
    "tests/test_bench.py::test_robotics_toolbox_is_optional",  # the same fixture: bracekit bench --quick
    "tests/test_bench.py::test_both_backends_side_by_side",
    "tests/test_bench.py::test_table_without_numba",
    "tests/test_bench_runs.py::test_the_baseline_script_measures_a_checkout_in_a_new_process",  # whole runs
    "tests/test_bench_runs.py::test_bench_with_runs_prints_the_ratios_and_goals_against_a_file",  # whole runs
)


@cache
def _module_imports(path: Path) -> frozenset[str]:
    """Every module a test file imports, at any depth of its code."""
    try:
        tree = ast.parse(path.read_text(encoding="utf-8"))
    except (OSError, SyntaxError):
        return frozenset()
    names: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module)
    return frozenset(names)


def _module_groups(path: Path) -> set[str]:
    groups = set()
    for name in _module_imports(path):
        if name.startswith(MODULE_EXCEPTIONS):
            continue
        for group, prefixes in MODULE_GROUPS.items():
            if any(name == p or name.startswith(p + ".") for p in prefixes):
                groups.add(group)
    return groups


@cache
def _source(obj: object) -> str:
    try:
        return inspect.getsource(obj)  # type: ignore[arg-type]
    except (OSError, TypeError):
        return ""


def _item_source(item: pytest.Function) -> str:
    """The test function's source and that of every fixture it uses that lives in the tests folder."""
    parts = [_source(getattr(item, "function", None))]
    info = getattr(item, "_fixtureinfo", None)  # pytest's record of the fixtures a test uses
    for defs in info.name2fixturedefs.values() if info is not None else ():
        for fixturedef in defs:
            func = fixturedef.func
            if TESTS in Path(inspect.getsourcefile(func) or "/").resolve().parents:
                parts.append(_source(func))
    return "\n".join(parts)


def groups_of(item: pytest.Item) -> set[str]:
    """The groups of a test: by its module's imports, its source and its fixtures' source."""
    path = Path(str(item.path)).resolve()
    groups = _module_groups(path)
    if isinstance(item, pytest.Function):
        text = _item_source(item)
        groups |= {group for group, pattern in SOURCE_GROUPS.items() if pattern.search(text)}
    return groups


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    for item in items:
        groups = groups_of(item)
        rel = Path(str(item.path)).resolve().relative_to(TESTS.parent).as_posix()
        slow = bool(groups & set(SLOW_GROUPS)) or any(f"{rel}::{item.name}".startswith(s) for s in SLOW)
        for group in sorted(groups):
            item.add_marker(getattr(pytest.mark, group))
        if slow:
            item.add_marker(pytest.mark.slow)


@pytest.fixture
def chain_urdf() -> str:
    """A 9-joint random chain braced on link 5 (n1 = 5 is not 6 on purpose)."""
    return random_chain_urdf(9, seed=3, brace_link=5)


# --- helpers of the core-model tests (test_robot, test_kinematics, test_compliance, test_objective) ---
@pytest.fixture
def short_scenario_file(tmp_path: Path) -> Path:
    """The paper scenario cut to its first 2 s (a tenth of the circle, 20 steps of 0.1 s per strategy)."""
    path = tmp_path / "short.toml"
    path.write_text(scenario_text(turns=0.1, dt=0.1), encoding="utf-8")
    return path
