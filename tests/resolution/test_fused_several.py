"""The compiled gradient-projection step of several braces equals the reference step.

Reference: ``BracedGradientProjection.velocity(braced.state(q, hessians=True), ẋ)`` (SVD null space, SVD
pseudo-inverse, ``Objective.gradient`` through ``bilinear_gradient``) on the two-braces scenario, at
configurations about its start, in the pose and position task spaces, with β_x replaced; where the kernel
does not apply or declines, the step is the reference's (same errors). Skipped without numba. No timing.
"""

from __future__ import annotations

import dataclasses
import warnings
from functools import cache

import numpy as np
import pytest

from bracekit import BracedGradientProjection, ComplianceIndex, Objective, RegionBarrier, load_scenario
from bracekit.control import ControlStep
from bracekit.errors import BarrierError
from bracekit.objective import ConditionNumber, JointLimitBarrier
from bracekit.resolution.fused import GradientProjectionStep
from bracekit.resolution.task_space import POSE

pytest.importorskip("numba")

RTOL = 1e-12  # observed ≈ 3e-15


@cache
def _scenario():  # type: ignore[no-untyped-def]
    return load_scenario("two-braces")


def _reference(strategy: BracedGradientProjection, q: np.ndarray, xdot: np.ndarray) -> np.ndarray:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return strategy.velocity(_scenario().braced.state(q, hessians=True), xdot)


def _configurations(count: int, spread: float = 0.02) -> list[np.ndarray]:
    rng = np.random.default_rng(7)
    q0 = np.asarray(_scenario().guess, dtype=float)
    return [q0 + spread * rng.normal(size=q0.size) for _ in range(count)]


@pytest.mark.parametrize("space", ["position", "pose"])
def test_kernel_equals_the_reference_step(space: str) -> None:
    sc = _scenario()
    strategy = sc.strategy("braced_gradient_projection")
    if space == "pose":
        strategy = dataclasses.replace(strategy, space=POSE)
    step = GradientProjectionStep(sc.braced, strategy, backend="numba")
    assert (step.backend, step.uses_kernel, step.fallback_reason) == ("numba", True, None)
    rng = np.random.default_rng(3)
    used = 0
    for q in _configurations(12):
        xdot = rng.normal(size=6)
        ref = _reference(strategy, q, xdot)
        got = step._multi(q, xdot)  # type: ignore[misc]
        if got is None:  # the kernel declined: the step is the reference's
            np.testing.assert_array_equal(step(q, xdot), ref)
            continue
        used += 1
        assert np.max(np.abs(got - ref)) <= RTOL * np.max(np.abs(ref))
        np.testing.assert_array_equal(step(q, xdot), got)
    assert used >= 10


def test_kernel_replaces_beta_x_like_a_new_compliance_index() -> None:
    sc = _scenario()
    strategy = sc.strategy("braced_gradient_projection")
    step = GradientProjectionStep(sc.braced, strategy, backend="numba")
    beta = np.array([0.3, -0.2, 0.9, 0.0, 0.1, 0.0])
    want = dataclasses.replace(strategy, objective=strategy.objective.with_beta_x(beta))
    for q in _configurations(4):
        xdot = np.array([0.01, 0.0, -0.02, 0.0, 0.0, 0.0])
        ref = _reference(want, q, xdot)
        assert np.max(np.abs(step(q, xdot, beta) - ref)) <= RTOL * np.max(np.abs(ref))


def test_kernel_every_term_and_weight() -> None:
    """C_i, both region barriers and the joint-limit barrier, each alone and together, against the reference."""
    sc = _scenario()
    braced = sc.braced
    beta = np.array([1.0, 0.0, 0.5, 0.0, 0.0, 0.0])
    model = braced.robot.model
    terms = [
        ComplianceIndex(beta, "constrained"),
        RegionBarrier(0.15, braced.braces[0].surface.point, name="d_0", brace=0),
        RegionBarrier(0.2, braced.braces[1].surface.point, name="d_1", brace=1),
        JointLimitBarrier(model.lowerPositionLimit, model.upperPositionLimit),
    ]
    cases = [[100.0, 0.0, 0.0, 0.0], [0.0, 0.3, 0.0, 0.0], [0.0, 0.0, 0.3, 0.0], [0.0, 0.0, 0.0, 0.05]]
    cases.append([100.0, 0.2, 0.2, 0.01])
    for weights in cases:
        strategy = BracedGradientProjection(Objective(terms, weights), alpha=-0.5, space=sc.task_space)
        step = GradientProjectionStep(braced, strategy, backend="numba")
        assert step.uses_kernel
        for q in _configurations(3):
            xdot = np.array([0.0, 0.01, 0.02, 0.0, 0.0, 0.0])
            ref = _reference(strategy, q, xdot)
            got = step._multi(q, xdot)  # type: ignore[misc]
            assert got is not None
            assert np.max(np.abs(got - ref)) <= RTOL * np.max(np.abs(ref))


def test_where_the_kernel_does_not_apply_the_reference_runs() -> None:
    sc = _scenario()
    braced = sc.braced
    strategy = sc.strategy("braced_gradient_projection")
    fd = dataclasses.replace(strategy, gradient="finite-difference")
    other = dataclasses.replace(strategy, objective=Objective([ConditionNumber()], [1.0]))
    q = _configurations(1)[0]
    xdot = np.array([0.01, 0.0, 0.0, 0.0, 0.0, 0.0])
    for strat, reason in ((fd, "finite-difference"), (other, "without a compiled copy")):
        step = GradientProjectionStep(braced, strat, backend="numba")
        assert not step.uses_kernel and reason in (step.fallback_reason or "")
        np.testing.assert_array_equal(step(q, xdot), _reference(strat, q, xdot))
    numpy_step = GradientProjectionStep(braced, strategy)
    assert numpy_step.backend == "numpy" and not numpy_step.uses_kernel


def test_kernel_declines_outside_a_region_and_the_reference_raises() -> None:
    sc = _scenario()
    braced = sc.braced
    terms = [RegionBarrier(1e-4, braced.braces[1].surface.point + 0.05, name="d_1", brace=1)]
    strategy = BracedGradientProjection(Objective(terms, [1.0]), space=sc.task_space)
    step = GradientProjectionStep(braced, strategy, backend="numba")
    q = np.asarray(sc.guess, dtype=float)
    xdot = np.zeros(6)
    assert step._multi(q, xdot) is None  # type: ignore[misc]
    with pytest.raises(BarrierError) as got, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        step(q, xdot)
    with pytest.raises(BarrierError) as want:
        _reference(strategy, q, xdot)
    assert str(got.value) == str(want.value)


def test_control_step_of_two_braces_uses_one_pass_and_the_kernel() -> None:
    sc = _scenario()
    strategy = sc.strategy("braced_gradient_projection")
    fast = ControlStep(sc.braced, strategy, 1e-3)
    slow = ControlStep(sc.braced, strategy, 1e-3, backend="numpy")
    xdot = np.array([0.02, 0.0, -0.01, 0.0, 0.0, 0.0])
    for q in _configurations(3, spread=0.005):
        fast.reset(q)
        slow.reset(q)
        a, b = fast(q, xdot), slow(q, xdot)
        assert np.max(np.abs(a.qdot - b.qdot)) <= RTOL * np.max(np.abs(b.qdot))
        for x, y in zip(a[2:], b[2:], strict=True):
            np.testing.assert_allclose(x, y, rtol=0, atol=1e-12)


def test_terms_the_reference_refuses_are_left_to_it() -> None:
    """A region barrier of a third brace on a two-brace robot: not compiled, the reference's InputError."""
    from bracekit.errors import InputError

    sc = _scenario()
    braced = sc.braced
    strategy = BracedGradientProjection(
        Objective([RegionBarrier(0.2, braced.braces[1].surface.point, name="d_2", brace=2)], [1.0]),
        space=sc.task_space,
    )
    step = GradientProjectionStep(braced, strategy, backend="numba")
    assert not step.uses_kernel and "d_2" in (step.fallback_reason or "")
    q = np.asarray(sc.guess, dtype=float)
    with pytest.raises(InputError, match="braces\\[2\\]"):
        step(q, np.zeros(6))


def test_the_braced_conditioning_barrier_is_certified_inactive_or_left_to_the_reference() -> None:
    """Inactive (r well above r₀): the kernel adds nothing, as the reference; active: the kernel declines."""
    conditioning = pytest.importorskip("bracekit.objective.braced_conditioning")
    sc = _scenario()
    braced = sc.braced
    beta = np.array([1.0, 0.0, 0.5, 0.0, 0.0, 0.0])
    xdot = np.array([0.0, 0.01, 0.02, 0.0, 0.0, 0.0])
    for r0, active in ((0.01, False), (0.99, True)):
        term = conditioning.BracedConditioning(threshold=r0, space=sc.task_space)
        objective = Objective([ComplianceIndex(beta, "constrained"), term], [100.0, 0.5])
        strategy = BracedGradientProjection(objective, space=sc.task_space)
        step = GradientProjectionStep(braced, strategy, backend="numba")
        assert step.uses_kernel
        for q in _configurations(3):
            ref = _reference(strategy, q, xdot)
            got = step._multi(q, xdot)  # type: ignore[misc]
            if active:
                assert got is None  # the reference computes the barrier's gradient
                np.testing.assert_array_equal(step(q, xdot), ref)
            else:
                assert got is not None
                assert np.max(np.abs(got - ref)) <= RTOL * np.max(np.abs(ref))


def test_kernel_inputs_keep_the_rows_of_the_last_beta_x_and_equal_a_fresh_call() -> None:
    from bracekit.errors import InputError
    from bracekit.resolution.fused_several import KernelInputs, kernel_inputs

    rows = np.array([[0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 2.0], [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5]])
    inputs = KernelInputs(rows)
    xd = np.arange(6.0)[::-1]  # not contiguous: copied, as kernel_inputs copies it
    first = np.array([0.0, 3.0, 4.0, 0.0, 0.0, 0.0])
    for beta in (first, first.copy(), np.array([1.0, 1.0, 0.0, 0.0, 0.0, 1.0]), [0.0, 0.0, 2.0, 0, 0, 0], None):
        got_ci, got_xd = inputs(beta, xd)
        want_ci, want_xd = kernel_inputs(rows, beta, xd)
        np.testing.assert_array_equal(got_ci, want_ci)
        np.testing.assert_array_equal(got_xd, want_xd)
        assert got_xd.flags.c_contiguous and got_xd.flags.writeable
    np.testing.assert_array_equal(inputs(first, xd)[0][:, :6], [[0.0, 0.6, 0.8, 0.0, 0.0, 0.0]] * 2)
    assert inputs(first, xd)[0] is inputs(first.copy(), xd)[0]  # one twist: its rows formed once
    np.testing.assert_array_equal(rows[:, :6], [[0.0, 0.0, 1.0, 0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0, 0.0, 0.0]])
    with pytest.raises(InputError):
        inputs(np.zeros(6), xd)  # a zero twist is refused every time, as ComplianceIndex refuses it
