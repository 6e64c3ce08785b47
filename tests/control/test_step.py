"""ControlStep against independent references: Pinocchio's Jacobians, the contact's motion, the statics' set points."""

from functools import cache

import numpy as np
import pytest

from bracekit.control import ControlStep
from bracekit.simulation.correction import contact_residual
from bracekit.simulation.scenario import Scenario, load_scenario
from bracekit.simulation.start import solve_start
from bracekit.statics import contact_responses


@cache
def _setup(name: str) -> tuple[Scenario, np.ndarray]:
    sc = load_scenario(name)
    st = solve_start(sc.braced, sc.task.position(0.0), sc.guess, rotation=sc.task.rotation, space=sc.task_space)
    return sc, st.q.copy()


STRATEGIES = ["free_space_min_norm", "braced_min_norm", "braced_gradient_projection"]


@pytest.mark.parametrize("name", ["paper", "two-braces"])
@pytest.mark.parametrize("strategy", STRATEGIES)
def test_task_realised_and_contacts_kept(name: str, strategy: str) -> None:
    sc, q0 = _setup(name)
    step = ControlStep(sc.braced, sc.strategy(strategy), 1e-3)
    xdot = np.array([0.02, -0.01, 0.015, 0.0, 0.0, 0.0])
    out = step(q0, xdot)
    st = sc.braced.state(q0)
    sel = sc.task_space.selection(st.R_e)
    assert np.allclose(sel @ st.J_e @ out.qdot, sel @ xdot, atol=1e-9)
    assert np.allclose(out.q_next, q0 + 1e-3 * out.qdot)
    if sc.strategy(strategy).braced:
        # every contact's constraint rows stay closed to second order in the tick (the drift is O(dt²))
        anchors = [(c.b, c.R_b) for c in st.contacts]
        drift = contact_residual(sc.braced.state(out.q_next), anchors)
        assert np.max(np.abs(drift)) < 1e-6 * np.max(np.abs(out.qdot)) + 1e-12
        assert out.residual.size == drift.size


@pytest.mark.parametrize("name", ["paper", "two-braces"])
def test_contact_drift_is_removed_in_one_tick(name: str) -> None:
    sc, q0 = _setup(name)
    step = ControlStep(sc.braced, sc.strategy("braced_min_norm"), 1e-3)
    step.reset(q0)
    rng = np.random.default_rng(0)
    q = q0 + 1e-4 * rng.standard_normal(q0.size)  # off the contacts by ~1e-5 m
    out = step(q, np.zeros(6))
    before = np.max(np.abs(out.residual))
    after = np.max(np.abs(contact_residual(sc.braced.state(out.q_next), step.anchors)))
    assert before > 1e-6
    assert after < 1e-3 * before  # deadbeat: only the second-order remainder is left
    st = sc.braced.state(q)
    sel = sc.task_space.selection(st.R_e)
    assert np.allclose(sel @ st.J_e @ out.qdot, 0.0, atol=1e-9)  # the task rows are left alone


def test_set_point_matches_the_statics_one_brace() -> None:
    sc, q0 = _setup("panda")
    step = ControlStep(sc.braced, sc.strategy("braced_min_norm"), 1e-3, preloads=7.0, gravity=True)
    out = step(q0, np.zeros(6))
    ref = contact_responses(sc.braced, q0, preload=7.0, gravity=True, geometric=False).q_s[0]
    assert np.allclose(out.set_point, ref + (out.q_next - q0), atol=1e-12)


def test_set_point_matches_the_statics_two_braces() -> None:
    sc, q0 = _setup("two-braces")
    step = ControlStep(sc.braced, sc.strategy("braced_min_norm"), 1e-3, preloads=[3.0, 5.0], gravity=True)
    out = step(q0, np.zeros(6))
    ref = contact_responses(sc.braced, q0, preload=[3.0, 5.0], gravity=True, geometric=False).q_s[0]
    assert np.allclose(out.set_point, ref + (out.q_next - q0), atol=1e-12)


def test_free_space_presses_nothing() -> None:
    sc, q0 = _setup("panda")
    step = ControlStep(sc.braced, sc.strategy("free_space_min_norm"), 1e-3, preloads=7.0, gravity=False)
    out = step(q0, np.zeros(6))
    assert np.allclose(out.set_point, out.q_next) and out.residual.size == 0
