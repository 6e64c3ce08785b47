"""The load cases of the deflection checks: scaled wrenches against the directions scaled by hand."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from bracekit.errors import InputError
from bracekit.validate.inputs import DEFAULT_DIRECTIONS, _tip_loads


def test_tip_loads_scale_each_part() -> None:
    loads = _tip_loads(0.5, 0.05, DEFAULT_DIRECTIONS)
    assert [lab for lab, _ in loads.labelled] == [lab for lab, _ in DEFAULT_DIRECTIONS]
    for (_, d), (_, raw) in zip(loads.labelled, DEFAULT_DIRECTIONS, strict=True):
        w = d * loads.scale
        raw = np.asarray(raw)
        assert np.allclose(w[:3], 0.5 * raw[:3], atol=1e-15) and np.allclose(w[3:], 0.05 * raw[3:], atol=1e-15)
    assert loads.directions_json()[0] == {"label": "force +x", "direction": [1.0, 0.0, 0.0, 0.0, 0.0, 0.0]}


@pytest.mark.parametrize(
    ("force", "moment", "directions"),
    [(0.0, 0.05, DEFAULT_DIRECTIONS), (0.5, -1.0, DEFAULT_DIRECTIONS), (0.5, 0.05, [])],
)
def test_tip_loads_refuse_bad_input(force: float, moment: float, directions: Any) -> None:
    with pytest.raises(InputError):
        _tip_loads(force, moment, directions)
