from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pinocchio as pin

from bracekit.studies.sweep.candidates import brace_links, candidate_id, expand, link_offset
from bracekit.studies.sweep.spec import load_spec


def test_grid_is_every_combination_in_order_with_stable_ids(tiny_spec: Path) -> None:
    spec = load_spec(tiny_spec)
    cands = expand(spec)
    assert [c.inputs for c in cands] == [
        {"link": "link4", "fraction": 0.3},
        {"link": "link4", "fraction": 0.7},
        {"link": "link8", "fraction": 0.3},
        {"link": "link8", "fraction": 0.7},
    ]
    assert [c.index for c in cands] == [0, 1, 2, 3]
    assert [c.id for c in cands] == [c.id for c in expand(load_spec(tiny_spec))]
    assert len({c.id for c in cands}) == 4
    assert [c.id for c in expand(spec, limit=2)] == [c.id for c in cands[:2]]
    assert cands[0].id == candidate_id({"fraction": 0.3, "link": "link4"})  # key order does not matter


def test_range_grid_is_evenly_spaced() -> None:
    spec = load_spec("paper-links")
    fractions = spec.axis("fraction").grid()
    assert len(fractions) == 25
    np.testing.assert_allclose(fractions, np.linspace(0.02, 0.98, 25), rtol=0, atol=1e-15)
    assert len(expand(spec)) == 8 * 25


def test_random_sampling_is_seeded(tiny_spec: Path) -> None:
    base = load_spec(tiny_spec)
    fraction = dataclasses.replace(base.axis("fraction"), values=None, low=0.1, high=0.9, count=2)
    spec = dataclasses.replace(base, mode="random", samples=20, seed=7, axes=(base.axis("link"), fraction))
    a, b = expand(spec), expand(spec)
    assert [c.inputs for c in a] == [c.inputs for c in b]
    assert all(0.1 <= c.inputs["fraction"] <= 0.9 for c in a)
    assert {c.inputs["link"] for c in a} == {"link4", "link8"}
    other = expand(dataclasses.replace(spec, seed=8))
    assert [c.inputs for c in other] != [c.inputs for c in a]
    rng = np.random.default_rng(7)  # the documented draw order: each axis in spec order
    first = {"link": ["link4", "link8"][int(rng.integers(2))], "fraction": float(rng.uniform(0.1, 0.9))}
    assert a[0].inputs == first


def test_link_offsets_lie_on_the_segment_to_the_next_joint() -> None:
    robot = load_spec("paper-links").base_scenario().robot
    links = brace_links(robot)
    assert links == ("link2", "link3", "link4", "link6", "link7", "link8", "link9", "link10")
    model = robot.model
    data = model.createData()
    q = np.linspace(-0.5, 0.5, robot.n)
    pin.framesForwardKinematics(model, data, q)
    for link in links:
        frame = model.frames[robot.frame_id(link)]
        j = int(frame.parentJoint)
        for f in (0.0, 0.3, 1.0):
            world = data.oMf[robot.frame_id(link)].act(link_offset(robot, link, f))
            expected = (1 - f) * data.oMi[j].translation + f * data.oMi[j + 1].translation
            np.testing.assert_allclose(world, expected, atol=1e-12)
