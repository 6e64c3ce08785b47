"""tools/slow_tests.py adds each test's setup, call and teardown from pytest's --durations report."""

from __future__ import annotations

import importlib.util
from pathlib import Path


def test_durations_add_the_phases_of_each_test() -> None:
    spec = importlib.util.spec_from_file_location("slow_tests", Path(__file__).parents[1] / "tools" / "slow_tests.py")
    assert spec is not None and spec.loader is not None
    tool = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(tool)
    report = """
============================== slowest durations ===============================
1.50s call     tests/a.py::test_x[1]
0.50s setup    tests/a.py::test_x[1]
0.25s teardown tests/a.py::test_x[1]
3.00s call     tests/b.py::test_y
(12 durations < 0.005s hidden.  Use -vv to show these durations.)
2 passed in 5.30s
"""
    assert tool.durations(report) == {"tests/a.py::test_x[1]": 2.25, "tests/b.py::test_y": 3.0}
