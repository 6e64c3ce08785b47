"""Tests of bracekit.model.robot: loading a serial chain from URDF, its tip, stiffnesses, joint values, point frames.

References are Pinocchio models built independently from the same URDF (pin.buildModelFromXML /
buildModelFromUrdf on the full tree, no reduction). What a URDF may hold and how a bad one is refused:
test_robot_urdf.py.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from bracekit.errors import FrameNotFoundError, InputError
from bracekit.model.robot import Robot
from bracekit.model.shipped import model_path
from helpers import (
    branched_chain_urdf,
    pin_frame_placement,
    random_chain_urdf,
)

PUMA = model_path("puma560")
PAPER = model_path("paper-robot")


def one_line(exc: pytest.ExceptionInfo[BaseException]) -> str:
    """The exception's message, checked to be a single non-empty line."""
    msg = str(exc.value)
    assert msg and "\n" not in msg, repr(msg)
    return msg


# ---------------------------------------------------------------------------------------------- loading
def test_from_urdf_path_matches_pinocchio_forward_kinematics_of_the_puma() -> None:
    robot = Robot.from_urdf(PUMA, tip="flange")
    ref = pin.buildModelFromUrdf(str(PUMA))
    assert robot.n == 6 == ref.nv
    assert robot.joint_names == tuple(f"joint{i}" for i in range(1, 7))
    q = np.array([0.3, -0.2, 0.5, 1.0, -0.7, 0.4])
    np.testing.assert_allclose(
        pin_frame_placement(robot.model, "flange", q).homogeneous,
        pin_frame_placement(ref, "flange", q).homogeneous,
        atol=1e-14,
    )


def test_from_urdf_accepts_a_path_given_as_a_string() -> None:
    robot = Robot.from_urdf(str(PAPER), tip="tool")
    assert robot.n == 11
    assert robot.tip == "tool"


def test_from_urdf_string_equals_from_urdf_file(tmp_path: Path) -> None:
    text = random_chain_urdf(7, seed=11, brace_link=3)
    path = tmp_path / "chain.urdf"
    path.write_text(text)
    from_text = Robot.from_urdf(text, tip="tip")
    from_file = Robot.from_urdf(path, tip="tip")
    ref = pin.buildModelFromXML(text)
    q = np.linspace(-1.0, 1.2, 7)
    for robot in (from_text, from_file):
        assert robot.n == 7
        for frame in ("tip", "brace", "l4"):
            np.testing.assert_allclose(
                pin_frame_placement(robot.model, frame, q).homogeneous,
                pin_frame_placement(ref, frame, q).homogeneous,
                atol=1e-14,
            )


def test_from_urdf_string_with_leading_whitespace_is_parsed_as_xml() -> None:
    robot = Robot.from_urdf("\n   " + random_chain_urdf(3, seed=1), tip="tip")
    assert robot.n == 3


def test_tip_frame_id_points_at_the_tip_frame() -> None:
    robot = Robot.from_urdf(PAPER, tip="tool")
    assert robot.model.frames[robot.tip_id].name == "tool"
    assert robot.frame_joint("tool") == robot.n - 1
    assert robot.frame_joint("base_link") == -1
    assert robot.frame_joint("brace") == 5  # on link6: chain 1 = joints 1..6


def test_tip_may_be_an_intermediate_link_then_later_joints_are_dropped() -> None:
    text = random_chain_urdf(6, seed=5)
    robot = Robot.from_urdf(text, tip="l4")
    assert robot.joint_names == ("j1", "j2", "j3", "j4")
    ref = pin.buildModelFromXML(text)
    q = np.array([0.1, 0.2, -0.3, 0.4])
    np.testing.assert_allclose(
        pin_frame_placement(robot.model, "l4", q).homogeneous,
        pin_frame_placement(ref, "l4", np.concatenate([q, [0.7, -0.8]])).homogeneous,
        atol=1e-14,
    )
    assert "l5" in robot.off_chain and "tip" in robot.off_chain


def test_side_branch_is_locked_at_neutral_and_its_frames_are_off_chain() -> None:
    text = branched_chain_urdf()
    robot = Robot.from_urdf(text, tip="tip")
    full = pin.buildModelFromXML(text)
    assert list(full.names)[1:] == ["j1", "j2", "a_side_joint", "j3", "j4"]  # the side joint sits inside
    assert robot.joint_names == ("j1", "j2", "j3", "j4")
    q = np.array([0.4, -0.3, 0.9, -1.1])
    q_full = np.array([0.4, -0.3, 0.0, 0.9, -1.1])  # side joint at its neutral value
    np.testing.assert_allclose(
        pin_frame_placement(robot.model, "tip", q).homogeneous,
        pin_frame_placement(full, "tip", q_full).homogeneous,
        atol=1e-14,
    )
    assert {"side", "side_tool", "a_side_joint"} <= robot.off_chain
    assert not ({"base", "l1", "l2", "l3", "l4", "tip", "j3"} & robot.off_chain)


def test_unbranched_model_has_no_off_chain_frames() -> None:
    assert Robot.from_urdf(PAPER, tip="tool").off_chain == frozenset()


# ---------------------------------------------------------------------------------------------- stiffness
def test_scalar_stiffness_is_broadcast_to_every_joint() -> None:
    robot = Robot.from_urdf(PUMA, tip="flange", stiffness=250.0)
    np.testing.assert_array_equal(robot.stiffness, np.full(6, 250.0))
    assert Robot.from_urdf(PUMA, tip="flange").stiffness.tolist() == [170.0] * 6  # the paper's default


def test_stiffness_list_is_kept_per_joint_in_chain_order() -> None:
    k = [100.0, 200.0, 300.0, 400.0, 500.0, 600.0]
    robot = Robot.from_urdf(PUMA, tip="flange", stiffness=k)
    np.testing.assert_array_equal(robot.stiffness, k)
    other = robot.with_stiffness(np.arange(1.0, 7.0))
    np.testing.assert_array_equal(other.stiffness, np.arange(1.0, 7.0))
    np.testing.assert_array_equal(robot.stiffness, k)  # the original is unchanged


@pytest.mark.parametrize("k", [[170.0] * 5, [170.0] * 7, []], ids=["too-few", "too-many", "empty"])
def test_wrong_number_of_stiffnesses_is_an_input_error(k: list[float]) -> None:
    with pytest.raises(InputError) as info:
        Robot.from_urdf(PUMA, tip="flange", stiffness=k)
    assert "6" in one_line(info)


@pytest.mark.parametrize("bad", [0.0, -170.0, np.nan, np.inf], ids=["zero", "negative", "nan", "inf"])
def test_non_positive_or_non_finite_stiffness_is_an_input_error(bad: float) -> None:
    with pytest.raises(InputError) as info:
        Robot.from_urdf(PUMA, tip="flange", stiffness=[170.0, 170.0, bad, 170.0, 170.0, 170.0])
    assert "joint3" in one_line(info)
    with pytest.raises(InputError):
        Robot.from_urdf(PUMA, tip="flange", stiffness=bad)
    with pytest.raises(InputError):
        Robot.from_urdf(PUMA, tip="flange").with_stiffness(bad)


@pytest.mark.parametrize("bad", ["stiff", ["a", "b", "c", "d", "e", "f"]], ids=["string", "text-list"])
def test_non_numeric_stiffness_is_an_input_error(bad: object) -> None:
    # errors.py: "Every error a user can cause derives from InputError" (check_q does this for q).
    with pytest.raises(InputError) as info:
        Robot.from_urdf(PUMA, tip="flange", stiffness=bad)  # type: ignore[arg-type]
    one_line(info)


# ---------------------------------------------------------------------------------------------- joint values
@pytest.mark.parametrize("q", [[0.1] * 5, [0.1] * 7, []], ids=["too-few", "too-many", "empty"])
def test_wrong_number_of_joint_values_is_an_input_error(q: list[float]) -> None:
    robot = Robot.from_urdf(PUMA, tip="flange")
    with pytest.raises(InputError) as info:
        robot.check_q(q)
    assert "6" in one_line(info)


@pytest.mark.parametrize(
    "q",
    [
        [0.0, np.nan, 0.0, 0.0, 0.0, 0.0],
        [0.0, 0.0, np.inf, 0.0, 0.0, 0.0],
        ["a", "b", "c", "d", "e", "f"],
        [0.0, 0.0, "x", 0.0, 0.0, 0.0],
        "zero",
        None,
    ],
    ids=["nan", "inf", "text", "one-text", "string", "none"],
)
def test_non_finite_or_non_numeric_joint_values_are_input_errors(q: object) -> None:
    robot = Robot.from_urdf(PUMA, tip="flange")
    with pytest.raises(InputError) as info:
        robot.check_q(q)  # type: ignore[arg-type]
    one_line(info)


def test_check_q_returns_floats_in_chain_order() -> None:
    robot = Robot.from_urdf(PUMA, tip="flange")
    out = robot.check_q([0, 1, 2, 3, 4, 5])
    assert out.dtype == np.float64
    np.testing.assert_array_equal(out, [0.0, 1.0, 2.0, 3.0, 4.0, 5.0])
    np.testing.assert_array_equal(robot.neutral(), np.zeros(6))


# ---------------------------------------------------------------------------------------------- point frames
@pytest.mark.parametrize("link", ["l2", "l5", "l7"])
def test_with_point_frame_places_the_frame_at_link_pose_times_offset(link: str) -> None:
    text = random_chain_urdf(7, seed=21)
    robot = Robot.from_urdf(text, tip="tip")
    offset = np.array([0.03, -0.02, 0.07])
    rot = np.asarray(pin.rpy.rpyToMatrix(0.4, -0.3, 1.2))
    braced = robot.with_point_frame("pad", link, offset, rot)
    ref = pin.buildModelFromXML(text)
    rng = np.random.default_rng(0)
    for _ in range(3):
        q = rng.uniform(-2.0, 2.0, 7)
        expected = pin_frame_placement(ref, link, q) * pin.SE3(rot, offset)
        got = pin_frame_placement(braced.model, "pad", q)
        np.testing.assert_allclose(got.homogeneous, expected.homogeneous, atol=1e-13)
    assert braced.frame_joint("pad") == int(link[1:]) - 1
    assert not robot.model.existFrame("pad")  # the original robot is unchanged
    np.testing.assert_array_equal(braced.stiffness, robot.stiffness)


def test_with_point_frame_defaults_to_identity_rotation_and_zero_offset() -> None:
    robot = Robot.from_urdf(PAPER, tip="tool")
    braced = robot.with_point_frame("pad", "link3")
    ref = pin.buildModelFromUrdf(str(PAPER))
    q = np.linspace(-0.5, 0.5, 11)
    np.testing.assert_allclose(
        pin_frame_placement(braced.model, "pad", q).homogeneous,
        pin_frame_placement(ref, "link3", q).homogeneous,
        atol=1e-14,
    )


def test_with_point_frame_rejects_bad_arguments() -> None:
    robot = Robot.from_urdf(branched_chain_urdf(), tip="tip")
    with pytest.raises(InputError) as info:
        robot.with_point_frame("tip", "l2")  # existing name
    one_line(info)
    with pytest.raises(FrameNotFoundError):
        robot.with_point_frame("pad", "no_such_link")
    with pytest.raises(InputError) as info:
        robot.with_point_frame("pad", "side")  # on the locked side branch
    assert "not on the chain" in one_line(info)
    with pytest.raises(InputError):
        robot.with_point_frame("pad", "l2", offset=[0.1, 0.2])
    with pytest.raises(InputError):
        robot.with_point_frame("pad", "l2", offset=[0.1, np.nan, 0.0])
    with pytest.raises(InputError):
        robot.with_point_frame("pad", "l2", rotation=2.0 * np.eye(3))
    with pytest.raises(InputError):
        robot.with_point_frame("pad", "l2", rotation=np.diag([1.0, 1.0, -1.0]))  # a reflection


def test_with_point_frame_refuses_wrong_shapes_and_types_with_input_errors() -> None:
    robot = Robot.from_urdf(branched_chain_urdf(), tip="tip")
    for kwargs in (
        {"rotation": np.eye(2)},
        {"rotation": np.full((3, 3), np.nan)},
        {"rotation": np.full((3, 3), 1e200)},
        {"rotation": "identity"},
        {"offset": "0 0 0"},
        {"offset": None},
    ):
        with pytest.raises(InputError) as info:
            robot.with_point_frame("pad", "l2", **kwargs)
        one_line(info)
    for name, link in ((None, "l2"), (3, "l2"), ("", "l2"), ("pad", 3), ("pad", None)):
        with pytest.raises(InputError) as info:
            robot.with_point_frame(name, link)  # type: ignore[arg-type]
        one_line(info)


def test_with_point_frames_adds_several_frames_as_with_point_frame_does() -> None:
    robot = Robot.from_urdf(branched_chain_urdf(), tip="tip")
    rot = pin.utils.rpyToMatrix(0.1, -0.2, 0.3)
    many = robot.with_point_frames([("a", "l2", (0.1, 0.0, 0.2), None), ("b", "l4", (0.0, 0.3, 0.0), rot)])
    one_a = robot.with_point_frame("a", "l2", (0.1, 0.0, 0.2))
    one_b = robot.with_point_frame("b", "l4", (0.0, 0.3, 0.0), rot)
    q = np.random.default_rng(3).uniform(-1, 1, robot.n)
    for name, one in (("a", one_a), ("b", one_b)):
        np.testing.assert_array_equal(
            pin_frame_placement(many.model, name, q).homogeneous, pin_frame_placement(one.model, name, q).homogeneous
        )
    with pytest.raises(InputError, match="already exists"):
        robot.with_point_frames([("a", "l2", (0, 0, 0), None), ("a", "l3", (0, 0, 0), None)])
    with pytest.raises(InputError):
        robot.with_point_frames("a")  # type: ignore[arg-type]
