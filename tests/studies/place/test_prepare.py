"""What the command computes before its workers fork: the reference start, the spans and the task context.

Reference: the sweep's own functions called directly (the reference start of the context scenario, the task
context a worker computes otherwise).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from bracekit.studies.place.engine import PlaceSettings, prepare
from bracekit.studies.sweep.context import context_scenario, reference_start, task_context


def test_prepare_with_and_without_the_context(setup: dict[str, Any]) -> None:
    spec, settings = setup["spec"], PlaceSettings()
    plain = prepare(spec, settings)
    full = prepare(spec, settings, context=True)
    assert plain.context is None and full.context is not None
    q_ref = reference_start(context_scenario(spec, {}))
    assert np.array_equal(plain.q_ref, q_ref) and np.allclose(full.q_ref, q_ref, atol=1e-12)
    assert plain.links == full.links and plain.spans == full.spans
    ref = task_context(spec, {}, "{}")
    assert ref.q_ref is not None and full.context.q_ref is not None
    assert np.array_equal(full.context.q_ref, ref.q_ref) and np.array_equal(full.context.Q, ref.Q)
    assert full.context.free["Ci_mean"] == ref.free["Ci_mean"]
