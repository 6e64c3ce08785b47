"""The measures of a whole path at once equal the per-sample reference, and fail where it fails."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from bracekit import Circle, load_scenario, simulate, solve_start
from bracekit.errors import InputError
from bracekit.simulation.path_measures import measure_path, path_ratios
from bracekit.simulation.samples import Samples, measure


def _path(name: str):  # type: ignore[no-untyped-def]
    sc = load_scenario(name)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        start = solve_start(sc.braced, sc.task.position(0.0), sc.guess)
        task = Circle(
            sc.task.centre, sc.task.radius, sc.task.normal, sc.task.period, sc.task.start_direction, turns=0.1
        )
        tr = simulate(sc.braced, sc.strategy("braced_gradient_projection"), task, start.q, sc.dt, sc.beta_x)
    states = [sc.braced.state(q) for q in tr.q]
    n = len(states)
    rng = np.random.default_rng(3)
    betas = [sc.beta_x(t) for t in tr.t]
    errors = list(rng.uniform(0, 1e-6, n))
    ratios = [{"a": float(x), "b": float(2 * x)} for x in rng.uniform(0, 1, n)]
    steps = list(rng.uniform(0, 1e-2, n))
    return sc, states, betas, errors, ratios, steps


def _assert_equal(batch: Samples, ref: Samples) -> None:
    a, b = batch.as_dict(), ref.as_dict()
    assert a.keys() == b.keys()
    for key in b:
        np.testing.assert_array_equal(np.isfinite(a[key]), np.isfinite(b[key]), err_msg=key)
        fin = np.isfinite(b[key])
        scale = np.maximum(np.abs(b[key][fin]), 1e-300)
        assert np.all(np.abs(a[key][fin] - b[key][fin]) <= 1e-12 * scale), key


@pytest.mark.parametrize("name", ["paper", "two-braces"])
def test_the_path_at_once_equals_the_samples_one_by_one(name: str) -> None:
    sc, states, betas, errors, ratios, steps = _path(name)
    samples, count, error = measure_path(sc.braced, states, betas, errors, ratios, steps)
    assert error is None and count == len(states) and samples is not None
    ref = Samples.stack(sc.braced, [measure(*row) for row in zip(states, betas, errors, ratios, steps, strict=True)])
    _assert_equal(samples, ref)
    assert set(samples.Ci) == ({"free", "constrained", "projection"} if name == "paper" else {"free", "constrained"})


def test_a_sample_the_reference_refuses_ends_the_path_there_with_its_error() -> None:
    sc, states, betas, errors, ratios, steps = _path("paper")
    bad = list(betas)
    bad[5] = np.zeros(6)  # not a twist: the reference raises InputError at sample 5
    samples, count, error = measure_path(sc.braced, states, bad, errors, ratios, steps)
    with pytest.raises(InputError) as ref:
        measure(states[5], bad[5], errors[5], ratios[5], steps[5])
    assert count == 5 and isinstance(error, InputError) and str(error) == str(ref.value)
    assert samples is not None and samples.series["k"].size == 5
    _assert_equal(
        samples,
        Samples.stack(sc.braced, [measure(*r) for r in zip(states[:5], betas, errors, ratios, steps, strict=False)]),
    )


def test_a_refused_first_sample_gives_no_samples() -> None:
    sc, states, betas, errors, ratios, steps = _path("two-braces")
    bad = [np.full(6, np.nan), *betas[1:]]
    samples, count, error = measure_path(sc.braced, states, bad, errors, ratios, steps)
    assert samples is None and count == 0 and isinstance(error, InputError)


def test_no_states_no_samples() -> None:
    sc = load_scenario("paper")
    assert measure_path(sc.braced, [], [], [], [], []) == (None, 0, None)


@pytest.mark.parametrize("name", ["paper", "two-braces"])
def test_the_path_ratios_equal_the_guard_s_ratios(name: str) -> None:
    from bracekit.simulation.guards import sigma_ratios

    sc, states, *_ = _path(name)
    space = sc.strategy("braced_gradient_projection").space
    ref = [sigma_ratios(st, space) for st in states]
    keys = tuple(ref[0])
    checked = states[0].motions.inverted(True)
    known = [{key: r[key] for key in checked} for r in ref]
    got = path_ratios(states, space, keys, known)
    assert [tuple(g) for g in got] == [keys] * len(states)
    for g, r in zip(got, ref, strict=True):
        assert all(abs(g[key] - r[key]) <= 1e-12 * abs(r[key]) for key in keys)


@pytest.mark.parametrize(
    ("name", "strategy"),
    [("paper", "free_space_min_norm"), ("paper", "braced_min_norm"), ("two-braces", "braced_min_norm")],
)
def test_every_ratio_taken_at_once_equals_the_guard_s_ratio(name: str, strategy: str) -> None:
    """Nothing known from the run: J1, A, S A, J, J̃ (one brace) or G, S J_e N, J (two) all from stacked SVDs."""
    from bracekit.simulation.guards import sigma_ratios

    sc, states, *_ = _path(name)
    space = sc.strategy(strategy).space
    ref = [sigma_ratios(st, space) for st in states]
    keys = tuple(ref[0])
    got = path_ratios([sc.braced.state(st.q) for st in states], space, keys, [{}] * len(states))
    for g, r in zip(got, ref, strict=True):
        assert tuple(g) == keys
        assert all(abs(g[key] - r[key]) <= 1e-12 * abs(r[key]) for key in keys)


def test_the_stacked_constraint_of_a_path_at_once_is_that_of_each_state() -> None:
    """Every row kept at every sample: G and 1/k_env as each state's stacked constraint; else the states decide."""
    from bracekit.kinematics import BracedRobot
    from bracekit.kinematics.constraint import full_rank_constraint as _full_rank

    sc, states, *_ = _path("two-braces")
    fresh = [sc.braced.state(st.q) for st in states]
    found = _full_rank(fresh, sc.braced.robot.stiffness)
    assert found is not None
    for st, g in zip(fresh, found[0], strict=True):
        assert st.constraint.dependent == ()
        np.testing.assert_array_equal(g, st.constraint.G)
        np.testing.assert_array_equal(found[1], st.constraint.compliance)
    assert _full_rank(fresh, sc.braced.robot.stiffness) is None  # their constraints are known now: theirs count
    # the paper's brace twice: its rows depend on each other at every configuration, the states drop them and warn
    paper = load_scenario("paper").braced
    twice = BracedRobot(paper.robot, [paper.braces[0], paper.braces[0]])
    qs = np.random.default_rng(6).uniform(paper.robot.lower, paper.robot.upper, (5, paper.n))
    assert _full_rank([twice.state(q) for q in qs], paper.robot.stiffness) is None


def test_a_stack_equal_to_one_taken_shares_its_singular_values_and_any_other_gets_its_own() -> None:
    from bracekit.simulation.path_measures import _singular_values

    stack = np.random.default_rng(2).standard_normal((50, 6, 7))
    first = _singular_values(stack)
    np.testing.assert_array_equal(first, np.linalg.svd(stack, compute_uv=False))
    assert _singular_values(stack.copy()) is first  # equal entry by entry: the same values, not redone
    other = stack.copy()
    other[17, 2, 3] += 1e-9
    found = _singular_values(other)
    assert found is not first
    np.testing.assert_array_equal(found, np.linalg.svd(other, compute_uv=False))
    assert _singular_values(stack.reshape(50, 7, 6)) is not first  # another shape


@pytest.mark.parametrize("name", ["paper", "two-braces"])
def test_the_measures_from_the_guard_s_stacks_equal_the_samples_one_by_one(name: str) -> None:
    """The run hands k's Jacobians and their SVDs over from its guard; reference: ``measure`` of each sample."""
    from bracekit.simulation.guards import WATCH_BATCH, stacked_sigma_ratios
    from bracekit.simulation.path_measures import Known
    from bracekit.simulation.stacked_ratios import Decomposed

    sc, states, betas, errors, ratios, steps = _path(name)
    fresh = [sc.braced.state(st.q) for st in states]
    space = sc.strategy("braced_gradient_projection").space
    keys = tuple(states[0].motions.conditioning(None if space.is_pose else space.selection(states[0].R_e)))
    task = states[0].motions.task_key(space.is_pose)
    assert task == ("J_braced" if name == "paper" else "JN")  # two braces: a position task, J_e N beside S J_e N
    batches = []
    for first in range(0, len(fresh), WATCH_BATCH):  # as the run's guard takes them
        batches.append(stacked_sigma_ratios(fresh[first : first + WATCH_BATCH], space, keys).decomposed)

    def joined(parts: list[Decomposed | None]) -> Decomposed:
        done = [d for d in parts if d is not None]
        assert len(done) == len(parts)
        return Decomposed(np.concatenate([d.stack for d in done]), np.concatenate([d.s for d in done]))

    known = Known(joined([b.get(task) for b in batches]), joined([b.J_e for b in batches]))
    samples, count, error = measure_path(sc.braced, fresh, betas, errors, ratios, steps, known)
    assert error is None and count == len(fresh) and samples is not None
    # nothing of the chain split or of the stacked constraint formed state by state: the stacks served
    assert all("split" not in st.__dict__ and "motions" not in st.__dict__ for st in fresh)
    ref = Samples.stack(sc.braced, [measure(*row) for row in zip(states, betas, errors, ratios, steps, strict=True)])
    _assert_equal(samples, ref)
    for key in ("k", "k_free"):  # the very numbers of the path's own SVDs
        alone, *_ = measure_path(sc.braced, [sc.braced.state(st.q) for st in states], betas, errors, ratios, steps)
        assert alone is not None
        np.testing.assert_array_equal(samples.series[key], alone.series[key])
