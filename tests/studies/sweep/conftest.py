"""A tiny sweep for the tests: the paper scenario cut to 1 s of its circle (10 steps of 0.1 s), 4 candidates."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from helpers import scenario_text

SPEC = """
name = "tiny"
base = "short.toml"
[axes]
link = ["link4", "link8"]
fraction = [0.3, 0.7]
[screen]
keep_fraction = 0.5
[refine]
top = 1
max_evaluations = 4
xatol = 0.05
"""


@pytest.fixture(scope="session")
def tiny_spec(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The tiny spec's path (its base scenario beside it)."""
    folder = tmp_path_factory.mktemp("spec")
    (folder / "short.toml").write_text(scenario_text(turns=0.05, dt=0.1), encoding="utf-8")
    path = folder / "tiny.toml"
    path.write_text(SPEC, encoding="utf-8")
    return path


@pytest.fixture(scope="session")
def client2() -> Iterator[object]:
    """A local Dask cluster of 2 worker processes, shared by the tests."""
    from bracekit.studies.sweep.engine import dask_client

    with dask_client(workers=2) as client:
        yield client
