"""The lean minimum-norm step equals each strategy's own velocity (SVD pseudo-inverse, chain split) to round-off."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from bracekit import BracedMinNorm, FreeSpaceMinNorm, load_scenario
from bracekit.errors import SingularityError
from bracekit.resolution.min_norm import MinNormStep, min_norm_step
from bracekit.resolution.task_space import TASK_SPACES, TaskSpace


def _states(name: str, count: int = 8, scale: float = 0.2):  # type: ignore[no-untyped-def]
    sc = load_scenario(name)
    rng = np.random.default_rng(23)
    base = np.asarray(sc.guess, dtype=float)
    return sc, [sc.braced.state(base + scale * rng.standard_normal(base.shape)) for _ in range(count)], rng


@pytest.mark.parametrize("name", ["paper", "panda", "two-braces"])
@pytest.mark.parametrize("kind", [FreeSpaceMinNorm, BracedMinNorm])
@pytest.mark.parametrize("space", ["pose", "position"])
def test_the_lean_step_is_the_strategy_s_velocity(name: str, kind: type, space: str) -> None:
    """Reference: ``strategy.velocity`` (the SVD pseudo-inverse of S J or S A, q̇1 from the chain split)."""
    sc, states, rng = _states(name)
    strategy = kind(space=TaskSpace(space))
    step = min_norm_step(sc.braced, strategy)
    assert isinstance(step, MinNormStep)
    assert step.lean == (kind is FreeSpaceMinNorm or name != "two-braces")  # several braces: the reference
    checked = 0
    for st in states:
        xd = rng.standard_normal(6)
        try:
            want = strategy.velocity(st, xd)
        except SingularityError:
            continue
        got = step(st, xd)
        assert np.all(np.abs(got - want) <= 1e-11 * np.max(np.abs(want)))
        if not step.lean:
            assert np.array_equal(got, want)
        checked += 1
    assert checked >= len(states) // 2


def test_the_lean_step_is_only_for_the_minimum_norm_strategies() -> None:
    sc = load_scenario("paper")
    assert min_norm_step(sc.braced, sc.strategy("braced_gradient_projection")) is None
    assert TASK_SPACES  # the spaces the parametrisation names exist


@pytest.mark.parametrize("kind", [FreeSpaceMinNorm, BracedMinNorm])
def test_an_uncertified_state_takes_the_strategy_s_own_velocity_and_its_error(kind: type) -> None:
    """No certificate passes (a bound of 1 on the condition number): every q̇ and error is the reference's."""
    sc, states, rng = _states("paper", 4)
    strategy = kind()
    step = MinNormStep(sc.braced, strategy)
    step._cert2 = 1.0  # cond ≥ 1: never certified
    for st in states:
        xd = rng.standard_normal(6)
        assert np.array_equal(step(st, xd), strategy.velocity(st, xd))
    # a singular J (a zero row) or J1 (zero): the reference's SingularityError
    st = states[0]
    if kind is FreeSpaceMinNorm:
        st = replace(st, J_e=st.J_e * np.array([1.0, 1.0, 1.0, 1.0, 1.0, 0.0])[:, None])
    else:
        st = replace(st, contacts=(replace(st.contacts[0], J_b=np.zeros_like(st.contacts[0].J_b)),))
    with pytest.raises(SingularityError) as ref:
        strategy.velocity(st, np.ones(6))
    with pytest.raises(SingularityError) as got:
        MinNormStep(sc.braced, strategy)(st, np.ones(6))
    assert str(got.value) == str(ref.value)
