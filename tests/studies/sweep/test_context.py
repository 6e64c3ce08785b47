"""A worker's held task contexts: the reference start and scenario solved once, equal to solving them again."""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from bracekit.errors import ConvergenceError
from bracekit.studies.sweep import context as context_module
from bracekit.studies.sweep.candidates import expand
from bracekit.studies.sweep.context import (
    context_inputs,
    held_base,
    held_reference,
    held_scenario,
    reference_context,
)
from bracekit.studies.sweep.evaluate import candidate_point, evaluate_candidate, evaluate_held
from bracekit.studies.sweep.scenario import candidate_data
from bracekit.studies.sweep.spec import load_spec


@pytest.fixture(autouse=True)
def nothing_held() -> Iterator[None]:
    context_module._HELD.clear()
    context_module._BASE.clear()
    yield
    context_module._HELD.clear()
    context_module._BASE.clear()


@pytest.fixture
def solves(monkeypatch: pytest.MonkeyPatch) -> list[int]:
    """Counts the reference starts solved in this process."""
    count: list[int] = []
    solve = context_module.reference_start

    def counted(scenario: Any) -> Any:
        count.append(1)
        return solve(scenario)

    monkeypatch.setattr(context_module, "reference_start", counted)
    return count


def _no_time(row: dict[str, Any]) -> dict[str, Any]:
    return {k: v for k, v in row.items() if k != "wall_s"}


def test_a_held_reference_is_the_solved_one_and_is_solved_once_per_spec_and_task(
    tiny_spec: Path, solves: list[int]
) -> None:
    spec = load_spec(tiny_spec)
    key = expand(spec)[0].context_key
    plain = reference_context(spec, {}, key)
    assert len(solves) == 1 and plain.q_ref is not None
    held = held_reference(spec, {}, key)
    np.testing.assert_array_equal(held.q_ref, plain.q_ref)
    assert (held.key, held.inputs, held.failure) == (plain.key, plain.inputs, None)
    assert len(solves) == 2
    assert held_reference(spec, {}, key) is held
    assert held_reference(load_spec(tiny_spec), {}, key) is held  # an equal spec (as a worker unpickles it)
    assert len(solves) == 2
    other = dataclasses.replace(spec, feasibility=dataclasses.replace(spec.feasibility, k_max=1.0))
    assert held_reference(other, {}, key) is not held  # another spec: solved again
    assert len(solves) == 3


def test_a_reference_that_cannot_be_solved_is_held_as_the_plain_one_reports_it(
    tiny_spec: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    def fails(scenario: Any) -> Any:
        raise ConvergenceError("no configuration near the guess")

    monkeypatch.setattr(context_module, "reference_start", fails)
    spec = load_spec(tiny_spec)
    plain = reference_context(spec, {}, "{}")
    held = held_reference(spec, {}, "{}")
    assert held.q_ref is None and plain.q_ref is None
    assert held.failure == plain.failure and "no configuration near the guess" in str(held.failure)
    cand = expand(spec)[0]
    assert _no_time(evaluate_held(spec, cand)) == _no_time(evaluate_candidate(spec, cand, plain))


def test_the_oldest_held_context_is_dropped_beyond_the_limit(
    tiny_spec: Path, monkeypatch: pytest.MonkeyPatch, solves: list[int]
) -> None:
    monkeypatch.setattr(context_module, "MAX_HELD", 2)
    spec = load_spec(tiny_spec)
    for key in ("a", "b", "c"):
        held_reference(spec, {}, key)
    assert list(context_module._HELD) == ["b", "c"]
    held_reference(spec, {}, "a")
    assert len(solves) == 4


def test_a_held_scenario_places_every_candidate_point_as_a_new_one(tiny_spec: Path) -> None:
    spec = load_spec(tiny_spec)
    cands = expand(spec)
    plain = reference_context(spec, {}, cands[0].context_key)
    assert held_scenario(spec, plain) is not held_scenario(spec, plain)  # nothing held yet: built each time
    fresh = [candidate_point(spec, c, plain) for c in cands]  # each from a scenario built for it alone
    held = held_reference(spec, {}, cands[0].context_key)
    assert held_scenario(spec, held) is held_scenario(spec, plain)
    for c, point in zip(cands, fresh, strict=True):
        np.testing.assert_array_equal(candidate_point(spec, c, plain), point)
    moved = dataclasses.replace(plain, inputs={"task_radius": 0.1})  # other inputs than the held ones: built anew
    assert held_scenario(spec, moved) is not held_scenario(spec, held)


def test_every_row_from_a_held_reference_is_the_row_from_a_plain_one(tiny_spec: Path, solves: list[int]) -> None:
    """The sweep's candidate task (evaluate_held) against each candidate run from its own reference context."""
    spec = load_spec(tiny_spec)
    cands = expand(spec)
    for c in cands:
        assert context_inputs(c.inputs) == {}
        plain = reference_context(spec, {}, c.context_key)
        assert _no_time(evaluate_held(spec, c)) == _no_time(evaluate_candidate(spec, c, plain))
    assert len(solves) == len(cands) + 1  # each plain one, and the held one once


def test_the_held_base_scenario_is_built_once_per_spec_and_gives_each_candidate_its_own_data(
    tiny_spec: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    spec, twin = load_spec(tiny_spec), load_spec(tiny_spec)
    ref = reference_context(spec, {}, "{}")
    assert ref.q_ref is not None
    built: list[int] = []
    base_scenario = type(spec).base_scenario

    def counted(self: Any) -> Any:
        built.append(1)
        return base_scenario(self)

    monkeypatch.setattr(type(spec), "base_scenario", counted)
    centre = np.array([0.4, 0.1, 0.3])
    fresh = []
    for c in expand(spec):  # the base built anew for each candidate
        context_module._BASE.clear()
        fresh.append(candidate_data(spec, c, ref.q_ref, centre))
    assert len(built) == len(fresh)
    context_module._BASE.clear()
    held = [candidate_data(spec, c, ref.q_ref, centre) for c in expand(spec)]
    assert held == fresh and len(built) == len(fresh) + 1
    assert held_base(twin) is held_base(spec)  # an equal spec: the same base
    assert len(built) == len(fresh) + 1
