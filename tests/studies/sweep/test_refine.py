from __future__ import annotations

import dataclasses
import threading
import types
from concurrent.futures import CancelledError
from pathlib import Path
from typing import Any

import pytest

from bracekit.studies.sweep.candidates import Candidate, candidate_id, expand
from bracekit.studies.sweep.context import task_context
from bracekit.studies.sweep.evaluate import evaluate_candidate
from bracekit.studies.sweep.refine import PENALTY, interval, refine_candidate
from bracekit.studies.sweep.spec import load_spec


def test_interval_is_between_the_grid_neighbours() -> None:
    spec = load_spec("paper-links")
    assert interval(spec, 0.02) == (0.0, pytest.approx(0.06))
    lo, hi = interval(spec, 0.5)
    assert lo == pytest.approx(0.46) and hi == pytest.approx(0.54)
    assert interval(dataclasses.replace(spec, mode="random"), 0.95) == (pytest.approx(0.85), 1.0)


def test_refinement_reports_its_best_feasible_evaluation(tiny_spec: Path) -> None:
    spec = load_spec(tiny_spec)
    spec = dataclasses.replace(spec, refinement=dataclasses.replace(spec.refinement, max_evaluations=3, xatol=0.05))
    cand = expand(spec)[0]  # link4 at 0.3
    ctx = task_context(spec, {}, cand.context_key)
    out = refine_candidate(spec, cand, ctx, 0.2, 0.4)
    assert 1 <= out["evaluations"] <= 4
    if out["refined_fraction"] is None:
        pytest.skip("no feasible evaluation in the interval")
    assert 0.2 <= out["refined_fraction"] <= 0.4
    inputs = cand.inputs | {"fraction": out["refined_fraction"]}
    again = evaluate_candidate(spec, Candidate(-1, candidate_id(inputs), inputs), ctx)
    assert again["feasible"] and again["Ci_mean_gp"] == out["refined_Ci_mean_gp"] < PENALTY


class _Interrupted:
    """A Dask client stand-in whose evaluations are interrupted (Ctrl-C while waiting for a worker)."""

    def __init__(self) -> None:
        self.submitted = 0
        self.cancelled: list[object] = []

    def submit(self, *args: object, **kwargs: object) -> _Interrupted:
        self.submitted += 1
        return self

    def result(self) -> None:
        raise KeyboardInterrupt

    def cancel(self, futures: list[object]) -> None:
        self.cancelled += futures


def test_an_interrupted_refinement_cancels_its_evaluations(tiny_spec: Path, tmp_path: Path) -> None:
    from bracekit.studies.sweep.refine import refine_best
    from bracekit.studies.sweep.store import RowStore

    spec = load_spec(tiny_spec)
    cands = expand(spec)
    row = {"candidate": cands[0].id, "index": 0, "feasible": True, "Ci_mean_gp": 0.004, "fraction": 0.3}
    client = _Interrupted()
    futures: list[object] = []
    with pytest.raises(KeyboardInterrupt):
        refine_best(spec, [row], cands, {cands[0].context_key: None}, client, RowStore(tmp_path, spec), futures)
    assert client.submitted == 1 and client.cancelled == futures == [client]  # no evaluation after the interrupt
    assert not list((tmp_path / ".sweep" / "refined").iterdir())


class _Stopping:
    """The interleaving of an interrupt with a search that has passed its stop check but not yet submitted.

    Two searches: A's first evaluation is interrupted (Ctrl-C while waiting, as :class:`_Interrupted`) only once
    B has checked the stop and found it clear; B then holds until the interrupt is under way (the stopper has
    cancelled, or waits for B to submit) and submits. The client records every submit and cancel in order.
    Every wait is bounded (a hang fails the test instead of blocking it).
    """

    WAIT = 20.0  # s, only reached if the interleaving cannot happen (a failure, reported by the asserts)

    def __init__(self, first: str, main: threading.Thread) -> None:
        self.first, self.main = first, main  # A's candidate; the thread that runs refine_best (the stopper)
        self.log: list[tuple[str, list[Any]]] = []  # ("submit", [its future]) or ("cancel", futures)
        self.roles: dict[threading.Thread, str] = {}
        self.a_submitted = threading.Event()
        self.b_checked = threading.Event()
        self.stopping = threading.Event()
        self._log_lock = threading.Lock()

    def role(self) -> str:
        return self.roles.get(threading.current_thread(), "")

    # the Dask client
    def submit(self, *args: object, **kwargs: object) -> _Future:
        fut = _Future(self, self.role())
        with self._log_lock:
            self.log.append(("submit", [fut]))
        if fut.role == "A":
            self.a_submitted.set()
        return fut

    def cancel(self, futures: list[object]) -> None:
        with self._log_lock:
            self.log.append(("cancel", list(futures)))
        self.stopping.set()

    # hooks of the refinement's stop event and lock (module `threading` of refine.py)
    def before_check(self) -> None:
        if self.role() == "B":
            self.a_submitted.wait(self.WAIT)

    def after_check(self) -> None:
        if self.role() == "B" and not self.b_checked.is_set():
            self.b_checked.set()
            self.stopping.wait(self.WAIT)

    def before_lock(self) -> None:
        if threading.current_thread() is self.main:
            self.stopping.set()  # the stopper is under way: B may submit, which the stopper waits for
        else:
            self.before_check()


class _Future:
    def __init__(self, client: _Stopping, role: str) -> None:
        self.client, self.role = client, role

    def result(self) -> None:
        if self.role == "A":  # interrupted once B stands between its check and its submit
            self.client.b_checked.wait(self.client.WAIT)
            raise KeyboardInterrupt
        raise CancelledError


def test_no_evaluation_is_submitted_after_an_interrupt(
    tiny_spec: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A search between its stop check and its submit when the interrupt comes: its evaluation is cancelled too.

    Reference: the order of the client's calls; every submitted evaluation must be in a cancel that follows it.
    """
    from bracekit.studies.sweep import refine
    from bracekit.studies.sweep.store import RowStore

    spec = load_spec(tiny_spec)
    spec = dataclasses.replace(spec, refinement=dataclasses.replace(spec.refinement, top=2))
    cands = expand(spec)
    rows = [
        {"candidate": c.id, "index": i, "feasible": True, "Ci_mean_gp": 0.004 + 0.001 * i, "fraction": 0.3}
        for i, c in enumerate(cands[:2])
    ]
    client = _Stopping(cands[0].id, threading.current_thread())
    real_refine = refine.refine_candidate

    def tagged(spec: object, c: Candidate, *args: Any, **kwargs: Any) -> dict[str, Any]:
        client.roles[threading.current_thread()] = "A" if c.id == client.first else "B"
        return real_refine(spec, c, *args, **kwargs)  # type: ignore[arg-type]

    class Event(threading.Event):
        def is_set(self) -> bool:
            client.before_check()
            value = super().is_set()
            client.after_check()
            return value

    class Lock:
        def __init__(self) -> None:
            self._lock = threading.Lock()

        def __enter__(self) -> bool:
            client.before_lock()
            return self._lock.__enter__()

        def __exit__(self, *exc: Any) -> None:
            self._lock.__exit__(*exc)

    hooked = types.SimpleNamespace(**{k: getattr(threading, k) for k in dir(threading) if not k.startswith("__")})
    hooked.Event, hooked.Lock = Event, Lock
    monkeypatch.setattr(refine, "threading", hooked)
    monkeypatch.setattr(refine, "refine_candidate", tagged)
    futures: list[object] = []
    contexts = {c.context_key: None for c in cands}
    with pytest.raises(KeyboardInterrupt):
        refine.refine_best(spec, rows, cands, contexts, client, RowStore(tmp_path, spec), futures)
    for thread in list(client.roles):  # the searches end (their evaluations cancelled) before the record is read
        thread.join(client.WAIT)
        assert not thread.is_alive()
    assert client.b_checked.is_set() and client.stopping.is_set()  # the interleaving happened
    submitted = [f for kind, fs in client.log if kind == "submit" for f in fs]
    assert [f.role for f in submitted] == ["A", "B"]
    first_cancel = next(i for i, (kind, _) in enumerate(client.log) if kind == "cancel")
    assert all(kind == "cancel" for kind, _ in client.log[first_cancel:])  # nothing submitted after the stop
    cancelled = [f for kind, fs in client.log if kind == "cancel" for f in fs]
    assert all(any(f is c for c in cancelled) for f in submitted)  # every evaluation submitted is cancelled
    assert not list((tmp_path / ".sweep" / "refined").iterdir())
