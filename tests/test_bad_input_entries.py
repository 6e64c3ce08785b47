"""The property-based bad-input test (test_bad_input.py) extended to the newer entry points.

Several braces (evaluate, BracedRobot, link-point frames), the statics options of simulate and the start solve,
URDF numbers, the sweep (spec tables and saved rows), the viewer (scene.json values) and the bounded readers:
a bad value gives bracekit's own one-line error, or a result without NaN — never a bare Python, NumPy, SciPy
or Boost error, a RecursionError or a hang.
"""

from __future__ import annotations

import json
import math
import shutil
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import bracekit as bk
from bracekit._io import loads_json, read_toml
from bracekit.errors import InputError
from bracekit.studies.sweep.candidates import expand
from bracekit.studies.sweep.evaluate import empty_row
from bracekit.studies.sweep.rows import row_problem
from bracekit.studies.sweep.spec import parse_spec
from bracekit.viewer.scene import SCENE_FILE, load_scene
from helpers import random_chain_urdf, scenario_text
from test_bad_input import BAD, BRACED, FLOATS, ROBOT, SETTINGS, Q, check
from test_bad_input import ENTRIES as BASE_ENTRIES

SIMULATE = next(valid for name, _, valid, _ in BASE_ENTRIES if name == "simulate")
TWO = ROBOT.with_point_frame("second", "link4", [0.0, 0.0, 0.05])
SECOND = bk.Brace("second", bk.Surface(np.array([0.3, 0.0, 0.2]), np.array([1.0, 0.0, 0.0])))
FIRST = bk.Brace("brace", bk.Surface(np.array([0.70, -0.15, -0.30]), np.array([0.0, 0.0, 1.0])))
NORMALS = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])

ENTRIES: list[tuple[str, Any, dict[str, Any], tuple[str, ...]]] = [
    (
        "evaluate-several-braces",
        bk.evaluate,
        {"robot": TWO, "brace_frame": ["brace", "second"], "q": Q, "normal": NORMALS},
        ("brace_frame", "q", "normal", "beta_x"),
    ),
    ("BracedRobot-several-braces", bk.BracedRobot, {"robot": TWO, "braces": [FIRST, SECOND]}, ("braces",)),
    (
        "with_point_frames",
        ROBOT.with_point_frames,
        {"frames": [("p1", "link4", [0.0, 0.0, 0.05], None), ("p2", "link6", [0.0, 0.1, 0.0], None)]},
        ("frames",),
    ),
    ("simulate-options", bk.simulate, {**SIMULATE, "progress": None}, ("progress",)),
    (
        "solve_start-weights",
        bk.solve_start,
        {"braced": BRACED, "position": np.array([1.34, -0.32, -0.17]), "guess": Q},
        ("region_weight", "posture_weight"),
    ),
]
CASES = [(name, fn, valid, key) for name, fn, valid, keys in ENTRIES for key in keys]


def _slow_but_valid(name: str, key: str, bad: Any) -> bool:
    """A value that is valid and only starts a long computation (a solve from a valid weight)."""
    if name == "solve_start-weights":
        return isinstance(bad, int | float) and not isinstance(bad, bool) and 0.0 <= bad <= 1e6
    return False


@pytest.mark.parametrize(("name", "fn", "valid", "key"), CASES, ids=[f"{c[0]}-{c[3]}" for c in CASES])
@SETTINGS
@given(bad=BAD)
def test_bad_values_of_the_newer_entries_give_bracekit_errors(name: str, fn: Any, valid: dict, key: str, bad: Any):
    if _slow_but_valid(name, key, bad):
        return
    check(lambda: fn(**{**valid, key: bad}))


@SETTINGS
@given(value=st.one_of(FLOATS, st.sampled_from(["nan", "inf", "-1", "1e300", "x", "1 2", ""])), where=st.integers(0, 3))
def test_urdf_numbers_give_model_errors_or_a_valid_robot(value: Any, where: int) -> None:
    text = random_chain_urdf(4, seed=2)
    target = ('<mass value="0.5"/>', 'ixx="0.001"', 'xyz="0.1 0.02 0.03"', 'effort="10"')[where]
    replacement = target.replace(target.split('"')[1], str(value), 1)
    text = text.replace(target, replacement, 1)

    def load() -> Any:
        robot = bk.Robot.from_urdf(text, tip="tip")
        masses = [float(robot.model.inertias[j].mass) for j in range(1, robot.model.njoints)]
        assert all(math.isfinite(m) and m >= 0 for m in masses)
        return robot

    check(load)


# --- the sweep --------------------------------------------------------------------------------------
SPECS = Path(bk.__file__).parent / "studies" / "sweep" / "specs"
SPEC_DATA = read_toml(SPECS / "paper-links.toml", "the shipped spec")
SPEC = parse_spec(SPEC_DATA, base=SPECS, name="paper-links")
SPEC_KEYS = [(table, key) for table, values in SPEC_DATA.items() if isinstance(values, dict) for key in values]


@pytest.mark.parametrize(("table", "key"), SPEC_KEYS, ids=[f"{t}.{k}" for t, k in SPEC_KEYS])
@SETTINGS
@given(bad=BAD)
def test_bad_spec_values_give_one_line_errors(table: str, key: str, bad: Any) -> None:
    data = json.loads(json.dumps(SPEC_DATA))
    data[table][key] = bad

    def parse() -> Any:
        with warnings.catch_warnings():
            return parse_spec(data, base=SPECS, name="fuzzed")

    check(parse)


CANDIDATE = expand(SPEC)[0]
VALID_ROW = empty_row(SPEC, CANDIDATE)


@pytest.mark.parametrize("column", sorted(VALID_ROW))
@SETTINGS
@given(bad=BAD)
def test_a_saved_row_with_a_bad_value_is_judged_never_raises(column: str, bad: Any) -> None:
    assert row_problem(SPEC, CANDIDATE, VALID_ROW) is None
    row = {**VALID_ROW, column: bad}
    try:
        json.dumps(row, allow_nan=True)
    except (TypeError, ValueError):
        return  # a value JSON cannot hold never reaches a saved row
    why = row_problem(SPEC, CANDIDATE, row)
    if why is None:  # accepted: then it is a value of the column's type
        assert bad is None or isinstance(bad, bool | str | int | float)
        assert not (isinstance(bad, float) and not math.isfinite(bad))


@SETTINGS
@given(value=BAD)
def test_row_problem_takes_any_json_value(value: Any) -> None:
    result = row_problem(SPEC, CANDIDATE, value)
    assert result is None or isinstance(result, str)


# --- the viewer and the bounded readers ----------------------------------------------------------------
@pytest.fixture(scope="module")
def run_folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from bracekit.report import write_run

    folder = tmp_path_factory.mktemp("view")
    source = folder / "short.toml"
    source.write_text(scenario_text(turns=0.05, dt=0.1), encoding="utf-8")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = bk.run_scenario(bk.load_scenario(source))
    write_run(result, folder / "out", figures=False)
    return folder / "out"


SCENE_KEYS = [
    ("robot", "stiffness"),
    ("robot", "tip"),
    ("robot", "capsules"),
    ("robot", "pinocchio_model"),
    ("task", "path"),
    ("holding", "preloads"),
    ("holding", "gravity"),
    (None, "braces"),
    (None, "runs"),
    (None, "compliance_model"),
]


@pytest.mark.parametrize(("table", "key"), SCENE_KEYS, ids=[f"{t}.{k}" for t, k in SCENE_KEYS])
@SETTINGS
@given(bad=BAD)
def test_bad_scene_values_give_one_line_input_errors(
    run_folder: Path, tmp_path_factory: pytest.TempPathFactory, table: str | None, key: str, bad: Any
) -> None:
    folder = tmp_path_factory.mktemp("scene") / "out"
    shutil.copytree(run_folder, folder)
    data = json.loads((folder / SCENE_FILE).read_text())
    try:
        (data if table is None else data[table])[key] = json.loads(json.dumps(bad, allow_nan=True))
    except (TypeError, ValueError):
        return
    (folder / SCENE_FILE).write_text(json.dumps(data, allow_nan=True))
    try:
        load_scene(folder)
    except InputError as exc:
        assert str(exc).strip() and "\n" not in str(exc)


@SETTINGS
@given(depth=st.integers(0, 20_000), kind=st.sampled_from("[{"))
def test_the_bounded_json_reader_never_recurses(depth: int, kind: str) -> None:
    text = ('{"a":' * depth + "1" + "}" * depth) if kind == "{" else ("[" * depth + "1" + "]" * depth)
    try:
        loads_json(text, "a test file")
    except InputError as exc:
        assert depth > 32 and "deeper than" in str(exc)
    else:
        assert depth <= 32


def test_the_two_library_reproductions_are_one_line_input_errors() -> None:
    with pytest.raises(InputError, match="progress must be None or a function"):
        bk.simulate(**{**SIMULATE, "progress": 3})
    with pytest.raises(InputError, match=r"region_weight must be a number from 0 to 1e\+06, got 1e\+308"):
        bk.solve_start(BRACED, np.array([1.34, -0.32, -0.17]), Q, region_weight=1e308)
