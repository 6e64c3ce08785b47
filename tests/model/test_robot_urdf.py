"""Tests of bracekit.model.robot on what a URDF holds: bad files and sources, continuous and mimic joints, bad joints.

A bad file, source, tip, frame or joint (zero axis, inverted or non-finite limits, a locked joint, a mimic joint on
the chain) is a one-line ModelError (or InputError) naming its cause. References are Pinocchio models built
independently from the same URDF (pin.buildModelFromXML on the full tree), and for continuous joints the revolute
version of the same chain.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from test_robot import PUMA, one_line

from bracekit.errors import FrameNotFoundError, InputError, ModelError
from bracekit.model.robot import Robot
from helpers import (
    branched_chain_urdf,
    continuous_chain_urdf,
    mimic_gripper_urdf,
    pin_frame_jacobian,
    pin_frame_placement,
    random_chain_urdf,
)


# ---------------------------------------------------------------------------------------------- errors
def test_missing_urdf_file_is_a_model_error(tmp_path: Path) -> None:
    with pytest.raises(ModelError) as info:
        Robot.from_urdf(tmp_path / "nope.urdf", tip="tip")
    assert "not found" in one_line(info)


def test_malformed_xml_string_is_a_model_error() -> None:
    with pytest.raises(ModelError) as info:
        Robot.from_urdf('<robot name="x"><link name="a"></robot', tip="a")
    one_line(info)


def test_xml_string_that_is_not_urdf_is_a_model_error() -> None:
    with pytest.raises(ModelError) as info:
        Robot.from_urdf("<html><body>hello</body></html>", tip="a")
    one_line(info)


def test_malformed_urdf_file_is_a_model_error(tmp_path: Path) -> None:
    path = tmp_path / "broken.urdf"
    path.write_text('<robot name="x"><link name="a"><joint name="j" type="revolute"><parent')
    with pytest.raises(ModelError) as info:
        Robot.from_urdf(path, tip="a")
    one_line(info)


def test_file_that_is_not_urdf_is_a_model_error(tmp_path: Path) -> None:
    path = tmp_path / "notes.urdf"
    path.write_text("joint1: revolute\njoint2: revolute\n")
    with pytest.raises(ModelError) as info:
        Robot.from_urdf(path, tip="tip")
    assert "not a URDF" in one_line(info)


def test_directory_instead_of_file_is_a_model_error(tmp_path: Path) -> None:
    with pytest.raises(ModelError) as info:
        Robot.from_urdf(tmp_path, tip="tip")
    one_line(info)


def test_unknown_tip_frame_is_a_frame_not_found_error_listing_known_frames() -> None:
    with pytest.raises(FrameNotFoundError) as info:
        Robot.from_urdf(PUMA, tip="gripper")
    msg = one_line(info)
    assert "gripper" in msg and "flange" in msg
    assert not msg.startswith("'")  # not KeyError's quoted repr
    assert isinstance(info.value, KeyError) and isinstance(info.value, InputError)


def test_unknown_frame_name_is_a_frame_not_found_error() -> None:
    robot = Robot.from_urdf(PUMA, tip="flange")
    with pytest.raises(FrameNotFoundError) as info:
        robot.frame_id("elbow")
    assert "elbow" in one_line(info)
    with pytest.raises(FrameNotFoundError):
        robot.frame_joint("elbow")


def test_tip_on_the_base_is_a_model_error() -> None:
    with pytest.raises(ModelError) as info:
        Robot.from_urdf(random_chain_urdf(3, seed=2), tip="base")
    one_line(info)


@pytest.mark.parametrize("seed", [8, 21])
def test_continuous_joints_load_as_plain_angles_with_the_revolute_version_s_kinematics(seed: int) -> None:
    text, revolute = continuous_chain_urdf(5, seed, continuous=(1, 3, 5))
    assert text.count('type="continuous"') == 3
    robot = Robot.from_urdf(text, tip="tip")
    ref = pin.buildModelFromXML(revolute)
    assert robot.n == robot.model.nq == robot.model.nv == 5
    assert np.all(np.isinf(robot.lower[[0, 2, 4]])) and np.all(robot.lower[[0, 2, 4]] < 0)
    assert np.all(np.isposinf(robot.upper[[0, 2, 4]]))
    np.testing.assert_array_equal(robot.lower[[1, 3]], [-3.14, -3.14])
    rng = np.random.default_rng(seed)
    for q in (rng.uniform(-3, 3, 5), rng.uniform(-20, 20, 5)):  # angles beyond ±π too
        np.testing.assert_allclose(
            robot.frame_kinematics(q, [robot.tip_id])[0][1], pin_frame_jacobian(ref, "tip", q), atol=1e-12
        )
        np.testing.assert_allclose(
            pin_frame_placement(robot.model, "tip", q).homogeneous,
            pin_frame_placement(ref, "tip", q).homogeneous,
            atol=1e-12,
        )


def test_a_continuous_joint_keeps_its_urdf_velocity_limit(tmp_path: Path) -> None:
    text = random_chain_urdf(3, seed=8).replace('name="j2" type="revolute"', 'name="j2" type="continuous"')
    path = tmp_path / "chain.urdf"
    path.write_text(text)
    robot = Robot.from_urdf(path, tip="tip")
    assert np.isneginf(robot.lower[1]) and robot.model.velocityLimit[1] == 1.0


def test_a_mimic_joint_on_the_chain_is_refused_naming_it_and_its_leader() -> None:
    with pytest.raises(ModelError) as info:
        Robot.from_urdf(mimic_gripper_urdf(mimic_on_chain=True), tip="tip")
    msg = one_line(info)
    assert "'j3'" in msg and "'j2'" in msg and "mimic" in msg


def test_mimic_gripper_fingers_off_the_chain_are_locked() -> None:
    robot = Robot.from_urdf(mimic_gripper_urdf(), tip="tip")
    assert robot.joint_names == ("j1", "j2", "j3")
    ref = pin.buildModelFromXML(mimic_gripper_urdf())
    q = np.array([0.3, -0.4, 0.7])
    q_ref = np.zeros(ref.nq)
    for name, value in zip(robot.joint_names, q, strict=True):
        q_ref[ref.joints[ref.getJointId(name)].idx_q] = value
    ours = robot.frame_kinematics(q, [robot.tip_id])[0][1]
    full = pin_frame_jacobian(ref, "tip", q_ref)
    cols = [ref.joints[ref.getJointId(name)].idx_v for name in robot.joint_names]
    np.testing.assert_allclose(ours, full[:, cols], atol=1e-12)


def test_continuous_joint_on_a_locked_side_branch_is_accepted() -> None:
    robot = Robot.from_urdf(branched_chain_urdf("continuous"), tip="tip")
    assert robot.joint_names == ("j1", "j2", "j3", "j4")


# ---------------------------------------------------------------------------------------------- joints of the URDF
def _edit_first_joint(text: str, old: str, new: str) -> str:
    assert old in text
    return text.replace(old, new, 1)


def test_a_joint_with_a_zero_axis_is_a_model_error_naming_the_joint() -> None:
    for kind in ("revolute", "prismatic"):
        text = random_chain_urdf(4, seed=1).replace('type="revolute"', f'type="{kind}"', 1)
        for axis in ("0 0 0", "0 0 1e-300"):
            bad = _edit_first_joint(text, '<axis xyz="', f'<axis xyz="{axis}" was="')
            with pytest.raises(ModelError) as info:
                Robot.from_urdf(bad, tip="tip")
            msg = one_line(info)
            assert "'j1'" in msg and "zero axis" in msg


def test_inverted_joint_limits_are_a_model_error_naming_the_joint() -> None:
    bad = _edit_first_joint(random_chain_urdf(4, seed=1), 'lower="-3.14" upper="3.14"', 'lower="1" upper="-1"')
    with pytest.raises(ModelError) as info:
        Robot.from_urdf(bad, tip="tip")
    msg = one_line(info)
    assert "'j1'" in msg and "lower" in msg


def test_a_locked_joint_is_a_model_error_saying_to_make_it_fixed() -> None:
    text = random_chain_urdf(4, seed=1)
    bad = text.replace('lower="-3.14" upper="3.14"', 'lower="0.5" upper="0.5"', 2)
    with pytest.raises(ModelError) as info:
        Robot.from_urdf(bad, tip="tip")
    msg = one_line(info)
    assert "'j1'" in msg and "fixed" in msg
    # a locked joint off the chain to the tip does not matter (it is locked anyway)
    side = branched_chain_urdf().replace(
        '<joint name="a_side_joint" type="revolute"', '<joint name="a_side_joint" type="prismatic"'
    )
    side = side.replace('<limit lower="-3" upper="3"', '<limit lower="0" upper="0"', 3)
    with pytest.raises(ModelError, match="'j1'"):  # j1 (on the chain) is now locked too
        Robot.from_urdf(side, tip="tip")


def test_a_non_finite_joint_origin_or_nan_limit_is_a_model_error() -> None:
    model = pin.buildModelFromXML(random_chain_urdf(4, seed=1))
    placement = model.jointPlacements[2]
    placement.translation = np.array([np.nan, 0.0, 0.1])
    model.jointPlacements[2] = placement
    with pytest.raises(ModelError) as info:
        Robot(model=model, tip="tip", stiffness=np.ones(4))
    assert "'j2'" in one_line(info)
    model = pin.buildModelFromXML(random_chain_urdf(4, seed=1))
    lower = model.lowerPositionLimit.copy()
    lower[3] = np.nan
    model.lowerPositionLimit = lower
    with pytest.raises(ModelError) as info:
        Robot(model=model, tip="tip", stiffness=np.ones(4))
    assert "'j4'" in one_line(info)


class _Fspath:
    def __init__(self, path: Path) -> None:
        self.path = path

    def __fspath__(self) -> str:
        return str(self.path)


def test_from_urdf_accepts_any_os_pathlike() -> None:
    assert Robot.from_urdf(_Fspath(PUMA), tip="flange").n == 6  # type: ignore[arg-type]


@pytest.mark.parametrize("source", [None, 3, 2.5, b"robot.urdf", ["a.urdf"], "", "no\nsuch\nfile.urdf", "x" * 5000])
def test_a_urdf_source_that_is_not_a_path_or_urdf_text_is_a_one_line_model_error(source: object) -> None:
    with pytest.raises(ModelError) as info:
        Robot.from_urdf(source, tip="flange")  # type: ignore[arg-type]
    assert len(one_line(info)) < 400


@pytest.mark.parametrize("tip", [None, 3, ["flange"]])
def test_a_tip_that_is_not_a_name_is_a_model_error(tip: object) -> None:
    with pytest.raises(ModelError) as info:
        Robot.from_urdf(PUMA, tip=tip)  # type: ignore[arg-type]
    one_line(info)


def test_a_robot_needs_a_pinocchio_model_and_frame_names_must_be_strings() -> None:
    with pytest.raises(ModelError):
        Robot(model="model.urdf", tip="flange", stiffness=np.ones(6))  # type: ignore[arg-type]
    robot = Robot.from_urdf(PUMA, tip="flange")
    with pytest.raises(InputError) as info:
        robot.frame_id(3)  # type: ignore[arg-type]
    one_line(info)


@pytest.mark.parametrize("name", [["paper-robot"], None, 3])
def test_load_model_refuses_a_name_that_is_not_a_string(name: object) -> None:
    from bracekit.model.shipped import load_model

    with pytest.raises(ModelError) as info:
        load_model(name)  # type: ignore[arg-type]
    one_line(info)
