"""Scenario files: the shipped paper scenario, and one-line errors that name the key."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from bracekit import Circle, load_scenario
from bracekit.errors import ScenarioError
from bracekit.simulation.scenario import parse_scenario, shipped_scenarios
from helpers import PAPER_TOML, scenario_text


def test_paper_scenario_matches_the_paper_setup() -> None:
    sc = load_scenario("paper")
    assert "paper" in shipped_scenarios()
    assert sc.robot.n == 11 and sc.braced.split.n1 == 6 and sc.braced.split.n2 == 5
    assert np.all(sc.robot.stiffness == 170.0)
    assert sc.braced.brace.contact.name == "frictionless_point"
    assert np.allclose(sc.braced.brace.surface.normal, [0, 0, 1])  # horizontal plane
    assert isinstance(sc.task, Circle) and abs(sc.task.normal[2]) < 1e-12  # vertical circle
    assert sc.alpha == -1.0
    assert sc.weights == {
        "k": 0.5,
        "Ci": 100.0,
        "ct": 0.0,
        "theta_z": 0.6,
        "d": 0.01,
        "joint_limits": 0.0,
        "joint_limit_barrier": 0.0,
        "brace_margin": 0.0,
        "clearance": 0.0,
        "conditioning": 0.0,
    }
    # radial β_x: unit, in the circle plane, pointing from the centre to the desired point
    for t in (0.0, 5.0, 12.5):
        beta = sc.beta_x(t)
        radial = sc.task.position(t) - sc.task.centre
        assert np.allclose(beta[:3], radial / np.linalg.norm(radial)) and np.allclose(beta[3:], 0)


def test_scenario_loads_from_a_path_too(tmp_path: Path) -> None:
    p = tmp_path / "mine.toml"
    p.write_text(PAPER_TOML.read_text(), encoding="utf-8")
    assert load_scenario(p).robot.n == 11


def _edit(text: str, old: str, new: str) -> str:
    assert old in text
    return text.replace(old, new, 1)


@pytest.mark.parametrize(
    ("old", "new", "fragment"),
    [
        ("period = 20.0", "periodd = 20.0", "task.periodd"),
        ("radius = 0.10", 'radius = "big"', "task.radius"),
        ("alpha = -1.0", "alpha = 1.0", "alpha"),
        ('model = "constrained"', 'model = "exact"', "compliance.model"),
        ('frame = "brace"', 'frame = "elbow_pad"', "elbow_pad"),
        ('type = "circle"', 'type = "spiral"', "task.type"),
        ("normal = [0.0, 0.0, 1.0]", "normal = [0.0, 0.0, 0.0]", "normal"),
        ("stiffness = 170.0", "stiffness = -1.0", "robot.stiffness"),
        ('strategies = ["free_space_min_norm"', 'strategies = ["teleport"', "simulation.strategies"),
        ("dt = 0.05", "dt = 0", "simulation.dt"),
        ("dt = 0.05", "dt = 1e9", "simulation.dt"),
        ("dt = 0.05", "dt = 1e-7", "simulation.dt"),
        ("dt = 0.05", "dt = 0.05\nfeedback_gain = -50", "feedback_gain"),
        ("period = 20.0", "period = -20.0", "task.period"),
        ('model = "paper-robot"', 'model = "kuka"', "robot.model"),
        ("guess = [0.0,", "guess = [", "start.guess"),
    ],
)
def test_scenario_mistakes_give_one_line_errors_naming_the_key(
    tmp_path: Path, old: str, new: str, fragment: str
) -> None:
    p = tmp_path / "bad.toml"
    p.write_text(_edit(PAPER_TOML.read_text(), old, new), encoding="utf-8")
    with pytest.raises(ScenarioError) as info:
        load_scenario(p)
    msg = str(info.value)
    assert fragment in msg and "\n" not in msg


def test_radial_beta_needs_a_circle_task() -> None:
    import tomllib

    data = tomllib.loads(scenario_text())
    data["task"] = {"type": "line", "start": [1.2, -0.3, -0.1], "end": [1.3, -0.3, -0.1], "duration": 1.0}
    with pytest.raises(ScenarioError, match="radial"):
        parse_scenario(data)
    data["compliance"]["beta_x"] = [1, 0, 0, 0, 0, 0]
    assert parse_scenario(data).beta_x(0.3).tolist() == [1, 0, 0, 0, 0, 0]


def test_missing_file_and_invalid_toml_are_scenario_errors(tmp_path: Path) -> None:
    with pytest.raises(ScenarioError, match="not found"):
        load_scenario(tmp_path / "nope.toml")
    bad = tmp_path / "broken.toml"
    bad.write_text("[robot\nmodel = 1", encoding="utf-8")
    with pytest.raises(ScenarioError, match="not valid TOML"):
        load_scenario(bad)


def test_brace_can_be_placed_at_a_link_point_and_urdf_paths_are_relative_to_the_file(tmp_path: Path) -> None:
    from bracekit.model.shipped import model_path

    (tmp_path / "robot.urdf").write_text(model_path("paper-robot").read_text(), encoding="utf-8")
    text = scenario_text()
    text = _edit(text, 'model = "paper-robot"', 'urdf = "robot.urdf"')
    text = _edit(
        text, 'frame = "brace"', 'frame = "pad"\nlink = "link6"\noffset = [0.0, 0.0, 0.05]\npad_axis = [0.0, 0.0, -2.0]'
    )
    p = tmp_path / "custom.toml"
    p.write_text(text, encoding="utf-8")
    sc = load_scenario(p)
    assert sc.braced.brace.pad_axis and sc.start_theta_weight == 0.3
    q = sc.guess
    # the new frame is the URDF's own brace frame (same link, same offset, z_b = −z_flange)
    ref = load_scenario("paper").braced.state(q)
    st = sc.braced.state(q)
    assert np.allclose(st.split.b, ref.split.b, atol=1e-12)
    np.testing.assert_allclose(st.split.R_b, ref.split.R_b, atol=1e-12)


def _link_point_scenario(tmp_path: Path, extra: str = "", weights: str | None = None, start: str = "") -> Path:
    text = _edit(scenario_text(), 'frame = "brace"', f'frame = "pad"\nlink = "link6"\noffset = [0.0, 0.0, 0.05]{extra}')
    if weights is not None:
        text = _edit(text, "theta_z = 0.6", weights)
    if start:
        text = _edit(text, "[start]", f"[start]\n{start}")
    p = tmp_path / "link_point.toml"
    p.write_text(text, encoding="utf-8")
    return p


def test_a_link_point_brace_without_pad_axis_refuses_a_theta_z_weight_naming_the_key_and_the_fix(
    tmp_path: Path,
) -> None:
    with pytest.raises(ScenarioError) as info:
        load_scenario(_link_point_scenario(tmp_path))
    msg = str(info.value)
    assert "'gradient_projection.weights.theta_z'" in msg and "'brace.pad_axis'" in msg and "theta_z = 0" in msg


def test_a_link_point_brace_without_pad_axis_has_no_theta_z_anywhere(tmp_path: Path) -> None:
    sc = load_scenario(_link_point_scenario(tmp_path, weights="theta_z = 0.0"))
    assert not sc.braced.brace.pad_axis
    assert sc.start_theta_weight == 0.0
    assert all(t.key != "theta_z" for t in sc.objective().terms)
    with pytest.raises(ScenarioError, match=r"'start\.theta_weight'"):
        load_scenario(_link_point_scenario(tmp_path, weights="theta_z = 0.0", start="theta_weight = 0.3"))


@pytest.mark.parametrize(
    ("start", "weights", "expected"),
    [("", None, 0.3), ("", "theta_z = 0.0", 0.0), ("theta_weight = 0.7", None, 0.7), ("theta_weight = 0", None, 0.0)],
)
def test_the_start_theta_weight_follows_the_scenario(
    tmp_path: Path, start: str, weights: str | None, expected: float
) -> None:
    sc = load_scenario(_link_point_scenario(tmp_path, "\npad_axis = [1.0, 0.0, 0.0]", weights, start))
    assert sc.start_theta_weight == expected
    assert sc.braced.brace.pad_axis


@pytest.mark.parametrize(
    ("extra", "fragment"),
    [
        ("\npad_axis = [0.0, 0.0, 0.0]", "'brace.pad_axis'"),
        ("\npad_axis = [1.0, 0.0]", "'brace.pad_axis'"),
    ],
)
def test_a_bad_pad_axis_is_refused_naming_the_key(tmp_path: Path, extra: str, fragment: str) -> None:
    with pytest.raises(ScenarioError, match=fragment):
        load_scenario(_link_point_scenario(tmp_path, extra))


def test_a_pad_axis_goes_with_a_link_point_only(tmp_path: Path) -> None:
    text = _edit(scenario_text(), 'frame = "brace"', 'frame = "brace"\npad_axis = [0.0, 0.0, 1.0]')
    p = tmp_path / "frame_pad.toml"
    p.write_text(text, encoding="utf-8")
    with pytest.raises(ScenarioError, match=r"'brace\.pad_axis'"):
        load_scenario(p)


def test_region_barrier_weight_needs_a_region(tmp_path: Path) -> None:
    text = _edit(scenario_text(), "region_radius = 0.15", "")
    p = tmp_path / "noregion.toml"
    p.write_text(text, encoding="utf-8")
    with pytest.raises(ScenarioError, match="region_radius"):
        load_scenario(p)


def test_a_scenario_without_region_and_without_the_barrier_term_builds_its_objective(tmp_path: Path) -> None:
    text = _edit(scenario_text(), "region_radius = 0.15", "")
    text = _edit(text, "d = 0.01", "d = 0.0")
    p = tmp_path / "noregion.toml"
    p.write_text(text, encoding="utf-8")
    sc = load_scenario(p)
    assert sc.objective().names == ("k", "Ci", "theta_z")


class _Fspath:
    """An os.PathLike that is not a pathlib.Path."""

    def __init__(self, path: Path) -> None:
        self.path = path

    def __fspath__(self) -> str:
        return str(self.path)


def test_scenario_loads_from_any_os_pathlike(tmp_path: Path) -> None:
    p = tmp_path / "mine.toml"
    p.write_text(PAPER_TOML.read_text(), encoding="utf-8")
    assert load_scenario(_Fspath(p)).robot.n == 11


@pytest.mark.parametrize("source", [None, 3, 2.5, ["paper"], b"paper", "", {"robot": 1}])
def test_a_scenario_source_that_is_not_a_path_or_name_is_a_scenario_error(source: object) -> None:
    with pytest.raises(ScenarioError) as info:
        load_scenario(source)  # type: ignore[arg-type]
    assert "\n" not in str(info.value)


@pytest.mark.parametrize(
    ("old", "new", "key"),
    [
        # the circle's geometry
        ("normal = [0.0, 1.0, 0.0]", "normal = [0.0, 0.0, 0.0]", "'task.normal'"),
        ("start_direction = [1.0, 0.0, 0.0]", "start_direction = [0.0, 2.0, 0.0]", "'task.start_direction'"),
        # the robot: a mistake in each key is named by that key
        ('tip = "tool"', 'tip = "elbow_pad"', "'robot.tip'"),
        ("stiffness = 170.0", "stiffness = [170.0, 170.0]", "'robot.stiffness'"),
        ("stiffness = 170.0", "stiffness = 1e-30", "'robot.stiffness'"),
        # the brace: the frame, the surface
        ('frame = "brace"', 'frame = "tool"', "'brace.frame'"),
        ('frame = "brace"', 'frame = "pad"\nlink = "wrist"', "'brace.link'"),
        ('frame = "brace"', 'frame = "tool"\nlink = "link6"', "'brace.frame'"),
        ('frame = "brace"', 'frame = "brace"\ntangent = [0.0, 0.0, 2.0]', "'brace.tangent'"),
        # gains and directions
        ("d = 0.01", "d = -0.01", "'gradient_projection.weights.d'"),
        ('beta_x = "radial"', 'beta_x = "tangential"', "'compliance.beta_x'"),
        ('beta_x = "radial"', "beta_x = [0, 0, 0, 0, 0, 0]", "'compliance.beta_x'"),
        ('name = "paper"', "name = 3", "'name'"),
    ],
)
def test_every_scenario_error_names_its_key(tmp_path: Path, old: str, new: str, key: str) -> None:
    text = PAPER_TOML.read_text()
    p = tmp_path / "bad.toml"
    p.write_text(_edit(text, old, new), encoding="utf-8")
    with pytest.raises(ScenarioError) as info:
        load_scenario(p)
    msg = str(info.value)
    assert key in msg and "\n" not in msg, msg


@pytest.mark.parametrize(
    ("points", "times", "key"),
    [
        ([[1.2, -0.3, -0.1], [1.3, -0.3]], [0.0, 1.0], "'task.points'"),  # ragged
        ([[1.2, -0.3, -0.1], ["a", 0.0, 0.0]], [0.0, 1.0], "'task.points'"),
        ([[1.2, -0.3, -0.1]], [0.0], "'task.points'"),  # one point
        ("far", [0.0, 1.0], "'task.points'"),
        ([[1.2, -0.3, -0.1], [1.3, -0.3, -0.1]], [0.0, 0.0], "'task.times'"),
        ([[1.2, -0.3, -0.1], [1.3, -0.3, -0.1]], [0.0, 1.0, 2.0], "'task.times'"),
        ([[1.2, -0.3, -0.1], [1.3, -0.3, -0.1]], [0.5, 1.0], "'task.times'"),
    ],
)
def test_waypoint_task_errors_name_their_key(points: object, times: object, key: str) -> None:
    import tomllib

    data = tomllib.loads(scenario_text())
    data["task"] = {"type": "waypoints", "points": points, "times": times}
    data["compliance"]["beta_x"] = [0, 0, 1, 0, 0, 0]
    with pytest.raises(ScenarioError) as info:
        parse_scenario(data)
    msg = str(info.value)
    assert key in msg and "\n" not in msg, msg
