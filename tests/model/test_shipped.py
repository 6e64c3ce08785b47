"""Tests of the shipped URDF models (PUMA 560 and the paper's 11-joint robot).

These use pinocchio directly, not bracekit's own kinematics modules.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

REPO = Path(__file__).resolve().parents[2]
MODELS = REPO / "src/bracekit/model/urdf"
GENERATOR = REPO / "tools" / "build_models.py"
PUMA_URDF = MODELS / "puma560.urdf"
PAPER_URDF = MODELS / "paper_robot.urdf"

QN = np.array([0.0, np.pi / 4, np.pi, 0.0, np.pi / 4, 0.0])
# Corke's Robotics Toolbox, p560.fkine(qn) and p560.fkine(qz), no base offset.
FLANGE_AT_QN = np.array([0.5963, -0.1501, -0.0144])
FLANGE_AT_QZ = np.array([0.4521, -0.1500, 0.4318])
PUMA_LIMITS_DEG = [
    (-160, 160),
    (-45, 225),
    (-225, 45),
    (-110, 170),
    (-100, 100),
    (-266, 266),
]
# "Wrist down, arm forward" example pose: pad on a table, HEBI arm above it.
WRIST_DOWN_Q = np.array([0.0, 0.1924, -2.594, 0.0, -0.74, -3.1416, 0.2, -3.0734, 1.9224, 0.2834, 0.3])
N_RANDOM = 25


@pytest.fixture(scope="module")
def puma() -> pin.Model:
    """PUMA 560 model."""
    return pin.buildModelFromUrdf(str(PUMA_URDF))


@pytest.fixture(scope="module")
def paper() -> pin.Model:
    """Paper robot model (PUMA 560 + five HEBI X8-16)."""
    return pin.buildModelFromUrdf(str(PAPER_URDF))


def random_configurations(model: pin.Model, count: int, seed: int) -> list[np.ndarray]:
    """Draw configurations uniformly inside the joint limits."""
    rng = np.random.default_rng(seed)
    lower, upper = model.lowerPositionLimit, model.upperPositionLimit
    return [rng.uniform(lower, upper) for _ in range(count)]


def puma_jacobian_determinant(q: np.ndarray) -> float:
    """Closed-form det of the PUMA 560 geometric Jacobian (any point on axis 6).

    Zero exactly at the elbow (d4 c3 + a3 s3 = 0), shoulder (wrist centre on
    the plane through joint 1's axis, a2 c2 + a3 c23 - d4 s23 = 0) and wrist
    (s5 = 0) singularities.
    """
    a2, a3, d4 = 0.4318, 0.0203, 0.4318
    c2, c3, s3, s5 = np.cos(q[1]), np.cos(q[2]), np.sin(q[2]), np.sin(q[4])
    c23, s23 = np.cos(q[1] + q[2]), np.sin(q[1] + q[2])
    elbow = d4 * c3 + a3 * s3
    shoulder = a2 * c2 + a3 * c23 - d4 * s23
    return float(a2 * elbow * shoulder * s5)


def generic_configurations(model: pin.Model, count: int, seed: int) -> list[np.ndarray]:
    """Random configurations kept away from the PUMA's singular sets."""
    kept = []
    for q in random_configurations(model, 20 * count, seed):
        if abs(puma_jacobian_determinant(q)) > 2e-3:
            kept.append(q)
        if len(kept) == count:
            return kept
    raise AssertionError("too few generic samples")


def frame_placement(model: pin.Model, q: np.ndarray, name: str) -> pin.SE3:
    """World placement of a frame at configuration q."""
    data = pin.Data(model)
    pin.framesForwardKinematics(model, data, q)
    return data.oMf[model.getFrameId(name)].copy()


def frame_jacobian(model: pin.Model, q: np.ndarray, name: str) -> np.ndarray:
    """Geometric Jacobian of a frame (LOCAL_WORLD_ALIGNED, 6 x nv)."""
    data = pin.Data(model)
    return pin.computeFrameJacobian(model, data, q, model.getFrameId(name), pin.LOCAL_WORLD_ALIGNED)


def smallest_singular_value(matrix: np.ndarray) -> float:
    """Smallest singular value."""
    return float(np.linalg.svd(matrix, compute_uv=False).min())


@pytest.mark.parametrize(("path", "nq"), [(PUMA_URDF, 6), (PAPER_URDF, 11)], ids=["puma560", "paper_robot"])
def test_models_parse_with_only_revolute_joints(path: Path, nq: int) -> None:
    """Both files parse with nq == nv and revolute (not continuous) joints."""
    model = pin.buildModelFromUrdf(str(path))
    assert model.nq == nq
    assert model.nv == nq
    names = [model.names[j] for j in range(1, model.njoints)]
    assert names == [f"joint{k}" for k in range(1, nq + 1)]
    for j in range(1, model.njoints):
        assert model.joints[j].shortname() == "JointModelRZ"  # revolute, not continuous
    assert np.all(np.isfinite(model.lowerPositionLimit))
    assert np.all(np.isfinite(model.upperPositionLimit))


@pytest.mark.parametrize("path", [PUMA_URDF, PAPER_URDF], ids=["puma560", "paper_robot"])
def test_puma_joint_limits_match_corke(path: Path) -> None:
    """Joints 1-6 carry Corke's PUMA 560 limits."""
    model = pin.buildModelFromUrdf(str(path))
    limits = np.radians(np.array(PUMA_LIMITS_DEG, dtype=float))
    np.testing.assert_allclose(model.lowerPositionLimit[:6], limits[:, 0], atol=1e-12)
    np.testing.assert_allclose(model.upperPositionLimit[:6], limits[:, 1], atol=1e-12)


def test_hebi_joint_limits_are_plus_minus_two_pi(paper: pin.Model) -> None:
    """HEBI joints 7-11 (multi-turn modules) are limited to +-2 pi."""
    np.testing.assert_allclose(paper.lowerPositionLimit[6:], -2 * np.pi, atol=1e-12)
    np.testing.assert_allclose(paper.upperPositionLimit[6:], 2 * np.pi, atol=1e-12)


def test_puma_flange_at_qn_matches_corke_fkine(puma: pin.Model) -> None:
    """Flange at qn equals Corke's published fkine(qn)."""
    position = frame_placement(puma, QN, "flange").translation
    np.testing.assert_allclose(position, FLANGE_AT_QN, rtol=0, atol=1e-4)


def test_puma_flange_at_qz_matches_corke_fkine(puma: pin.Model) -> None:
    """Flange at qz equals Corke's published fkine(qz)."""
    placement = frame_placement(puma, np.zeros(6), "flange")
    np.testing.assert_allclose(placement.translation, FLANGE_AT_QZ, rtol=0, atol=1e-4)
    np.testing.assert_allclose(placement.rotation, np.eye(3), atol=1e-12)


def test_puma_flange_matches_standard_dh_product_at_random_q(puma: pin.Model) -> None:
    """Flange pose equals the product of standard DH matrices."""
    a = [0.0, 0.4318, 0.0203, 0.0, 0.0, 0.0]
    d = [0.0, 0.0, 0.15005, 0.4318, 0.0, 0.0]
    alpha = [np.pi / 2, 0.0, -np.pi / 2, np.pi / 2, -np.pi / 2, 0.0]
    for q in random_configurations(puma, N_RANDOM, seed=1):
        expected = np.eye(4)
        for i in range(6):
            ct, st = np.cos(q[i]), np.sin(q[i])
            ca, sa = np.cos(alpha[i]), np.sin(alpha[i])
            expected = expected @ np.array(
                [
                    [ct, -st * ca, st * sa, a[i] * ct],
                    [st, ct * ca, -ct * sa, a[i] * st],
                    [0.0, sa, ca, d[i]],
                    [0.0, 0.0, 0.0, 1.0],
                ]
            )
        np.testing.assert_allclose(frame_placement(puma, q, "flange").homogeneous, expected, atol=1e-12)


def test_paper_robot_first_six_joints_reproduce_puma(puma: pin.Model, paper: pin.Model) -> None:
    """Joints 1-6 of the paper robot are exactly the PUMA 560."""
    for q in random_configurations(paper, N_RANDOM, seed=2):
        on_paper = frame_placement(paper, q, "flange")
        on_puma = frame_placement(puma, q[:6], "flange")
        np.testing.assert_allclose(on_paper.translation, on_puma.translation, atol=1e-12)
        np.testing.assert_allclose(on_paper.rotation, on_puma.rotation, atol=1e-12)


def test_paper_robot_tool_jacobian_has_full_rank_6(paper: pin.Model) -> None:
    """The 6 x 11 tool Jacobian has full rank."""
    for q in random_configurations(paper, N_RANDOM, seed=3):
        jac = frame_jacobian(paper, q, "tool")
        assert jac.shape == (6, 11)
        assert np.linalg.matrix_rank(jac) == 6
        assert smallest_singular_value(jac) > 1e-3


def test_brace_jacobian_of_chain1_has_the_puma_determinant(paper: pin.Model) -> None:
    """The 6 x 6 brace Jacobian has the closed-form PUMA determinant."""
    for q in random_configurations(paper, N_RANDOM, seed=4):
        jac1 = frame_jacobian(paper, q, "brace")[:, :6]
        det = np.linalg.det(jac1)
        assert det == pytest.approx(puma_jacobian_determinant(q), rel=1e-9, abs=1e-12)


def test_brace_jacobian_of_chain1_is_invertible_at_generic_q(paper: pin.Model) -> None:
    """The 6 x 6 brace Jacobian (chain 1) is invertible off singularities."""
    for q in generic_configurations(paper, N_RANDOM, seed=4):
        jac1 = frame_jacobian(paper, q, "brace")[:, :6]
        assert np.linalg.matrix_rank(jac1) == 6
        assert smallest_singular_value(jac1) > 1e-3
        assert np.all(frame_jacobian(paper, q, "brace")[:, 6:] == 0.0)


def test_tool_jacobian_of_chain2_has_rank_5_at_generic_q(paper: pin.Model) -> None:
    """The HEBI chain (joints 7-11) alone gives a rank-5 Jacobian."""
    for q in random_configurations(paper, N_RANDOM, seed=5):
        jac2 = frame_jacobian(paper, q, "tool")[:, 6:]
        assert np.linalg.matrix_rank(jac2) == 5
        assert smallest_singular_value(jac2) > 1e-3


def test_joint7_axis_is_perpendicular_not_coaxial_to_joint6(paper: pin.Model) -> None:
    """The adapter mounts joint 7 perpendicular to joint 6."""
    j6, j7 = paper.getJointId("joint6"), paper.getJointId("joint7")
    for q in random_configurations(paper, N_RANDOM, seed=6):
        data = pin.Data(paper)
        pin.forwardKinematics(paper, data, q)
        axis6 = data.oMi[j6].rotation[:, 2]
        axis7 = data.oMi[j7].rotation[:, 2]
        assert np.linalg.norm(np.cross(axis6, axis7)) > 0.99  # far from parallel
        assert abs(axis6 @ axis7) < 1e-12  # by design exactly perpendicular


def test_brace_z_axis_is_minus_flange_z_axis(paper: pin.Model) -> None:
    """z_b points back into the robot: z_b = -z_flange."""
    for q in random_configurations(paper, N_RANDOM, seed=7):
        brace = frame_placement(paper, q, "brace")
        flange = frame_placement(paper, q, "flange")
        np.testing.assert_allclose(brace.rotation[:, 2], -flange.rotation[:, 2], atol=1e-12)


def test_brace_is_on_joint6_axis_beyond_the_flange(paper: pin.Model) -> None:
    """The pad tip lies on the joint-6 axis, 0.03-0.05 m past the flange."""
    for q in random_configurations(paper, N_RANDOM, seed=8):
        brace = frame_placement(paper, q, "brace")
        flange = frame_placement(paper, q, "flange")
        offset = flange.rotation.T @ (brace.translation - flange.translation)
        np.testing.assert_allclose(offset[:2], 0.0, atol=1e-12)
        assert 0.03 - 1e-12 <= offset[2] <= 0.05 + 1e-12


def test_brace_frame_moves_with_link6_only(paper: pin.Model) -> None:
    """The brace frame hangs on joint 6 (chain split 6 + 5), tool on joint 11."""
    assert paper.frames[paper.getFrameId("brace")].parentJoint == paper.getJointId("joint6")
    assert paper.frames[paper.getFrameId("tool")].parentJoint == paper.getJointId("joint11")


def test_wrist_down_example_pose_braces_pad_on_a_table(paper: pin.Model) -> None:
    """The documented wrist-down pose rests the pad on a table below the arm."""
    q = WRIST_DOWN_Q
    assert np.all(q >= paper.lowerPositionLimit)
    assert np.all(q <= paper.upperPositionLimit)
    assert abs(q[4]) > 0.5  # PUMA wrist well away from its theta5 = 0 singularity
    brace = frame_placement(paper, q, "brace")
    tool = frame_placement(paper, q, "tool")
    flange = frame_placement(paper, q, "flange")
    assert brace.rotation[2, 2] > 1 - 1e-6  # z_b points up: the table normal
    assert brace.translation[2] < flange.translation[2]  # pad below the flange
    horizontal = np.linalg.norm(tool.translation[:2] - brace.translation[:2])
    assert 0.3 <= horizontal <= 0.6
    assert tool.translation[2] > brace.translation[2]  # tool above the table
    for name in ("adapter", "link7", "module2", "module3", "module4", "module5"):
        height = frame_placement(paper, q, name).translation[2] - brace.translation[2]
        assert height > 0.05, name  # module frames stay above the table


def test_regenerated_urdfs_equal_committed_files(tmp_path: Path) -> None:
    """Running the generator reproduces the committed URDF files exactly."""
    subprocess.run(
        [sys.executable, str(GENERATOR), "--out", str(tmp_path), "--quiet"],
        check=True,
        capture_output=True,
    )
    for name in ("puma560.urdf", "paper_robot.urdf"):
        regenerated = (tmp_path / name).read_text(encoding="utf-8")
        committed = (MODELS / name).read_text(encoding="utf-8")
        assert regenerated == committed, f"{name} is stale: run tools/build_models.py"


def test_load_model_parses_once_and_matches_a_fresh_parse_of_the_urdf() -> None:
    """The per-process parsed robot: the same Pinocchio model each call, equal to pinocchio's own parse."""
    from bracekit.model.shipped import load_model

    a = load_model("paper-robot", stiffness=300.0)
    b = load_model("paper-robot")
    assert a.model is b.model  # parsed once
    np.testing.assert_array_equal(a.stiffness, np.full(a.n, 300.0))
    np.testing.assert_array_equal(b.stiffness, np.full(b.n, 170.0))
    fresh = pin.buildModelFromUrdf(str(PAPER_URDF))  # pinocchio's parse, independent of bracekit's loader
    data, fdata = a.model.createData(), fresh.createData()
    q = np.random.default_rng(4).uniform(-1.0, 1.0, a.n)
    pin.framesForwardKinematics(a.model, data, q)
    pin.framesForwardKinematics(fresh, fdata, q)
    tool = fresh.getFrameId("tool")
    np.testing.assert_allclose(data.oMf[a.model.getFrameId("tool")].homogeneous, fdata.oMf[tool].homogeneous)


def test_a_derived_robot_leaves_the_parsed_robot_unchanged() -> None:
    """A brace point added to one loaded robot is not a frame of the next one (the model is copied)."""
    from bracekit.model.shipped import load_model

    load_model("puma560").with_point_frame("extra_point", "link3", [0.1, 0.0, 0.0])
    assert not load_model("puma560").model.existFrame("extra_point")
