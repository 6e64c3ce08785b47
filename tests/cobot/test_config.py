"""The cobot scenario file: the shipped one loads, bad keys are refused by name."""

import tomllib

import pytest

from bracekit.cobot.config import load_cobot, parse_cobot, shipped_cobots
from bracekit.errors import ScenarioError


def _data() -> tuple[dict, object]:
    path = shipped_cobots()["panda-cobot"]
    return tomllib.loads(path.read_text(encoding="utf-8")), path


def test_shipped_scenario_loads() -> None:
    sc = load_cobot("panda-cobot")
    assert sc.base.name == "panda" and sc.operator.targets.shape == (3, 3)
    assert sc.dt == pytest.approx(1e-3) and round(sc.dt / sc.physics_dt) == 4
    assert sc.duration == pytest.approx(3 * (sc.operator.travel + sc.operator.approach + sc.operator.dwell))


@pytest.mark.parametrize(
    ("table", "key", "value", "message"),
    [
        ("operator", "stiffnes", 1.0, "unknown key 'operator.stiffnes'"),
        ("operator", "stiffness", -1.0, "operator.stiffness"),
        ("control", "physics_dt", 3e-4, "must divide the control period"),
        ("control", "strategies", ["nope"], "control.strategies"),
        ("process", "hold", 10.0, "shorter than the work"),
    ],
)
def test_bad_keys_are_named(table: str, key: str, value: object, message: str) -> None:
    data, path = _data()
    data[table][key] = value
    with pytest.raises(ScenarioError, match=message):
        parse_cobot(data, path)  # type: ignore[arg-type]


def test_missing_file_is_one_line() -> None:
    with pytest.raises(ScenarioError, match="cobot scenario not found"):
        load_cobot("no-such-cobot")
