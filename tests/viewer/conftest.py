"""Run outputs the viewer tests read: the paper scenario cut short, written without figures."""

from __future__ import annotations

import warnings
from pathlib import Path

import pytest

from helpers import PAPER_TOML, scenario_text


def _run_into(folder: Path, text: str) -> tuple[object, Path]:
    from bracekit import load_scenario, run_scenario
    from bracekit.report import write_run

    source = folder / "scenario.toml"
    source.write_text(text, encoding="utf-8")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the free-space run's clearance warning
        result = run_scenario(load_scenario(source))
    out = folder / "out"
    write_run(result, out, figures=False)
    return result, out


@pytest.fixture(scope="module")
def short_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[object, Path]:
    """(RunResult, output folder) of the paper scenario's first tenth of the circle (21 samples per run)."""
    return _run_into(tmp_path_factory.mktemp("short"), scenario_text(turns=0.1, dt=0.1))


@pytest.fixture(scope="module")
def preloaded_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[object, Path]:
    """The same cut with a 5 N preload, gravity and the preloaded compliance model."""
    text = scenario_text(turns=0.05, dt=0.1)
    text = text.replace("# preload = 0.0", "preload = 5.0").replace("# gravity = false", "gravity = true")
    text = text.replace('model = "constrained"', 'model = "preloaded"')
    assert "preload = 5.0" in text and 'model = "preloaded"' in text
    return _run_into(tmp_path_factory.mktemp("preloaded"), text)


@pytest.fixture(scope="module")
def paper_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[object, Path]:
    """The shipped paper scenario, whole (400 samples per run; about 2 s)."""
    return _run_into(tmp_path_factory.mktemp("paper"), PAPER_TOML.read_text(encoding="utf-8"))


@pytest.fixture(scope="module")
def xarm_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[object, Path]:
    """The xArm7 of example-robot-data (its STL meshes) braced at its forearm on a post, a short circle."""
    from xarm_post import xarm_post_text

    return _run_into(tmp_path_factory.mktemp("xarm"), xarm_post_text())
