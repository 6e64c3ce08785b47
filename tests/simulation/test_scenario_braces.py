"""Scenario files with several braces ([[brace]]): parsing, and one-line errors that name the brace."""

from __future__ import annotations

import copy
import tomllib
from typing import Any

import numpy as np
import pinocchio as pin
import pytest

from bracekit.errors import ScenarioError
from bracekit.simulation.scenario import parse_scenario
from helpers import PAPER_TOML

PAPER: dict[str, Any] = tomllib.loads(PAPER_TOML.read_text(encoding="utf-8"))
SECOND = {"link": "link8", "offset": [0.1, 0.0, 0.05], "point": [0.9, -0.1, -0.1], "normal": [1.0, 0.0, 0.0]}


def _two_braces(**second: Any) -> dict[str, Any]:
    """The paper scenario with its brace and a link point on link8 as [[brace]], θ_z and d unweighted."""
    data = copy.deepcopy(PAPER)
    first = {k: v for k, v in data["brace"].items()}
    data["brace"] = [first, {**SECOND, **second}]
    data["gradient_projection"]["weights"] = {"Ci": 100.0}
    return data


def _error(data: dict[str, Any]) -> str:
    with pytest.raises(ScenarioError) as caught:
        parse_scenario(data)
    message = str(caught.value)
    assert "\n" not in message
    return message


def test_two_braces_on_the_paper_robot_give_the_stacked_model() -> None:
    sc = parse_scenario(_two_braces())
    braces = sc.braced.braces
    assert [b.frame for b in braces] == ["brace", "brace_2"]
    assert np.allclose(braces[0].surface.normal, [0, 0, 1]) and np.allclose(braces[1].surface.normal, [1, 0, 0])
    assert np.allclose(braces[1].surface.point, SECOND["point"]) and braces[0].region_radius == 0.15
    assert braces[1].pad_axis is False and braces[1].region_radius is None
    # the link point is where Pinocchio puts link8's frame, offset in link axes
    robot = sc.robot
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, sc.guess)
    expected = data.oMf[robot.frame_id("link8")].act(np.array(SECOND["offset"]))
    state = sc.braced.state(sc.guess)
    assert np.allclose(state.b_i[1], expected, atol=1e-12)
    assert state.G.shape == (2, 11) and state.constraint.rank == 2
    assert sc.compliance_model == "constrained" and sc.weights["theta_z"] == 0.0 and sc.weights["d"] == 0.0
    assert sc.start_theta_weight == 0.0 and not sc.holding.active


def test_a_link_point_brace_keeps_the_frame_it_is_given() -> None:
    sc = parse_scenario(_two_braces(frame="pad_8", contact="point_with_friction"))
    assert [b.frame for b in sc.braced.braces] == ["brace", "pad_8"]
    assert sc.braced.braces[1].contact.name == "point_with_friction"


@pytest.mark.parametrize(
    ("second", "fragment"),
    [
        ({"normal": [0.0, 0.0, 0.0]}, "'brace[2].normal'"),
        ({"colour": "red"}, "'brace[2].colour'"),
        ({"point": [1.0, 2.0]}, "'brace[2].point'"),
        ({"link": "nowhere"}, "'brace[2].link'"),
        ({"frame": "brace"}, "'brace[2].frame'"),
        ({"preload": -5.0}, "'brace[2].preload'"),
        ({"friction": -0.5}, "'brace[2].friction'"),
        ({"environment_stiffness": -1.0}, "'brace[2].environment_stiffness'"),
        ({"pad_axis": [0.0, 0.0, 0.0]}, "'brace[2].pad_axis'"),
    ],
)
def test_a_bad_key_of_one_brace_names_its_index(second: dict[str, Any], fragment: str) -> None:
    assert fragment in _error(_two_braces(**second))


def test_a_bad_first_brace_names_index_one() -> None:
    data = _two_braces()
    data["brace"][0]["frame"] = "nowhere"
    assert "'brace[1].frame'" in _error(data)
    data = _two_braces()
    del data["brace"][0]["point"]
    assert "missing key 'brace[1].point'" in _error(data)


@pytest.mark.parametrize(
    ("edit", "fragment"),
    [
        (lambda d: d["compliance"].update(model="projection"), "'compliance.model'"),
    ],
)
def test_several_braces_refuse_what_only_one_brace_supports(edit: Any, fragment: str) -> None:
    data = _two_braces()
    edit(data)
    message = _error(data)
    assert fragment in message and "one brace" in message


def test_several_braces_take_every_term_with_a_meaning_for_them_one_per_brace_where_it_is_per_brace() -> None:
    data = _two_braces()
    data["gradient_projection"]["weights"].update(k=0.5, clearance=0.1, joint_limit_barrier=0.01, d=0.01)
    data["start"].update(theta_weight=0.0)
    objective = parse_scenario(data).objective()
    count = len(data["brace"])
    names = objective.names
    assert "k" in names and "joint_limit_barrier" in names
    assert [n for n in names if n.startswith("clearance_")] == [f"clearance_{i}" for i in range(count)]
    assert sum(n.startswith("d_") for n in names) == sum("region_radius" in b for b in data["brace"])


def test_several_braces_take_a_preload_and_friction_each_and_shared_gravity_and_loads() -> None:
    data = _two_braces(preload=5.0, friction=0.5)
    data["brace"][0]["preload"] = 20.0
    data["robot"]["gravity"] = True
    data["loads"] = {"wrenches": [[0.0, 0.0, -1.0, 0.0, 0.0, 0.0]]}
    h = parse_scenario(data).holding
    assert h.gravity and h.brace_preloads(2) == (20.0, 5.0) and h.brace_frictions(2) == (None, 0.5)
    assert h.wrenches is not None and h.wrenches.shape == (1, 6)


def test_an_empty_brace_array_is_refused() -> None:
    data = copy.deepcopy(PAPER)
    data["brace"] = []
    assert "at least one [[brace]]" in _error(data)


def test_one_brace_table_is_unchanged_and_one_array_entry_is_the_same_model() -> None:
    table = parse_scenario(copy.deepcopy(PAPER))
    data = copy.deepcopy(PAPER)
    data["brace"] = [data["brace"]]
    array = parse_scenario(data)
    assert table.braced.split.n1 == array.braced.split.n1 == 6
    assert table.braced.brace.frame == array.braced.brace.frame == "brace"
    assert np.array_equal(table.braced.brace.surface.point, array.braced.brace.surface.point)
    assert table.weights == array.weights and table.start_theta_weight == array.start_theta_weight == 0.3
    bad = copy.deepcopy(PAPER)
    bad["brace"]["normal"] = [0.0, 0.0, 0.0]
    assert _error(bad).startswith("'brace.normal' must be a non-zero vector")
    bad["brace"] = [bad["brace"]]
    assert _error(bad).startswith("'brace[1].normal' must be a non-zero vector")
