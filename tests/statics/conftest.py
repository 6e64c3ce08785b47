"""Fixtures of the statics tests: the paper robot at its start configuration and a random braced chain."""

from __future__ import annotations

import numpy as np
import pytest

from bracekit.contact import Brace, Surface
from bracekit.kinematics import BracedRobot
from bracekit.model.robot import Robot
from bracekit.simulation import load_scenario, solve_start
from helpers import random_chain_urdf


@pytest.fixture(scope="session")
def paper() -> tuple[BracedRobot, np.ndarray]:
    """The paper scenario's braced robot (170 N·m/rad) and its start configuration (b on the table)."""
    sc = load_scenario("paper")
    return sc.braced, solve_start(sc.braced, sc.task.position(0.0), sc.guess).q


@pytest.fixture(scope="session")
def paper_path(paper) -> np.ndarray:
    """Three configurations of the paper task (tip on the circle, b on the table), 3×11."""
    sc = load_scenario("paper")
    braced, q = paper
    qs = [q]
    for t in (4.0, 8.0):
        qs.append(solve_start(braced, sc.task.position(t), qs[-1]).q)
    return np.array(qs)


def _braced_chain(
    contact: str = "frictionless_point", stiffness: float = 40.0, seed: int = 3, k_env: float | None = None
) -> tuple[BracedRobot, np.ndarray]:
    """A 9-joint random chain braced on link 5 at a random q, the plane through b with a random normal."""
    robot = Robot.from_urdf(random_chain_urdf(9, seed=seed, brace_link=5), tip="tip", stiffness=stiffness)
    rng = np.random.default_rng(seed)
    q = rng.uniform(-1.5, 1.5, robot.n)
    normal = rng.normal(size=3)
    probe = BracedRobot(robot, Brace("brace", Surface(np.zeros(3), normal)))
    b = probe.frame_placements(q).b_i[0]
    brace = Brace("brace", Surface(b, normal), contact=contact, environment_stiffness=k_env)
    return BracedRobot(robot, brace), q


@pytest.fixture
def chain():
    """The factory of random braced chains: chain(contact=..., stiffness=..., seed=..., k_env=...)."""
    return _braced_chain
