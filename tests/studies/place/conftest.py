"""Shared fixtures of the placement tests: the paper-links spec, its reference start and a template scenario."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest


@pytest.fixture(scope="module")
def setup() -> dict[str, Any]:
    from bracekit.studies.place.scenario import Place, place_scenario
    from bracekit.studies.place.surface import link_surface
    from bracekit.studies.sweep.context import context_scenario, reference_start
    from bracekit.studies.sweep.spec import load_spec

    spec = load_spec("paper-links")
    sc0 = context_scenario(spec, {})
    q = reference_start(sc0)
    surface = link_surface(sc0.robot, "link4")
    template = Place("link4", 0.3, np.pi)
    sc = place_scenario(spec, surface, template, q)
    return {"spec": spec, "q": q, "surface": surface, "template": template, "scenario": sc}
