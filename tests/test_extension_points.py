"""The extension points, used as a user would: a new contact type and a new task shape, each one class.

(A new objective term is shown in tests/objective/test_jacobians.py, where the registry-driven gradient check
takes it up.) Each class is registered for the test and removed from its registry afterwards.
"""

from __future__ import annotations

import re
import warnings
from dataclasses import dataclass

import numpy as np
import pytest

from bracekit.compliance.first_order import end_effector_compliance
from bracekit.contact import Brace, Surface
from bracekit.contact.base import REGISTRY, Array, ContactType, columns, register
from bracekit.kinematics import BracedRobot
from bracekit.objective import BraceMargin
from bracekit.resolution import BracedMinNorm
from bracekit.simulation.loop import simulate
from bracekit.simulation.scenario import load_scenario, parse_scenario, shipped_scenarios
from bracekit.simulation.start import solve_start
from bracekit.simulation.tasks import TASK_SHAPES, TaskShape, TaskTable, register_task
from helpers import pin_frame_jacobian, pin_frame_placement

try:  # Python ≥ 3.11
    import tomllib
except ModuleNotFoundError:  # pragma: no cover
    import tomli as tomllib  # type: ignore[no-redef]


class SlidingPad(ContactType):
    """A flat pad: slides in the plane and turns about the normal; holds the normal force and tilting moments."""

    name = "sliding_pad"
    l = 3

    def H(self, frame: Array) -> Array:
        x, y, z = frame[:, 0], frame[:, 1], frame[:, 2]
        zero = np.zeros(3)
        return columns((x, zero), (y, zero), (zero, z))

    def X(self, frame: Array) -> Array:
        x, y, z = frame[:, 0], frame[:, 1], frame[:, 2]
        zero = np.zeros(3)
        return columns((z, zero), (zero, x), (zero, y))


@pytest.fixture
def sliding_pad():
    register(SlidingPad)
    yield SlidingPad()
    REGISTRY.pop(SlidingPad.name)


def test_a_new_contact_type_is_one_class_and_every_layer_takes_it(sliding_pad) -> None:
    sc = load_scenario("paper")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        start = solve_start(sc.braced, sc.task.position(0.0), sc.guess)
    b = start.contacts[0].b
    brace = Brace("brace", Surface(b, [0.0, 0.0, 1.0]), contact="sliding_pad")  # by its registered name
    braced = BracedRobot(sc.robot, brace)
    frame = brace.surface.frame
    np.testing.assert_allclose(sliding_pad.H(frame).T @ sliding_pad.X(frame), 0.0, atol=1e-15)
    q = start.q
    # compliance: the stacked constrained C_e against the bordered KKT equilibrium, built here from Pinocchio
    model, k = sc.robot.model, sc.robot.stiffness
    j_e, j_b = pin_frame_jacobian(model, sc.robot.tip, q), pin_frame_jacobian(model, "brace", q)
    g = sliding_pad.X(frame).T @ j_b
    n, c = q.size, g.shape[0]
    kkt = np.block([[np.diag(k), -g.T], [g, np.zeros((c, c))]])
    expected = j_e @ np.linalg.solve(kkt, np.vstack([j_e.T, np.zeros((c, 6))]))[:n]
    c_e = end_effector_compliance(braced.state(q))
    assert np.abs(c_e - expected).max() < 1e-10 * np.abs(expected).max()
    # resolution and the run: the pad slides on the plane and turns about the normal only (R R0ᵀ keeps n̂)
    e0 = start.e
    from bracekit.simulation.tasks import Line

    task = Line(e0, e0 + np.array([0.02, 0.0, 0.0]), 1.0)
    run = simulate(braced, BracedMinNorm(), task, q, 0.1, lambda t: np.array([1.0, 0, 0, 0, 0, 0]))
    assert run.completed, run.failure
    r0, normal = pin_frame_placement(model, "brace", q).rotation, brace.surface.normal
    for qq in run.q:
        m = pin_frame_placement(model, "brace", qq)
        assert abs(brace.surface.signed_distance(m.translation)) < 1e-9
        np.testing.assert_allclose(m.rotation @ r0.T @ normal, normal, rtol=0, atol=1e-9)
    # statics: its load wrenches are its X by default, and the brace margin takes them
    np.testing.assert_array_equal(sliding_pad.load_wrenches(frame, 0.5), sliding_pad.X(frame))
    margin = BraceMargin(braced, np.array([0.0, 0.0, -1.0, 0.0, 0.0, 0.0]), preload=5.0)
    assert np.isfinite(margin.value(braced.state(q)))


@dataclass(frozen=True)
class Hold:
    """Hold the tip at `point` (3,), m, for `duration` s."""

    point: np.ndarray
    duration: float
    rotation: None = None

    def position(self, t: float) -> np.ndarray:
        return np.asarray(self.point, dtype=float)

    def velocity(self, t: float) -> np.ndarray:
        return np.zeros(3)


class HoldShape(TaskShape):
    kind = "hold"
    keys = ("point", "duration")

    @classmethod
    def from_table(cls, table: TaskTable) -> Hold:
        return Hold(table.vector("point", 3), table.number("duration", positive=True))


@pytest.fixture
def hold_shape():
    register_task(HoldShape)
    yield HoldShape
    TASK_SHAPES.pop(HoldShape.kind)


def test_a_new_task_shape_is_one_class_that_the_scenario_parser_reads(hold_shape) -> None:
    text = shipped_scenarios()["paper"].read_text(encoding="utf-8")
    text = re.sub(
        r"(?ms)^\[task\].*?(?=^\[start\])",
        '[task]\ntype = "hold"\npoint = [1.34, -0.32, -0.17]\nduration = 0.5\n\n',
        text,
    )
    text = text.replace('beta_x = "radial"', "beta_x = [1.0, 0.0, 0.0, 0.0, 0.0, 0.0]")
    sc = parse_scenario(tomllib.loads(text))
    assert isinstance(sc.task, Hold) and sc.task.duration == 0.5
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        start = solve_start(sc.braced, sc.task.position(0.0), sc.guess)
    run = simulate(sc.braced, BracedMinNorm(), sc.task, start.q, 0.1, sc.beta_x)
    assert run.completed, run.failure
    for q in run.q:  # independent: Pinocchio's tip placement
        tip = pin_frame_placement(sc.robot.model, sc.robot.tip, q).translation
        np.testing.assert_allclose(tip, [1.34, -0.32, -0.17], atol=1e-9)
    # "radial" needs a shape with a radial direction: a hold has none, and the parser says so by the shape
    with pytest.raises(Exception, match="radial direction"):
        parse_scenario(tomllib.loads(text.replace("beta_x = [1.0, 0.0, 0.0, 0.0, 0.0, 0.0]", 'beta_x = "radial"')))
