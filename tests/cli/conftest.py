"""Fixtures of the command-line tests."""

from __future__ import annotations

import pytest


@pytest.fixture
def no_simulation(monkeypatch):
    """Make any simulation, validation or cluster start fail loudly: the input must be refused before."""

    def called(*_a, **_k):
        raise AssertionError("the computation started before the input was checked")

    monkeypatch.setattr("bracekit.simulation.run.run_scenario", called)
    monkeypatch.setattr("bracekit.validate.run_validation", called)
    monkeypatch.setattr("bracekit.studies.sweep.engine.dask_client", called)
