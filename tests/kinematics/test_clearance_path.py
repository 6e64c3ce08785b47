"""Tests of the capsule clearance over a whole path (bracekit.kinematics._clearance_path through Clearance.minima).

Reference: the Python search of one configuration, :meth:`Clearance.minimum` (itself tested against a brute
force in test_clearance.py), at every configuration; the compiled search over the path must give the same least
clearance to 1e-12 m and the same link, for one brace (half-space, disks of several radii, off-centre), two
braces and capsules with a further obstacle.
"""

from __future__ import annotations

import numpy as np
import pytest
from test_clearance import same_least

import bracekit.kinematics.path_clearance as path_clearance
from bracekit import load_scenario
from bracekit.contact import Brace, Surface
from bracekit.geometry.obstacle_tables import with_obstacles
from bracekit.geometry.obstacles import box_obstacle
from bracekit.kinematics import BracedRobot
from bracekit.kinematics.clearance import Clearance, compiled_path, geometry_of, path_search
from bracekit.model.robot import Robot
from helpers import random_chain_urdf

pytest.importorskip("numba")


def _chain(region: float | None, centre: tuple[float, float]) -> BracedRobot:
    robot = Robot.from_urdf(random_chain_urdf(6, seed=11, brace_link=3), tip="tip")
    return BracedRobot(robot, Brace("brace", Surface([*centre, -0.2], [0.0, 0.3, 1.0]), region_radius=region))


def _agree(clearance: Clearance, qs: list[np.ndarray]) -> np.ndarray:
    """The path's minima against minimum at each configuration (same_least); the values."""
    values, joints = clearance.minima(qs)
    same_least(clearance, qs, values, joints)
    return values


@pytest.mark.parametrize(
    ("region", "centre"), [(None, (0.0, 0.0)), (0.3, (0.0, 0.0)), (0.05, (0.1, -0.05)), (1.0, (0.4, 0.2))]
)
def test_the_compiled_path_search_gives_the_python_search_of_each_configuration(region, centre) -> None:
    braced = _chain(region, centre)
    clearance = Clearance(braced)
    rng = np.random.default_rng(3)
    qs = list(rng.uniform(-2.5, 2.5, (300, braced.n)))
    values = _agree(clearance, qs)
    assert compiled_path() is not None
    # the cases of the rule: penetration and clearance, over and beside the disk
    assert (values < 0.0).any() and (values > 0.0).any()


def test_the_path_search_of_two_braces_and_of_the_paper_robot_is_that_of_each_configuration() -> None:
    for name in ("two-braces", "paper"):
        braced = load_scenario(name).braced
        robot = braced.robot
        rng = np.random.default_rng(9)
        qs = [robot.neutral(), *rng.uniform(robot.lower, robot.upper, (150, robot.n))]
        values = _agree(Clearance(braced), qs)
        assert (values < 0.0).any() and (values > 0.0).any()


@pytest.mark.slow  # the two-brace robot's 11 000 link pieces against a box: about 15 s
def test_capsules_with_a_further_obstacle_take_the_least_of_the_surface_and_the_obstacle() -> None:
    braced = _chain(0.3, (0.0, 0.0))
    pose = np.eye(4)
    pose[:3, 3] = [0.25, 0.1, 0.1]
    boxed = Clearance(with_obstacles(braced, [box_obstacle("box", np.array([0.2, 0.2, 0.2]), pose)]))
    assert boxed.extra is not None and boxed.mesh is None
    qs = list(np.random.default_rng(4).uniform(-2.0, 2.0, (60, braced.n)))
    values = _agree(boxed, qs)
    plain = Clearance(braced).minima(qs)[0]
    assert (values <= plain).all() and (values < plain).any()  # the box is the nearer obstacle somewhere
    two = load_scenario("two-braces").braced  # two surfaces and a box beside the arm
    pose[:3, 3] = [0.3, 0.3, 0.4]
    boxed = Clearance(with_obstacles(two, [box_obstacle("box", np.array([0.3, 0.3, 0.3]), pose)]))
    assert boxed.extra is not None and len(boxed.surfaces) == 2
    rng = np.random.default_rng(5)
    qs = [two.robot.neutral(), *rng.uniform(two.robot.lower, two.robot.upper, (40, two.n))]
    values = _agree(boxed, qs)
    assert (values < Clearance(two).minima(qs)[0]).any()


def test_without_numba_the_python_search_runs_and_the_geometry_line_says_so(monkeypatch) -> None:
    braced = _chain(0.3, (0.0, 0.0))
    qs = list(np.random.default_rng(5).uniform(-2.0, 2.0, (40, braced.n)))
    compiled = Clearance(braced).minima(qs)
    assert "Python" not in geometry_of(braced) and path_search() == "compiled"
    monkeypatch.setattr(path_clearance, "numba_installed", lambda: False)
    assert compiled_path() is None
    python = Clearance(braced).minima(qs)
    assert python[0].tolist() == [Clearance(braced).minimum(q)[0] for q in qs]
    np.testing.assert_allclose(python[0], compiled[0], rtol=0.0, atol=1e-12)
    same_least(Clearance(braced), qs, *compiled)
    assert geometry_of(braced).endswith("; path searched in Python (numba not installed)")


def test_the_path_search_of_a_chain_with_a_prismatic_joint_is_that_of_each_configuration() -> None:
    text = random_chain_urdf(6, seed=11, brace_link=3).replace(
        'name="j2" type="revolute"', 'name="j2" type="prismatic"'
    )
    robot = Robot.from_urdf(text, tip="tip")
    braced = BracedRobot(robot, Brace("brace", Surface([0.0, 0.0, -0.2], [0.0, 0.3, 1.0]), region_radius=0.3))
    _agree(Clearance(braced), list(np.random.default_rng(8).uniform(-1.0, 1.0, (30, robot.n))))
