"""Which sweep specs `bracekit place` takes: the axes that place the pad (link, fraction, angle) only."""

from __future__ import annotations

import pytest

from bracekit.errors import InputError
from bracekit.studies.place.engine import check_spec
from bracekit.studies.place.spec import load_place_spec
from bracekit.studies.sweep.spec import parse_spec


def test_fraction_and_angle_axes_are_the_grid_of_its_own_variables() -> None:
    # the shipped Panda spec samples fraction × angle for the grid; place optimises both itself
    spec = load_place_spec("panda-links")
    assert set(spec.axis_names) == {"link", "fraction", "angle"}
    # the Panda's links with a length between their joint and the next (docs/place.md)
    assert check_spec(spec) == ["panda_link2", "panda_link3", "panda_link4", "panda_link6"]


def test_an_axis_of_the_task_is_refused_by_name() -> None:
    spec = parse_spec({"name": "task", "base": "paper", "axes": {"link": ["link4"], "task_radius": [0.05, 0.1]}})
    with pytest.raises(InputError, match="also sweeps task_radius"):
        check_spec(spec)
