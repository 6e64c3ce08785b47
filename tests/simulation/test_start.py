"""Tests of the start solve in the scenario's task space and of what its failures name.

References: Pinocchio's own forward kinematics (a fresh model and data) for the tip and the brace point, and the
surface's plane written out here.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from bracekit.errors import ConvergenceError
from bracekit.simulation import start as start_module
from bracekit.simulation.run import run_scenario
from bracekit.simulation.scenario import load_scenario
from bracekit.simulation.scenario_model import DEFAULT_STRATEGIES
from bracekit.simulation.start import solve_start
from geometry_refs import xarm_planar as xarm_planar_scenario

PAPER = Path(__file__).resolve().parents[2] / "src/bracekit/simulation/scenarios/paper.toml"


def xarm_planar(tmp_path: Path, strategies: tuple[str, ...] = DEFAULT_STRATEGIES) -> Path:
    """tests/data/xarm7-planar.toml with example-robot-data's xArm7 (skips without the test extra)."""
    return xarm_planar_scenario(tmp_path, strategies)


def test_the_xarm7_planar_guess_starts_in_its_position_task_space(tmp_path: Path) -> None:
    sc = load_scenario(xarm_planar(tmp_path))
    start = solve_start(sc.braced, sc.task.position(0.0), sc.guess, rotation=sc.task.rotation, space=sc.task_space)
    model = sc.braced.robot.model  # reference: a fresh Pinocchio pass at the solved q
    data = model.createData()
    pin.framesForwardKinematics(model, data, start.q)
    tip = data.oMf[model.getFrameId("link_eef")].translation
    brace = data.oMf[model.getFrameId(sc.braced.brace.frame)].translation
    np.testing.assert_allclose(tip, sc.task.position(0.0), atol=1e-9)
    assert abs((brace - sc.braced.brace.surface.point) @ np.array([0.0, 0.0, 1.0])) < 1e-9


@pytest.mark.parametrize("scatter", [0.0, 0.01])
def test_the_xarm7_start_closes_from_a_least_squares_start_off_the_task(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, scatter: float
) -> None:
    """The least squares stopped after one evaluation ends 6e-5 m (or 0.01 m) off the task at the planar pose,
    where the full pose with the contact is a singular 7 × 7 system (σ_min/σ_max of A 2.5e-7): corrected on
    the pose it does not close; on the task's position rows and the contact it does."""
    sc = load_scenario(xarm_planar(tmp_path))
    monkeypatch.setattr(start_module, "START_MAX_NFEV", 1)
    guess = np.asarray(sc.guess) + scatter * np.random.default_rng(0).normal(size=7)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        start = solve_start(sc.braced, sc.task.position(0.0), guess, space=sc.task_space)
    model = sc.braced.robot.model  # reference: a fresh Pinocchio pass at the solved q
    data = model.createData()
    pin.framesForwardKinematics(model, data, start.q)
    np.testing.assert_allclose(data.oMf[model.getFrameId("link_eef")].translation, sc.task.position(0.0), atol=1e-9)
    brace = data.oMf[model.getFrameId(sc.braced.brace.frame)].translation
    assert abs((brace - sc.braced.brace.surface.point) @ np.array([0.0, 0.0, 1.0])) < 1e-9


@pytest.mark.slow
def test_the_xarm7_planar_guess_completes_with_every_gradient_strategy(tmp_path: Path) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = run_scenario(xarm_planar(tmp_path), both_models=False)
    failures = {name: tr.failure for runs in result.trajectories.values() for name, tr in runs.items()}
    assert set(failures) == set(DEFAULT_STRATEGIES)
    assert all(f is None for f in failures.values()), failures


def test_a_brace_that_cannot_close_is_blamed_not_the_tip(tmp_path: Path) -> None:
    text = PAPER.read_text(encoding="utf-8").replace('frame = "brace"', 'link = "link1"\nframe = "pad1"')
    text = text.replace("theta_z = 0.6", "theta_z = 0.0")
    path = tmp_path / "link1.toml"
    path.write_text(text, encoding="utf-8")
    sc = load_scenario(path)
    with pytest.raises(ConvergenceError) as info:
        solve_start(sc.braced, sc.task.position(0.0), sc.guess, space=sc.task_space)
    message = str(info.value)
    # reference: link1 is the PUMA's first link, 0.3 m or more above the table (z = −0.30) wherever it turns
    assert "did not close the contact at 'pad1'" in message and "the tip (" not in message
    assert "the bracing point 0.3 m off its surface" in message


def test_a_failed_start_names_the_joints_at_a_limit_and_a_link_inside_the_post(tmp_path: Path) -> None:
    from bracekit.simulation.start import _blocked

    sc = load_scenario(xarm_planar(tmp_path))
    q = np.array(sc.guess, dtype=float)
    q[1] = sc.braced.robot.lower[1]  # joint 2 at its URDF lower limit
    text = _blocked(sc.braced, sc.braced.state(q))
    assert "at a joint limit: joint 2 (joint2)" in text
    assert "joint 1 " not in text and "joint 3 (joint3)," not in text
    # at the planar guess the elbow point is inside link3's housing: link 3 starts inside the post
    inside = _blocked(sc.braced, sc.braced.state(np.array(sc.guess, dtype=float)))
    assert "at a joint limit" not in inside and "m inside the surface's solid" in inside


def test_the_start_s_cross_product_is_numpy_s_to_the_last_bit() -> None:
    """Reference: ``np.cross`` of the same 3-vectors (random, of every scale, and the axes)."""
    rng = np.random.default_rng(11)
    pairs = [(rng.standard_normal(3) * 10.0 ** rng.integers(-8, 8), rng.standard_normal(3)) for _ in range(200)]
    pairs += [(a, b) for a in np.eye(3) for b in np.eye(3)]
    for a, b in pairs:
        assert np.array_equal(start_module._cross(a, b), np.cross(a, b))
