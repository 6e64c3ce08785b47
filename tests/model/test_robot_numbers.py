"""The numbers of a URDF checked at load (model/urdf_numbers.py): one ModelError naming the link or joint and value.

The reference for why: Pinocchio itself reads a mass "nan" as 0 kg and accepts an origin of 1e300 m (checked
below), so without these checks a wrong model would run silently or fail far from its cause.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pinocchio as pin
import pytest

from bracekit.errors import InputError, ModelError
from bracekit.model.robot import Robot
from bracekit.model.shipped import MODELS, load_model
from helpers import random_chain_urdf

COLLISION = '<collision><geometry><cylinder radius="0.05" length="0.2"/></geometry></collision>'


def _chain(**changes: str) -> str:
    """The 5-joint test chain with link l3's mass, joint j2's origin or l3's collision radius replaced."""
    text = random_chain_urdf(5, seed=1)
    text = text.replace('<link name="l3"><inertial>', f'<link name="l3">{COLLISION}<inertial>')
    if "mass" in changes:
        text = text.replace('<link name="l3">', '<link name="l3" x="">', 1)
        head, tail = text.split('<link name="l3" x="">', 1)
        tail = tail.replace('<mass value="0.5"/>', f'<mass value="{changes["mass"]}"/>', 1)
        text = head + '<link name="l3">' + tail
    if "origin" in changes:
        text = re.sub(
            r'(<joint name="j2"[^>]*>.*?<origin xyz=")[^"]*',
            rf"\g<1>{changes['origin']} 0 0",
            text,
            count=1,
            flags=re.S,
        )
    if "radius" in changes:
        text = text.replace('radius="0.05"', f'radius="{changes["radius"]}"')
    return text


def test_the_test_chain_loads_and_pinocchio_alone_accepts_the_bad_numbers() -> None:
    robot = Robot.from_urdf(_chain(), tip="tip")
    assert robot.n == 5 and len(robot.collisions) == 1
    nan_mass = pin.buildModelFromXML(_chain(mass="nan"))
    assert float(nan_mass.inertias[3].mass) == 0.0  # read as 0 kg: silently wrong statics
    far = pin.buildModelFromXML(_chain(origin="1e300"))
    assert float(far.jointPlacements[2].translation[0]) == 1e300


@pytest.mark.parametrize("value", ["-5", "1e300", "nan", "inf", "-inf"])
def test_a_bad_mass_is_refused_naming_the_link(value: str) -> None:
    with pytest.raises(ModelError, match=r"link 'l3'.*mass") as info:
        Robot.from_urdf(_chain(mass=value), tip="tip")
    text = str(info.value)
    assert "\n" not in text and ("finite" in text or value.lstrip("-") in text.replace("+", ""))


@pytest.mark.parametrize("value", ["1e300", "-2e3", "nan", "inf"])
def test_a_far_or_non_finite_origin_is_refused_naming_the_joint(value: str) -> None:
    with pytest.raises(ModelError, match=r"joint 'j2'") as info:
        Robot.from_urdf(_chain(origin=value), tip="tip")
    assert "memory layout" not in str(info.value) and "Pinocchio" not in str(info.value)


@pytest.mark.parametrize("value", ["nan", "-0.1", "1e308", "inf"])
def test_a_bad_collision_radius_is_refused(value: str) -> None:
    with pytest.raises(ModelError, match=r"link 'l3'.*(collision|radius)"):
        Robot.from_urdf(_chain(radius=value), tip="tip")


def test_a_far_link_point_is_refused() -> None:
    robot = Robot.from_urdf(_chain(), tip="tip")
    with pytest.raises(InputError, match=r"offset of frame 'p'.*beyond"):
        robot.with_point_frame("p", "l3", [1e300, 0.0, 0.0])
    assert robot.with_point_frame("p", "l3", [0.1, 0.0, 0.0]).frame_id("p") >= 0


@pytest.mark.parametrize("name", list(MODELS))
def test_the_shipped_models_pass_and_their_masses_are_pinocchios(name: str) -> None:
    robot = load_model(name)
    masses = [float(robot.model.inertias[j].mass) for j in range(1, robot.model.njoints)]
    assert all(math.isfinite(m) and m >= 0 for m in masses) and sum(masses) > 0


def test_joint_values_outside_the_limits_are_named() -> None:
    robot = Robot.from_urdf(_chain(), tip="tip")
    inside = np.zeros(5)
    assert robot.outside_limits(inside) is None
    outside = inside.copy()
    outside[3] = 10.0
    assert robot.outside_limits(outside) == "joint 4 (j4) = 10 is outside its limits [-3.14, 3.14]"


def test_a_deeply_nested_urdf_is_refused_before_the_urdf_parser(tmp_path) -> None:
    text = random_chain_urdf(3, seed=1).replace("</robot>", "<a>" * 100_000 + "</a>" * 100_000 + "</robot>")
    for source in (text, tmp_path / "deep.urdf"):
        if not isinstance(source, str):
            source.write_text(text)
        with pytest.raises(ModelError, match="deeper than 64 levels"):
            Robot.from_urdf(source, tip="tip")
