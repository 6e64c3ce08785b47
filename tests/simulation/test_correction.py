"""Tests of the correction's damped steps: it never ends above its starting residual, and names what stays open.

Reference: the residual at the start and at the end written out here from the tip pose (Pinocchio's frame
placement through BracedState) and the contact plane, scaled as the docstring of ``correct`` says.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

from bracekit.errors import ConvergenceError, InputError
from bracekit.simulation.correction import Correction, contact_residual, correct, reach, task_error
from bracekit.simulation.scenario import load_scenario


def _scaled(braced, q, position, length) -> float:
    st = braced.state(q)
    return float(np.max(np.abs(position - st.e)) / length)


def test_an_unreachable_tip_raises_naming_the_tip_without_raising_the_residual() -> None:
    sc = load_scenario("paper")
    braced = sc.braced
    st = braced.state(np.asarray(sc.guess, dtype=float))
    length = reach(braced.robot)
    target = st.e + np.array([3.0 * length, 0.0, 0.0])  # three reaches away: no configuration closes it
    before = _scaled(braced, st.q, target, length)
    with pytest.raises(ConvergenceError) as info:
        correct(braced, st.q, target, st.R_e, None, space=sc.task_space)
    message = str(info.value)
    assert "not closed: the tip (pose rows" in message
    after = float(re.search(r"\(residual ([0-9.e+-]+) of the robot's reach", message).group(1))
    assert after <= before * (1 + 1e-2)  # the message rounds to 3 digits


def test_a_reachable_correction_closes_the_tip_and_the_contact() -> None:
    sc = load_scenario("paper")
    braced = sc.braced
    st = braced.state(np.asarray(sc.guess, dtype=float))
    anchors = [(c.b - 0.01 * b.surface.normal, c.R_b) for c, b in zip(st.contacts, braced.braces, strict=True)]
    target = st.e + np.array([0.02, -0.01, 0.01])
    out = correct(braced, st.q + 0.05, target, st.R_e, anchors)
    np.testing.assert_allclose(out.e, target, atol=1e-10)
    np.testing.assert_allclose(braced.braces[0].surface.normal @ (out.b_i[0] - anchors[0][0]), 0.0, atol=1e-10)


def test_a_failure_says_whether_the_task_itself_or_only_the_braced_task_is_singular() -> None:
    from bracekit.resolution.task_space import TaskSpace
    from bracekit.simulation.correction import _where

    space = TaskSpace("position")
    rng = np.random.default_rng(3)
    task = rng.normal(size=(3, 5))
    scale = np.ones(4)
    task_singular = np.vstack([task[:2], task[0] + task[1], rng.normal(size=(1, 5))])  # rank 2 of 3 task rows
    assert "the task itself is singular" in _where(task_singular, scale, space)
    braced_singular = np.vstack([task, task[0] - 2.0 * task[2]])  # a contact row the task rows already span
    text = _where(braced_singular, scale, space)
    assert "a braced singularity" in text and "the task itself" not in text
    assert "reduce the time step" in _where(np.vstack([task, rng.normal(size=(1, 5))]), scale, space)


@pytest.mark.parametrize("name", ["paper", "panda", "two-braces"])
def test_one_correction_of_a_run_gives_the_state_of_braced_state_at_its_q_and_closes_every_row(name: str) -> None:
    """Reference: ``braced.state`` at the corrected q, and the residuals written out from it (one and two braces)."""
    sc = load_scenario(name)
    braced, space = sc.braced, sc.task_space
    rng = np.random.default_rng(5)
    base = braced.state(np.asarray(sc.guess, dtype=float))
    anchors = [(c.b.copy(), c.R_b.copy()) for c in base.contacts]
    correction = Correction(braced, base.R_e, anchors, space=space)
    for _ in range(3):
        target = base.e + 0.01 * rng.standard_normal(3)
        out = correction(base.q + 0.01 * rng.standard_normal(braced.n), target)
        ref = braced.state(out.q)
        for got, want in [(out.e, ref.e), (out.R_e, ref.R_e), (out.J_e, ref.J_e)]:
            assert np.array_equal(got, want)
        for c, r in zip(out.contacts, ref.contacts, strict=True):
            assert np.array_equal(c.b, r.b) and np.array_equal(c.R_b, r.R_b) and np.array_equal(c.J_b, r.J_b)
        assert np.max(np.abs(space.selection(ref.R_e) @ task_error(ref, target, base.R_e, space))) < 1e-9
        assert np.max(np.abs(contact_residual(ref, anchors))) < 1e-9
        again = correct(braced, out.q, target, base.R_e, anchors, space=space)  # the function: the same correction
        assert np.array_equal(again.q, out.q)


@pytest.mark.parametrize("name", ["paper", "two-braces"])
def test_a_step_on_the_correction_s_pass_is_the_step_on_its_own_pass_to_the_last_bit(name: str) -> None:
    """Reference: the gradient-projection step making its own Pinocchio pass at the same q (a copy of the array)."""
    from bracekit.resolution.fused import GradientProjectionStep
    from bracekit.simulation.start import solve_start

    sc = load_scenario(name)
    start = solve_start(sc.braced, sc.task.position(0.0), sc.guess, space=sc.task_space)
    anchors = [(c.b.copy(), c.R_b.copy()) for c in start.contacts]
    corr = Correction(sc.braced, start.R_e.copy(), anchors, space=sc.task_space)
    step = GradientProjectionStep(sc.braced, sc.strategy("braced_gradient_projection"), backend="auto")
    if not step.uses_kernel:
        pytest.skip(f"the compiled step does not run here ({step.fallback_reason}): the NumPy step makes its own pass")
    rng = np.random.default_rng(5)
    xdot = np.array([0.02, -0.01, 0.03, 0.0, 0.0, 0.0])
    beta = sc.beta_x(0.3)
    for k in range(4):
        st = corr(start.q + 1e-3 * rng.standard_normal(start.q.shape), sc.task.position(0.01 * k))
        at = corr.last_pass(st.q)
        assert at is not None and corr.last_pass(st.q.copy()) is None  # only at the very array of the pass
        shared = step(st.q, xdot, beta, at)
        own = step(st.q.copy(), xdot, beta)
        assert np.array_equal(shared, own)
        # the pass's frames are the state's: ⁰M and J of the tip, then of each brace
        assert np.array_equal(at.jacobians[0], st.J_e) and np.array_equal(at.placements[0][:3, 3], st.e)
        for i, c in enumerate(st.contacts):
            assert np.array_equal(at.jacobians[1 + i], c.J_b) and np.array_equal(at.placements[1 + i][:3, :3], c.R_b)
    later = corr(start.q, sc.task.position(0.0))
    assert corr.last_pass(st.q) is None and corr.last_pass(later.q) is not None  # a new pass: the old one is gone


def test_no_pass_is_handed_over_for_a_q_changed_in_place_or_after_a_call_that_raised() -> None:
    """Reference: the pass at the state's q as returned; a q changed since, or a failed call, gives none."""
    sc = load_scenario("paper")
    st0 = sc.braced.state(np.asarray(sc.guess, dtype=float))
    anchors = [(c.b.copy(), c.R_b.copy()) for c in st0.contacts]
    corr = Correction(sc.braced, st0.R_e.copy(), anchors)
    q = st0.q.copy()
    st = corr(q, st0.e)  # already on the task and contact: accepted at once, the state on the caller's array
    assert corr.last_pass(st.q) is not None
    q += 0.05  # the caller's array changed in place: the pass is not at it any more
    assert corr.last_pass(q) is None
    st = corr(st0.q.copy(), st0.e)
    with pytest.raises(InputError):
        corr(np.full_like(st.q, np.nan), st0.e)
    assert corr.last_pass(st.q) is None  # the failed call replaced the pass's arrays


def test_a_point_that_converges_on_the_last_allowed_step_is_accepted() -> None:
    """max_iter steps that reach the tolerance give the corrected state, not a ConvergenceError.

    Reference: the same correction with room to spare (max_iter 50); the steps it took, counted as its Pinocchio
    passes after the first (no damped trial at a start this near).
    """
    sc = load_scenario("paper")
    st0 = sc.braced.state(np.asarray(sc.guess, dtype=float))
    anchors = [(c.b.copy(), c.R_b.copy()) for c in st0.contacts]
    start = st0.q + 1e-5 * np.random.default_rng(2).standard_normal(st0.q.shape)
    roomy = Correction(sc.braced, st0.R_e.copy(), anchors, max_iter=50)
    passes = [0]
    own = roomy._pass

    def counted(q: np.ndarray) -> np.ndarray:
        passes[0] += 1
        return own(q)

    roomy._pass = counted  # type: ignore[method-assign]
    reference = roomy(start.copy(), st0.e)
    steps = passes[0] - 1
    assert steps >= 1
    tight = Correction(sc.braced, st0.R_e.copy(), anchors, max_iter=steps)
    assert np.array_equal(tight(start.copy(), st0.e).q, reference.q)
    with pytest.raises(ConvergenceError):
        Correction(sc.braced, st0.R_e.copy(), anchors, max_iter=steps - 1)(start.copy(), st0.e)
