"""The lean minimum-norm step equals each strategy's own velocity (SVD pseudo-inverse, chain split) to round-off."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from bracekit import BracedMinNorm, FreeSpaceMinNorm, load_scenario
from bracekit.errors import SingularityError
from bracekit.resolution import numba_available
from bracekit.resolution.min_norm import MinNormStep, min_norm_step
from bracekit.resolution.task_space import TASK_SPACES, TaskSpace
from bracekit.tolerances import NULL_SPACE_RTOL


def _states(name: str, count: int = 8, scale: float = 0.2):  # type: ignore[no-untyped-def]
    sc = load_scenario(name)
    rng = np.random.default_rng(23)
    base = np.asarray(sc.guess, dtype=float)
    return sc, [sc.braced.state(base + scale * rng.standard_normal(base.shape)) for _ in range(count)], rng


@pytest.mark.parametrize("name", ["paper", "panda", "two-braces"])
@pytest.mark.parametrize("kind", [FreeSpaceMinNorm, BracedMinNorm])
@pytest.mark.parametrize("space", ["pose", "position", "position+axis"])
@pytest.mark.parametrize("backend", ["numpy", "auto"])
def test_the_lean_step_is_the_strategy_s_velocity(name: str, kind: type, space: str, backend: str) -> None:
    """Reference: ``strategy.velocity`` (the SVD pseudo-inverse of S J or S A, q̇1 from the chain split).

    Both the NumPy code and the compiled kernel (numba installed; panda: n1 ≠ 6; pose and position rows; the
    rows of position+axis, S turning with the tool, in NumPy).
    """
    sc, states, rng = _states(name)
    strategy = kind(space=TaskSpace(space))
    step = min_norm_step(sc.braced, strategy, backend)  # type: ignore[arg-type]
    assert isinstance(step, MinNormStep)
    if backend == "auto" and numba_available():  # the kernel: free space and one brace, pose and position rows
        assert step.uses_kernel == (space != "position+axis" and (kind is FreeSpaceMinNorm or name != "two-braces"))
    else:
        assert not step.uses_kernel
    checked = compiled = 0
    for st in states:
        xd = rng.standard_normal(6)
        try:
            want = strategy.velocity(st, xd)
        except SingularityError:
            continue
        got = step(st, xd)
        if step.uses_kernel:  # the kernel itself, not a fallback, gave it
            c = st.contacts[0]
            constants = (step._h, step._x, step._n1, step._braced, step._rows, step._cert2, NULL_SPACE_RTOL)
            status, alone = step._kernel(st.J_e, c.J_b, c.b, st.e, xd, *constants)
            compiled += status == 0
            assert status != 0 or np.array_equal(alone, got)
        assert np.all(np.abs(got - want) <= 1e-11 * np.max(np.abs(want)))
        checked += 1
    assert checked >= len(states) // 2
    assert compiled >= checked // 2 if step.uses_kernel else compiled == 0


def test_the_lean_step_is_only_for_the_minimum_norm_strategies() -> None:
    sc = load_scenario("paper")
    assert min_norm_step(sc.braced, sc.strategy("braced_gradient_projection")) is None
    assert TASK_SPACES  # the spaces the parametrisation names exist


@pytest.mark.parametrize("kind", [FreeSpaceMinNorm, BracedMinNorm])
@pytest.mark.parametrize("backend", ["numpy", "auto"])
def test_an_uncertified_state_takes_the_strategy_s_own_velocity_and_its_error(kind: type, backend: str) -> None:
    """No certificate passes (a bound of 1 on the condition number): every q̇ and error is the reference's."""
    sc, states, rng = _states("paper", 4)
    strategy = kind()
    step = MinNormStep(sc.braced, strategy, backend)  # type: ignore[arg-type]
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
        MinNormStep(sc.braced, strategy, backend)(st, np.ones(6))  # type: ignore[arg-type]
    assert str(got.value) == str(ref.value)


def test_several_braces_with_a_dependent_row_take_the_reference_step_and_its_warning() -> None:
    """The paper's brace twice: rows of G depend on each other; reference: BracedMinNorm.velocity and its warning."""
    import warnings

    from bracekit.kinematics import BracedRobot

    sc = load_scenario("paper")
    twice = BracedRobot(sc.braced.robot, [sc.braced.braces[0], sc.braced.braces[0]])
    strategy = BracedMinNorm()
    step = MinNormStep(twice, strategy)
    base = np.asarray(sc.guess, dtype=float)
    xd = np.array([0.01, -0.02, 0.005, 0.0, 0.0, 0.0])
    with warnings.catch_warnings(record=True) as ours:
        warnings.simplefilter("always")
        try:
            got = step(twice.state(base), xd)
        except SingularityError as exc:
            got = str(exc)
    with warnings.catch_warnings(record=True) as ref:
        warnings.simplefilter("always")
        try:
            want = strategy.velocity(twice.state(base), xd)
        except SingularityError as exc:
            want = str(exc)
    assert ref and [str(w.message) for w in ours] == [str(w.message) for w in ref]
    assert got == want if isinstance(want, str) else np.array_equal(got, want)
