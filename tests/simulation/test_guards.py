"""The σ-ratio guard taken over batches of samples: the same numbers and the same stop as one check per sample.

References: NumPy's SVD of each matrix alone (``singular_ratio``, ``rank_ratio``, ``sigma_ratios`` of each
state) and, for a run, the ratios a complete run records at each sample, checked one by one here.
"""

from __future__ import annotations

import importlib
import warnings
from collections.abc import Callable
from dataclasses import fields
from pathlib import Path

import numpy as np
import pytest

from bracekit import BracedMinNorm, Circle, load_scenario, simulate, solve_start
from bracekit.errors import NumericalError
from bracekit.kinematics.motions import MATRIX_LABELS, rank_ratio, singular_ratio
from bracekit.simulation.guards import WATCH_BATCH, first_singular, sigma_ratios, stacked_sigma_ratios
from bracekit.simulation.scenario import Scenario
from bracekit.simulation.stacked_ratios import FULL_ROW_RANK, Watched, _split_stacks, stacked_ratios
from bracekit.simulation.trajectory import Trajectory

GUARDS = importlib.import_module("bracekit.simulation.guards")


def _matrices(rng: np.random.Generator) -> list[np.ndarray]:
    ms = [rng.standard_normal(shape) for shape in [(6, 6), (6, 10), (6, 6), (7, 5), (6, 10), (3, 11)]]
    ms.append(np.zeros((6, 6)))
    ms.append(np.outer(rng.standard_normal(6), rng.standard_normal(10)))  # rank 1
    ms.append(np.zeros((0, 4)))
    ms.append(np.zeros((3, 0)))
    return ms


@pytest.mark.parametrize("full_row_rank", [False, True])
def test_stacked_ratios_are_each_matrix_own_svd_ratio_to_the_last_bit(full_row_rank: bool) -> None:
    rng = np.random.default_rng(3)
    ms = _matrices(rng)
    alone = rank_ratio if full_row_rank else singular_ratio
    assert stacked_ratios(ms, full_row_rank) == [alone(m) for m in ms]


@pytest.mark.parametrize(("name", "scale"), [("paper", 0.3), ("panda", 0.1), ("two-braces", 0.05)])
def test_stacked_sigma_ratios_equal_sigma_ratios_of_each_state(name: str, scale: float) -> None:
    sc = load_scenario(name)
    rng = np.random.default_rng(11)
    base = np.asarray(sc.guess, dtype=float)
    states = [sc.braced.state(base + scale * rng.standard_normal(base.shape)) for _ in range(7)]
    keys = tuple(sigma_ratios(states[0], sc.task_space))
    found = stacked_sigma_ratios(states, sc.task_space, keys).ratios
    assert found == [sigma_ratios(st, sc.task_space, keys) for st in states]
    assert stacked_sigma_ratios([], sc.task_space, keys).ratios == []


def test_a_stack_watched_under_two_keys_is_decomposed_once(monkeypatch: pytest.MonkeyPatch) -> None:
    from bracekit.simulation import stacked_ratios as module

    sc = load_scenario("paper")  # the whole pose: S A is A
    rng = np.random.default_rng(5)
    base = np.asarray(sc.guess, dtype=float)
    states = [sc.braced.state(base + 0.1 * rng.standard_normal(base.shape)) for _ in range(4)]
    keys = tuple(sigma_ratios(states[0], sc.task_space))
    calls = []
    svd = np.linalg.svd

    def counted(m, **kw):  # type: ignore[no-untyped-def]
        calls.append(m.shape)
        return svd(m, **kw)

    monkeypatch.setattr(module.np.linalg, "svd", counted)
    found = stacked_sigma_ratios(states, sc.task_space, keys).ratios
    monkeypatch.setattr(module.np.linalg, "svd", svd)
    assert set(keys) == {"J1", "A", "SA", "J", "J_braced"} and len(calls) == len(keys) - 1
    assert found == [sigma_ratios(st, sc.task_space, keys) for st in states]
    assert all(row["A"] == row["SA"] for row in found)


def _assert_sample(stacks: Watched[np.ndarray], i: int, want: Watched[np.ndarray]) -> None:
    """Sample i of each stack is the wanted matrix to the last bit, and the stacks form no other matrix."""
    for f in fields(want):
        stack, matrix = getattr(stacks, f.name), getattr(want, f.name)
        assert (stack is None) == (matrix is None), f.name
        if matrix is not None:
            assert np.array_equal(stack[i], matrix), f.name


def test_the_record_s_fields_are_the_keys_of_the_recorded_measures() -> None:
    """Reference: MATRIX_LABELS (the measures' keys) and J_e N ("JN"), one field each, both ways."""
    keys = (*MATRIX_LABELS, "JN")
    record = Watched.of_keys({key: i for i, key in enumerate(keys)})
    assert [record.get(key) for key in keys] == list(range(len(keys)))
    assert sorted(getattr(record, f.name) for f in fields(record)) == list(range(len(keys)))
    assert record.get("j_e") is None and Watched.of_keys({"J_e": 0}) == Watched()


@pytest.mark.parametrize("name", ["paper", "two-braces"])
def test_the_matrices_that_need_full_row_rank_are_those_each_chart_flags(name: str) -> None:
    """Reference: the flags of ``motions.watched`` (``rank_ratio`` or ``singular_ratio`` of each matrix)."""
    sc = load_scenario(name)
    watched = sc.braced.state(np.asarray(sc.guess, dtype=float)).motions.watched(None)
    assert {key for key, (_, full) in watched.items() if full} == FULL_ROW_RANK & set(watched)


def test_first_singular_names_the_first_sample_below_the_ratio() -> None:
    keys = ("A", "J")
    rows = [{"A": 0.1, "J": 0.2}, {"A": 0.1, "J": 1e-9}, {"A": 1e-8, "J": 0.2}]
    found = first_singular(rows, keys)
    assert found is not None and found[0] == 1 and "J" in str(found[1])
    assert first_singular(rows[:1], keys) is None
    assert first_singular(rows, ("A",)) is not None and first_singular(rows, ("A",))[0] == 2  # type: ignore[index]


def _paper_run(turns: float) -> tuple[Scenario, Callable[[], Trajectory]]:
    """The paper scenario and a braced minimum-norm run along `turns` of its circle at dt = 0.1 s."""
    sc = load_scenario("paper")
    start = solve_start(sc.braced, sc.task.position(0.0), sc.guess)
    c = sc.task
    assert isinstance(c, Circle)
    task = Circle(c.centre, c.radius, c.normal, c.period, c.start_direction, turns=turns)
    return sc, lambda: simulate(sc.braced, BracedMinNorm(), task, start.q, 0.1, sc.beta_x)


def _refuse(*_: object) -> None:
    raise NumericalError("no stack here")


@pytest.mark.parametrize("stacked", [True, False])
def test_a_run_stops_at_the_first_singular_sample_inside_a_batch(
    monkeypatch: pytest.MonkeyPatch, stacked: bool
) -> None:
    sc, run = _paper_run(1.0)
    whole = run()
    assert whole.completed and whole.steps > 2 * WATCH_BATCH
    keys = sc.braced.state(whole.q[0]).motions.inverted(True)
    lowest = np.min([whole.measures[f"sigma_ratio_{key}"] for key in keys], axis=0)
    # a sample past the first batch, not at its end, whose ratio is the lowest so far: the threshold just above it
    ks = [k for k in range(WATCH_BATCH + 2, whole.steps) if lowest[k] < lowest[:k].min() and k % WATCH_BATCH]
    assert ks, "the run's ratios never fall past the first batch"
    k = ks[0]
    threshold = 0.5 * (lowest[k] + lowest[:k].min())
    monkeypatch.setattr(GUARDS, "PATH_SINGULAR_RATIO", threshold)
    if not stacked:  # the guard takes each sample alone
        monkeypatch.setattr(importlib.import_module("bracekit.simulation.loop"), "stacked_sigma_ratios", _refuse)
    cut = run()
    assert not cut.completed and cut.failure is not None
    assert cut.failure.startswith(f"step {k} (t = {k * whole.t[1]:.3f} s)") and "singular on the path" in cut.failure
    assert cut.q.shape[0] == k and np.array_equal(cut.q, whole.q[:k])
    for key in keys:
        assert np.array_equal(cut.measures[f"sigma_ratio_{key}"], whole.measures[f"sigma_ratio_{key}"][:k])


@pytest.mark.parametrize(("name", "scale"), [("paper", 0.3), ("panda", 0.1)])
def test_one_brace_stacks_are_the_chain_split_matrices_to_the_last_bit(name: str, scale: float) -> None:
    """Reference: ``state.split`` (J1, A, S A, J̃) and J_e of each state, formed one state at a time."""
    sc = load_scenario(name)
    rng = np.random.default_rng(13)
    base = np.asarray(sc.guess, dtype=float)
    states = [sc.braced.state(base + scale * rng.standard_normal(base.shape)) for _ in range(5)]
    space = sc.task_space
    rows = [None if space.is_pose else space.selection(st.R_e) for st in states]
    stacks = _split_stacks(states, rows)
    assert stacks is not None
    for i, (st, sel) in enumerate(zip(states, rows, strict=True)):
        sp = st.split
        sa = sp.A if sel is None else sel @ sp.A
        _assert_sample(stacks, i, Watched(J1=sp.J1, A=sp.A, SA=sa, J_e=st.J_e, J_braced=sp.J_braced))


def test_where_the_stacks_cannot_be_formed_the_guard_takes_each_sample_alone(monkeypatch: pytest.MonkeyPatch) -> None:
    """Reference: the same run with the stacked guard (the same states, ratios and stop)."""
    _, run = _paper_run(0.3)
    stacked = run()
    loop = importlib.import_module("bracekit.simulation.loop")

    monkeypatch.setattr(loop, "stacked_sigma_ratios", _refuse)
    alone = run()
    assert alone.completed == stacked.completed and np.array_equal(alone.q, stacked.q)
    for key, series in stacked.measures.items():
        if key.startswith("sigma_ratio_"):
            assert np.array_equal(alone.measures[key], series), key


def test_an_error_after_a_singular_sample_not_yet_guarded_reports_the_singularity(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A step that raises something else than bracekit's errors inside a batch: the earlier singular sample wins."""
    from bracekit.simulation.correction import Correction

    loop = importlib.import_module("bracekit.simulation.loop")
    sc, run = _paper_run(1.0)
    whole = run()
    keys = sc.braced.state(whole.q[0]).motions.inverted(True)
    lowest = np.min([whole.measures[f"sigma_ratio_{key}"] for key in keys], axis=0)
    ks = [k for k in range(WATCH_BATCH + 2, whole.steps - 1) if lowest[k] < lowest[:k].min() and (k + 1) % WATCH_BATCH]
    assert ks, "the run's ratios never fall past the first batch"
    k = ks[0]

    class Failing(Correction):
        calls = 0

        def __call__(self, *args, **kwargs):  # type: ignore[no-untyped-def]
            Failing.calls += 1
            if Failing.calls == k + 1:  # the step after the singular sample k, in the same batch
                raise FloatingPointError("not a bracekit error")
            return super().__call__(*args, **kwargs)

    monkeypatch.setattr(loop, "Correction", Failing)
    with pytest.raises(FloatingPointError):  # no singular sample before it: the error is not hidden
        run()
    Failing.calls = 0
    monkeypatch.setattr(GUARDS, "PATH_SINGULAR_RATIO", 0.5 * (lowest[k] + lowest[:k].min()))
    cut = run()
    assert not cut.completed and cut.failure is not None
    assert cut.failure.startswith(f"step {k} (t = {k * whole.t[1]:.3f} s)") and "singular on the path" in cut.failure
    assert np.array_equal(cut.q, whole.q[:k])


@pytest.mark.parametrize(("name", "scale"), [("paper", 0.3), ("panda", 0.1), ("two-braces", 0.05)])
def test_the_kept_stacks_are_each_state_s_own_matrix_and_svd(name: str, scale: float) -> None:
    """Reference: each state's watched matrix formed alone (``motions.watched``) and NumPy's SVD of it alone."""
    sc = load_scenario(name)
    rng = np.random.default_rng(17)
    base = np.asarray(sc.guess, dtype=float)
    states = [sc.braced.state(base + scale * rng.standard_normal(base.shape)) for _ in range(6)]
    keys = tuple(sigma_ratios(states[0], sc.task_space))
    fresh = [sc.braced.state(st.q) for st in states]  # nothing formed yet: the stacks form every matrix
    found, kept = stacked_sigma_ratios(fresh, sc.task_space, keys)
    assert found == [sigma_ratios(st, sc.task_space, keys) for st in states]
    task = states[0].motions.task_key(sc.task_space.is_pose)
    assert task is not None and kept.get(task) is not None and kept.J_e is not None
    held = [key for key in (*keys, "JN") if kept.get(key) is not None]
    assert set(keys) <= set(held)  # every recorded matrix decomposed, and no field but those
    assert sum(getattr(kept, f.name) is not None for f in fields(kept)) == len(held)
    for i, st in enumerate(states):
        rows = None if sc.task_space.is_pose else sc.task_space.selection(st.R_e)
        watched = st.motions.watched(rows)
        for key in held:
            d = kept.get(key)
            assert d is not None
            stack, s = d
            matrix = watched[key][0]() if key in watched else st.motions.task_jacobian
            assert np.array_equal(stack[i], matrix), key
            assert np.array_equal(s[i], np.linalg.svd(matrix, compute_uv=False)), key
        d = kept.get(task)
        assert d is not None and np.array_equal(d.stack[i], st.motions.task_jacobian)


@pytest.mark.parametrize("space", ["pose", "position"])
def test_several_brace_stacks_are_each_state_s_constraint_matrices_to_the_last_bit(space: str) -> None:
    """Reference: each state's stacked constraint (G, N by ``contact_null_space``), J_e N and S J_e N, alone."""
    from bracekit.resolution.task_space import TaskSpace
    from bracekit.simulation.stacked_ratios import _null_stacks

    sc = load_scenario("two-braces")
    task_space = TaskSpace(space)
    rng = np.random.default_rng(19)
    base = np.asarray(sc.guess, dtype=float)
    states = [sc.braced.state(base + 0.05 * rng.standard_normal(base.shape)) for _ in range(5)]
    rows = [None if task_space.is_pose else task_space.selection(st.R_e) for st in states]
    stacks = _null_stacks(states, rows)
    assert stacks is not None
    for i, (st, sel) in enumerate(zip(states, rows, strict=True)):
        m = st.motions
        assert st.constraint.dependent == ()
        _assert_sample(stacks, i, Watched(G=m.G, SJN=m.A if sel is None else sel @ m.A, J_e=st.J_e, JN=m.A))
    assert _null_stacks(states, rows) is None  # their constraints are known now: each state's own counts


def test_dependent_braces_are_left_to_each_state_s_constraint_and_its_warning() -> None:
    """The paper's brace twice: rows of G depend on each other, the states drop them and warn, not the stacks."""
    from bracekit.errors import RedundantContactWarning, UnloadedContactWarning
    from bracekit.kinematics import BracedRobot
    from bracekit.simulation.stacked_ratios import _null_stacks

    sc = load_scenario("paper")
    twice = BracedRobot(sc.braced.robot, [sc.braced.braces[0], sc.braced.braces[0]])
    base = np.asarray(sc.guess, dtype=float)
    rng = np.random.default_rng(21)
    qs = [base + 0.1 * rng.standard_normal(base.shape) for _ in range(4)]
    assert _null_stacks([twice.state(q) for q in qs], [None] * len(qs)) is None
    with pytest.warns((RedundantContactWarning, UnloadedContactWarning)):
        keys = tuple(sigma_ratios(twice.state(qs[0]), sc.task_space))
    with warnings.catch_warnings(record=True) as stacked:
        warnings.simplefilter("always")
        found = stacked_sigma_ratios([twice.state(q) for q in qs], sc.task_space, keys).ratios
    with warnings.catch_warnings(record=True) as alone:
        warnings.simplefilter("always")
        ref = [sigma_ratios(twice.state(q), sc.task_space, keys) for q in qs]
    assert found == ref
    assert [str(w.message) for w in stacked] == [str(w.message) for w in alone] and alone


@pytest.mark.parametrize("link", ["link4", "link8"])
def test_chain1_maps_of_a_link_point_are_each_state_s_own_null_space_to_the_last_bit(link: str, tmp_path: Path) -> None:
    """Reference: ``state.split.chain1_map`` and ``state.split.A`` (n1 ≠ 6), formed one state at a time."""
    from bracekit.simulation.scenario import shipped_scenarios
    from bracekit.simulation.stacked_ratios import chain1_maps

    text = shipped_scenarios()["paper"].read_text(encoding="utf-8")
    text = text.replace('frame = "brace"', f'link = "{link}"\nframe = "p"\noffset = [0.0, 0.0, 0.05]')
    path = tmp_path / f"{link}.toml"
    path.write_text(text.replace("theta_z = 0.6", "theta_z = 0.0"), encoding="utf-8")
    sc = load_scenario(path)
    assert sc.braced.split.n1 != 6
    rng = np.random.default_rng(7)
    base = np.asarray(sc.guess, dtype=float)
    states = [sc.braced.state(base + 0.3 * rng.standard_normal(base.shape)) for _ in range(6)]
    j1 = np.array([st.split.J1 for st in states])
    maps = chain1_maps(sc.braced.split.X, j1)
    stacks = _split_stacks(states, [None] * len(states))
    assert maps is not None and stacks is not None
    for i, st in enumerate(states):
        assert np.array_equal(maps[i], st.split.chain1_map)
        assert stacks.A is not None and np.array_equal(stacks.A[i], st.split.A)
    # a J1 whose Xᵀ J1 has another rank (zero: the whole chain-1 space) is left to each state
    j1[2] = 0.0
    assert chain1_maps(sc.braced.split.X, j1) is None
