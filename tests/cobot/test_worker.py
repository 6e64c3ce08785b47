"""The worker model: minimum-jerk reach, grip, the process profile and the seeded tremor."""

import numpy as np
import pytest

from bracekit.cobot.config import load_cobot
from bracekit.cobot.worker import Phase, Worker


def test_minimum_jerk_reach_ends_at_rest_on_the_target() -> None:
    sc = load_cobot("panda-cobot")
    w = Worker(sc, np.zeros(3))
    goal = sc.operator.targets[0]
    h0, v0 = w.hand(Phase(0, "travel", 0.0))
    h1, v1 = w.hand(Phase(0, "travel", sc.operator.travel - 1e-12))
    assert np.allclose(h0, 0.0) and np.allclose(v0, 0.0)
    assert np.allclose(h1, goal, atol=1e-9) and np.allclose(v1, 0.0, atol=1e-9)
    # the velocity is the derivative of the path (central difference)
    s, eps = 0.37, 1e-6
    hp, _ = w.hand(Phase(0, "travel", s + eps))
    hm, _ = w.hand(Phase(0, "travel", s - eps))
    assert np.allclose(w.hand(Phase(0, "travel", s))[1], (hp - hm) / (2 * eps), rtol=1e-6)


def test_phases_grip_and_process_profile() -> None:
    sc = load_cobot("panda-cobot")
    op, pr = sc.operator, sc.process
    w = Worker(sc, np.zeros(3))
    assert w.phase(0.0) == Phase(0, "travel", 0.0)
    dwell = op.travel + op.approach
    assert w.phase(dwell + 0.2).name == "dwell"
    assert w.grip(w.phase(dwell + 2 * pr.ramp)) == 0.0  # the hand is off during the work
    assert w.process(w.phase(dwell + pr.start)) == pytest.approx(0.0, abs=1e-12)
    assert w.process(w.phase(dwell + pr.start + pr.ramp + 0.5 * pr.hold)) == 1.0
    assert w.process(w.phase(dwell + pr.start + 2 * pr.ramp + pr.hold + 1e-9)) == pytest.approx(0.0, abs=1e-12)
    assert w.phase(op.travel + op.approach + op.dwell + 0.1) == Phase(1, "travel", pytest.approx(0.1))


def test_tremor_is_seeded_with_the_stated_rms() -> None:
    sc = load_cobot("panda-cobot")
    a, b = Worker(sc, np.zeros(3)), Worker(sc, np.zeros(3))
    xs = np.array([a.step_tremor(1e-3) for _ in range(20000)])
    ys = np.array([b.step_tremor(1e-3) for _ in range(20000)])
    assert np.array_equal(xs, ys)
    assert np.sqrt(np.mean(xs[2000:] ** 2)) == pytest.approx(sc.operator.tremor, rel=0.15)
