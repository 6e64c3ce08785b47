"""The garbage collector held off during a worker's run: its state restored, cycles freed, rows unchanged."""

from __future__ import annotations

import gc
import threading
import weakref
from pathlib import Path
from typing import Any

import pytest

from bracekit.studies.sweep import evaluate as evaluate_module
from bracekit.studies.sweep.candidates import expand
from bracekit.studies.sweep.collector import collector_paused
from bracekit.studies.sweep.context import task_context
from bracekit.studies.sweep.evaluate import evaluate_candidate
from bracekit.studies.sweep.spec import load_spec


class _Node:
    def __init__(self) -> None:
        self.me = self  # a reference cycle: only the cyclic collector frees it


@pytest.fixture
def collector_on() -> Any:
    was = gc.isenabled()
    gc.enable()
    yield
    if not was:
        gc.disable()


def test_the_collector_is_off_inside_and_back_on_after(collector_on: None) -> None:
    with collector_paused():
        assert not gc.isenabled()
        with collector_paused():  # nested
            assert not gc.isenabled()
        assert not gc.isenabled()
    assert gc.isenabled()


def test_the_cycles_left_inside_are_freed_on_leaving(collector_on: None) -> None:
    with collector_paused():
        ref = weakref.ref(_Node())
        assert ref() is not None  # alive: reference counting cannot free a cycle, the collector is off
    assert ref() is None


def test_a_program_that_had_it_off_keeps_it_off() -> None:
    was = gc.isenabled()
    gc.disable()
    try:
        with collector_paused():
            ref = weakref.ref(_Node())
        assert not gc.isenabled()
        assert ref() is not None  # nothing collected behind the program's back
    finally:
        gc.collect()
        if was:
            gc.enable()


def test_an_error_inside_restores_it(collector_on: None) -> None:
    with pytest.raises(ZeroDivisionError), collector_paused():
        _ = 1 / 0
    assert gc.isenabled()


def test_overlapping_holders_let_it_run_and_it_stays_on(collector_on: None) -> None:
    """Two task threads whose runs overlap: the collector runs meanwhile (garbage never held for long)."""
    entered, leave_first, first_left = threading.Event(), threading.Event(), threading.Event()

    def first() -> None:
        with collector_paused():
            entered.set()
            leave_first.wait(10)
        first_left.set()

    thread = threading.Thread(target=first)
    thread.start()
    assert entered.wait(10)
    assert not gc.isenabled()  # one run alone: held off
    with collector_paused():
        assert gc.isenabled()  # a second run overlaps: on again
        leave_first.set()
        assert first_left.wait(10)
        assert gc.isenabled()
    thread.join(10)
    assert gc.isenabled()
    with collector_paused():  # alone again: held off again
        assert not gc.isenabled()
    assert gc.isenabled()


def test_a_row_is_the_same_with_the_collector_on_throughout(
    tiny_spec: Path, monkeypatch: pytest.MonkeyPatch, collector_on: None
) -> None:
    spec = load_spec(tiny_spec)
    cand = expand(spec)[3]
    ctx = task_context(spec, {}, cand.context_key)
    seen: list[bool] = []
    build = evaluate_module.candidate_scenario

    def watched(*args: Any, **kwargs: Any) -> Any:
        seen.append(gc.isenabled())
        return build(*args, **kwargs)

    monkeypatch.setattr(evaluate_module, "candidate_scenario", watched)
    paused = evaluate_candidate(spec, cand, ctx)
    assert seen == [False]  # the run happened with the collector held off
    monkeypatch.setattr(evaluate_module, "collector_paused", _collector_running)
    running = evaluate_candidate(spec, cand, ctx)
    assert seen == [False, True]
    paused.pop("wall_s")
    running.pop("wall_s")
    assert paused == running


class _collector_running:  # noqa: N801 - stands in for the context manager
    def __enter__(self) -> None:
        gc.enable()

    def __exit__(self, *exc: object) -> None:
        return None
