"""Tests of Brace.surface_radius (bracekit.contact.brace): validation, the obstacle's radius and the scenario key.

References: the documented fallbacks written out (surface radius, else region radius, else none), and the
clearance of a brace built directly in Python compared with the one the scenario key builds.
"""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest

from bracekit.contact import Brace, Surface
from bracekit.errors import ContactError, InputError
from bracekit.kinematics import BracedRobot
from bracekit.kinematics.clearance import Clearance, link_clearance
from bracekit.simulation.scenario import parse_scenario
from helpers import scenario_text

TABLE = Surface([0.7, -0.15, -0.3], [0.0, 0.0, 1.0])


def test_the_obstacle_radius_is_the_surface_radius_else_the_region_radius_else_none() -> None:
    assert Brace("brace", TABLE, region_radius=0.15, surface_radius=0.6).obstacle_radius == 0.6
    assert Brace("brace", TABLE, surface_radius=0.6).obstacle_radius == 0.6  # a table without a region
    assert Brace("brace", TABLE, region_radius=0.15).obstacle_radius == 0.15
    assert Brace("brace", TABLE, region_radius=0.15, surface_radius=0.15).obstacle_radius == 0.15  # equal: allowed
    assert Brace("brace", TABLE).obstacle_radius is None  # the whole plane


@pytest.mark.parametrize("bad", [-0.5, 0.0, math.nan, math.inf, 1e200, "wide", True])
def test_a_surface_radius_that_is_not_a_positive_length_is_refused(bad: object) -> None:
    with pytest.raises(ContactError, match="surface_radius"):
        Brace("brace", TABLE, surface_radius=bad)  # type: ignore[arg-type]


def test_a_surface_smaller_than_the_bracing_region_is_refused() -> None:
    with pytest.raises(ContactError, match="smaller than the bracing region's radius") as caught:
        Brace("brace", TABLE, region_radius=0.15, surface_radius=0.1)
    assert isinstance(caught.value, InputError)


def _paper(extra: str) -> dict[str, object]:
    """The paper scenario's TOML data with `extra` lines added to its [brace] table."""
    text = scenario_text().replace("region_radius = 0.15", "region_radius = 0.15\n" + extra, 1)
    assert extra in text
    return tomllib.loads(text)


def test_the_scenario_key_gives_the_surface_radius_and_the_clearance_uses_it() -> None:
    sc = parse_scenario(_paper("surface_radius = 0.6"))
    brace = sc.braced.brace
    assert brace.surface_radius == 0.6 and brace.region_radius == 0.15 and brace.obstacle_radius == 0.6
    assert parse_scenario(_paper("")).braced.brace.obstacle_radius == 0.15  # without the key: the region's
    direct = BracedRobot(
        sc.robot,
        Brace(brace.frame, Surface(brace.surface.point, brace.surface.normal), region_radius=0.15, surface_radius=0.6),
    )
    q = sc.guess + np.random.default_rng(0).normal(scale=0.3, size=sc.robot.n)
    assert link_clearance(sc.braced.state(q)) == link_clearance(direct.state(q))
    table = [d.clearance for d in Clearance(sc.braced).links(q, False)]
    assert table == [d.clearance for d in Clearance(direct).links(q, False)]
    # the wider table is a different obstacle from the region's disk: some link is nearer it
    disk = [d.clearance for d in Clearance(parse_scenario(_paper("")).braced).links(q, False)]
    assert all(t <= d + 1e-15 for t, d in zip(table, disk, strict=True)) and table != disk


@pytest.mark.parametrize("value", ["0.1", "-0.6", '"wide"'])
def test_a_bad_scenario_surface_radius_is_refused_naming_it(value: str) -> None:
    with pytest.raises(InputError, match="surface_radius"):
        parse_scenario(_paper(f"surface_radius = {value}"))
