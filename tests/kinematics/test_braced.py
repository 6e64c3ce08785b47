"""Tests of bracekit.kinematics (Section III): J1, J2, S_t1, S_t2, A, J, J̃, chain-1 map and Hessians.

References: Pinocchio models built independently from the same URDF text (pin.computeFrameJacobian,
framesForwardKinematics) and central finite differences of poses (positions and log3 of rotations).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from bracekit.contact import Brace, Surface
from bracekit.errors import ContactError, FrameNotFoundError, InputError, NumericalError, SingularityError
from bracekit.kinematics import BracedRobot, skeleton
from bracekit.kinematics import hessian as kinematics
from bracekit.model.robot import Robot
from bracekit.model.shipped import load_model, model_path
from bracekit.objective import BraceAngle, ConditionNumber, Objective
from bracekit.resolution.fused import GradientProjectionStep
from bracekit.resolution.strategies import BracedGradientProjection
from helpers import branched_chain_urdf, pin_frame_jacobian, pin_frame_placement, random_chain_urdf, random_unit

SETTINGS = settings(max_examples=25, deadline=None)
PAPER_URDF = model_path("paper-robot")
WRIST_DOWN_Q = np.array([0.0, 0.1924, -2.594, 0.0, -0.74, -3.1416, 0.2, -3.0734, 1.9224, 0.2834, 0.3])
H_FD = 1e-6


def braced_chain(n: int, seed: int, brace_link: int, normal: np.ndarray | None = None) -> tuple[BracedRobot, pin.Model]:
    """A random chain braced at frame `brace` on link `brace_link`, and an independent Pinocchio model of it."""
    text = random_chain_urdf(n, seed=seed, brace_link=brace_link)
    rng = np.random.default_rng(seed + 1000)
    normal = random_unit(rng) if normal is None else normal
    braced = BracedRobot(Robot.from_urdf(text, tip="tip"), Brace("brace", Surface(np.zeros(3), normal)))
    return braced, pin.buildModelFromXML(text)


def paper_robot(normal: tuple[float, float, float] = (0.0, 0.0, 1.0)) -> tuple[BracedRobot, pin.Model]:
    braced = BracedRobot(load_model("paper-robot"), Brace("brace", Surface(np.zeros(3), np.array(normal))))
    return braced, pin.buildModelFromUrdf(str(PAPER_URDF))


def paper_configurations(count: int, seed: int, max_cond: float = 1e3) -> list[np.ndarray]:
    """Random configurations of the paper robot (inside its limits) where J1 is well conditioned."""
    ref = pin.buildModelFromUrdf(str(PAPER_URDF))
    rng = np.random.default_rng(seed)
    out = []
    while len(out) < count:
        q = rng.uniform(ref.lowerPositionLimit, ref.upperPositionLimit)
        if np.linalg.cond(pin_frame_jacobian(ref, "brace", q)[:, :6]) < max_cond:
            out.append(q)
    return out


def fd_twist(model: pin.Model, frame: str, q: np.ndarray, qdot: np.ndarray, h: float = H_FD) -> np.ndarray:
    """Central-difference twist [v; ω] of a frame (at its origin, world axes) when q moves along qdot."""
    plus = pin_frame_placement(model, frame, q + h * qdot)
    minus = pin_frame_placement(model, frame, q - h * qdot)
    v = (plus.translation - minus.translation) / (2 * h)
    w = pin.log3(plus.rotation @ minus.rotation.T) / (2 * h)
    return np.concatenate([v, w])


def fd_relative_twist(model: pin.Model, tip: str, q: np.ndarray, qdot: np.ndarray, h: float = H_FD) -> np.ndarray:
    """Twist of {e} relative to {b}, at e, in {b}'s axes, by central differences of ᵇM_e = (⁰M_b)⁻¹ ⁰M_e."""

    def rel(qq: np.ndarray) -> pin.SE3:
        return pin_frame_placement(model, "brace", qq).actInv(pin_frame_placement(model, tip, qq))

    plus, minus = rel(q + h * qdot), rel(q - h * qdot)
    v = (plus.translation - minus.translation) / (2 * h)
    w = pin.log3(plus.rotation @ minus.rotation.T) / (2 * h)
    return np.concatenate([v, w])


def hand_S_t1(b: np.ndarray, e: np.ndarray) -> np.ndarray:
    d = b - e
    s = np.eye(6)
    s[:3, 3:] = [[0.0, -d[2], d[1]], [d[2], 0.0, -d[0]], [-d[1], d[0], 0.0]]
    return s


def block_diag(*blocks: np.ndarray) -> np.ndarray:
    rows = sum(b.shape[0] for b in blocks)
    cols = sum(b.shape[1] for b in blocks)
    out = np.zeros((rows, cols))
    r = c = 0
    for b in blocks:
        out[r : r + b.shape[0], c : c + b.shape[1]] = b
        r, c = r + b.shape[0], c + b.shape[1]
    return out


CHAINS = st.tuples(st.integers(7, 10), st.integers(0, 10_000)).flatmap(
    lambda t: st.tuples(st.just(t[0]), st.just(t[1]), st.integers(2, t[0] - 1))
)


# ---------------------------------------------------------------------------------------------- structure
def test_paper_robot_splits_into_six_plus_five_joints() -> None:
    braced, _ = paper_robot()
    assert (braced.n, braced.split.n1, braced.split.n2) == (11, 6, 5)


@pytest.mark.parametrize("link", [2, 5, 7])
def test_random_chain_split_follows_the_brace_link(link: int) -> None:
    braced, _ = braced_chain(9, seed=3, brace_link=link)
    assert (braced.split.n1, braced.split.n2) == (link, 9 - link)
    st_ = braced.state(np.zeros(9))
    assert st_.split.J1.shape == (6, link) and st_.split.J2.shape == (6, 9 - link)
    assert st_.dJ_e is None and st_.split.dJ_b is None  # Hessians only on request


def test_state_rejects_bad_joint_values() -> None:
    braced, _ = paper_robot()
    with pytest.raises(InputError):
        braced.state(np.zeros(10))
    with pytest.raises(InputError):
        braced.state([np.nan] * 11)


def test_state_positions_and_rotations_match_pinocchio() -> None:
    braced, ref = paper_robot()
    st_ = braced.state(WRIST_DOWN_Q)
    mb, me = pin_frame_placement(ref, "brace", WRIST_DOWN_Q), pin_frame_placement(ref, "tool", WRIST_DOWN_Q)
    np.testing.assert_allclose(st_.split.b, mb.translation, atol=1e-14)
    np.testing.assert_allclose(st_.e, me.translation, atol=1e-14)
    np.testing.assert_allclose(st_.split.R_b, mb.rotation, atol=1e-14)
    np.testing.assert_allclose(st_.R_e, me.rotation, atol=1e-14)
    np.testing.assert_allclose(st_.split.z_b, mb.rotation[:, 2], atol=1e-14)
    # MODEL/URDF note A4: in this pose the pad is at (0.700, −0.150, −0.300) m with z_b up
    np.testing.assert_allclose(st_.split.b, [0.700, -0.150, -0.300], atol=1e-3)
    np.testing.assert_allclose(st_.split.z_b, [0.0, 0.0, 1.0], atol=1e-3)


# ---------------------------------------------------------------------------------------------- Jacobians
@SETTINGS
@given(chain=CHAINS, qseed=st.integers(0, 2**31))
def test_free_space_J_equals_pinocchio_tip_jacobian_on_random_chains(chain: tuple[int, int, int], qseed: int) -> None:
    n, seed, link = chain
    braced, ref = braced_chain(n, seed, link)
    q = np.random.default_rng(qseed).uniform(-3.0, 3.0, n)
    st_ = braced.state(q)
    j_ref = pin_frame_jacobian(ref, "tip", q)
    np.testing.assert_allclose(st_.split.J, j_ref, atol=1e-12)
    np.testing.assert_allclose(st_.J_e, j_ref, atol=1e-12)


def test_free_space_J_equals_pinocchio_tip_jacobian_on_the_paper_robot() -> None:
    braced, ref = paper_robot()
    for q in [WRIST_DOWN_Q, *paper_configurations(5, seed=1)]:
        np.testing.assert_allclose(braced.state(q).split.J, pin_frame_jacobian(ref, "tool", q), atol=1e-12)


@SETTINGS
@given(chain=CHAINS, qseed=st.integers(0, 2**31))
def test_J1_is_the_brace_jacobian_restricted_to_chain_1(chain: tuple[int, int, int], qseed: int) -> None:
    n, seed, link = chain
    braced, ref = braced_chain(n, seed, link)
    q = np.random.default_rng(qseed).uniform(-3.0, 3.0, n)
    st_ = braced.state(q)
    j_b = pin_frame_jacobian(ref, "brace", q)
    np.testing.assert_allclose(st_.split.J1, j_b[:, :link], atol=1e-12)
    np.testing.assert_allclose(j_b[:, link:], 0.0, atol=0)  # premise: chain 2 does not move b


def test_J1_of_the_paper_robot_is_the_brace_jacobian_of_joints_1_to_6() -> None:
    braced, ref = paper_robot()
    q = paper_configurations(1, seed=2)[0]
    np.testing.assert_allclose(braced.state(q).split.J1, pin_frame_jacobian(ref, "brace", q)[:, :6], atol=1e-12)


@pytest.mark.parametrize("case", ["paper", "chain-n1=4", "chain-n1=7"])
def test_J2_equals_finite_differences_of_the_relative_pose_of_e_in_b(case: str) -> None:
    if case == "paper":
        braced, ref = paper_robot()
        qs, tip = paper_configurations(2, seed=3), "tool"
    else:
        braced, ref = braced_chain(9, seed=17, brace_link=int(case[-1]))
        qs, tip = list(np.random.default_rng(5).uniform(-2.5, 2.5, (2, 9))), "tip"
    n1 = braced.split.n1
    for q in qs:
        J2 = braced.state(q).split.J2
        for i in range(braced.split.n2):
            qdot = np.zeros(braced.n)
            qdot[n1 + i] = 1.0
            np.testing.assert_allclose(J2[:, i], fd_relative_twist(ref, tip, q, qdot), atol=2e-8)


def test_S_t1_and_S_t2_are_built_from_the_brace_and_tip_poses() -> None:
    braced, ref = paper_robot()
    q = paper_configurations(1, seed=4)[0]
    st_ = braced.state(q)
    mb, me = pin_frame_placement(ref, "brace", q), pin_frame_placement(ref, "tool", q)
    np.testing.assert_allclose(st_.split.S_t1, hand_S_t1(mb.translation, me.translation), atol=1e-14)
    np.testing.assert_allclose(st_.split.S_t2, block_diag(mb.rotation, mb.rotation), atol=1e-14)


def test_J_braced_projects_the_chain_1_columns_off_the_contact_normal() -> None:
    braced, ref = braced_chain(9, seed=23, brace_link=6, normal=np.array([0.0, 0.6, 0.8]))
    q = np.random.default_rng(1).uniform(-2.0, 2.0, 9)
    st_ = braced.state(q)
    P = np.zeros((6, 6))
    P[:3, :3] = np.outer([0.0, 0.6, 0.8], [0.0, 0.6, 0.8])
    j_e, j_b = pin_frame_jacobian(ref, "tip", q), pin_frame_jacobian(ref, "brace", q)
    S = hand_S_t1(st_.split.b, st_.e)
    np.testing.assert_allclose(st_.split.P, P, atol=1e-15)
    np.testing.assert_allclose(st_.split.J_braced[:, :6], j_e[:, :6] - S @ P @ j_b[:, :6], atol=1e-12)
    np.testing.assert_allclose(st_.split.J_braced[:, 6:], j_e[:, 6:], atol=1e-12)


# ---------------------------------------------------------------------------------------------- braced map
def test_A_maps_braced_coordinates_to_the_finite_difference_twist_of_e_for_n1_6() -> None:
    braced, ref = paper_robot(normal=(0.3, -0.2, 0.9))
    rng = np.random.default_rng(6)
    for q in paper_configurations(4, seed=6):
        st_ = braced.state(q)
        j1 = pin_frame_jacobian(ref, "brace", q)[:, :6]
        bdot, q2dot = rng.normal(size=5), rng.normal(size=5)
        q1dot = np.linalg.solve(j1, braced.split.H @ bdot)  # eq:q1, computed here
        twist = fd_twist(ref, "tool", q, np.concatenate([q1dot, q2dot]))
        np.testing.assert_allclose(
            st_.split.A @ np.concatenate([bdot, q2dot]), twist, atol=1e-7 * np.linalg.norm(twist)
        )
        np.testing.assert_allclose(
            st_.split.A[:, :5], hand_S_t1(st_.split.b, st_.e) @ braced.split.H, atol=1e-13
        )  # eq:braced_kin
        np.testing.assert_allclose(st_.split.chain1_map, np.linalg.solve(j1, braced.split.H), atol=1e-10)


@pytest.mark.parametrize("link", [3, 5, 7])
def test_chain1_map_keeps_the_contact_and_A_is_consistent_with_J_for_n1_not_6(link: int) -> None:
    normal = np.array([0.2, -0.5, 0.84])
    normal /= np.linalg.norm(normal)
    braced, ref = braced_chain(9, seed=31, brace_link=link, normal=normal)
    q = np.random.default_rng(link).uniform(-2.5, 2.5, 9)
    st_ = braced.state(q)
    G = st_.split.chain1_map
    j_b, j_e = pin_frame_jacobian(ref, "brace", q), pin_frame_jacobian(ref, "tip", q)
    assert G.shape == (link, link - 1)  # one constraint removes one direction
    np.testing.assert_allclose(normal @ j_b[:3, :link] @ G, 0.0, atol=1e-12)  # Xᵀ J1 G = 0
    np.testing.assert_allclose(G.T @ G, np.eye(link - 1), atol=1e-12)  # orthonormal basis
    assert st_.split.A.shape == (6, link - 1 + 9 - link)
    np.testing.assert_allclose(st_.split.A, j_e @ block_diag(G, np.eye(9 - link)), atol=1e-12)


@pytest.mark.parametrize("case", ["paper", "chain-n1=5", "chain-n1=7"])
def test_braced_motion_has_zero_normal_velocity_at_b(case: str) -> None:
    normal = np.array([0.3, 0.4, np.sqrt(0.75)])
    if case == "paper":
        braced, ref = paper_robot(normal=tuple(normal))
        q = paper_configurations(1, seed=8)[0]
    else:
        braced, ref = braced_chain(9, seed=41, brace_link=int(case[-1]), normal=normal)
        q = np.random.default_rng(2).uniform(-2.0, 2.0, 9)
    st_ = braced.state(q)
    G = st_.split.chain1_map
    rng = np.random.default_rng(9)
    for _ in range(3):
        bdot = rng.normal(size=G.shape[1])
        qdot = np.concatenate([G @ bdot, rng.normal(size=braced.split.n2)])
        v_b = fd_twist(ref, "brace", q, qdot)
        assert abs(normal @ v_b[:3]) < 1e-8 * max(1.0, np.linalg.norm(v_b))
        assert np.linalg.norm(v_b[:3]) > 1e-3  # the brace point does move (tangentially)
        if braced.split.n1 == 6:  # b moves exactly with the allowed twist H ḃ
            np.testing.assert_allclose(v_b, braced.split.H @ bdot, atol=1e-7 * np.linalg.norm(bdot))


# ---------------------------------------------------------------------------------------------- Hessians
def fd_jacobian_derivative(model: pin.Model, frame: str, q: np.ndarray, h: float = 1e-6) -> np.ndarray:
    """(6, n, n), [:, i, k] = ∂J[:, i]/∂q_k by central differences of pin.computeFrameJacobian."""
    n = q.size
    out = np.empty((6, n, n))
    for k in range(n):
        dq = np.zeros(n)
        dq[k] = h
        out[:, :, k] = (pin_frame_jacobian(model, frame, q + dq) - pin_frame_jacobian(model, frame, q - dq)) / (2 * h)
    return out


@pytest.mark.parametrize("case", ["paper", "chain-n1=4", "chain-n1=8"])
def test_kinematic_hessians_equal_finite_differences_of_the_jacobians(case: str) -> None:
    if case == "paper":
        braced, ref = paper_robot()
        q, tip = paper_configurations(1, seed=10)[0], "tool"
    else:
        braced, ref = braced_chain(10, seed=51, brace_link=int(case[-1]))
        q, tip = np.random.default_rng(3).uniform(-2.5, 2.5, 10), "tip"
    st_ = braced.state(q, hessians=True)
    assert st_.dJ_e is not None and st_.split.dJ_b is not None
    fd_e, fd_b = fd_jacobian_derivative(ref, tip, q), fd_jacobian_derivative(ref, "brace", q)
    np.testing.assert_allclose(st_.dJ_e, fd_e, atol=1e-7)
    np.testing.assert_allclose(st_.split.dJ_b, fd_b, atol=1e-7)
    # the guard is sensitive to the memory layout: the swapped index order differs by far more than atol
    assert np.max(np.abs(fd_e - fd_e.transpose(0, 2, 1))) > 1e-2
    assert np.max(np.abs(fd_b - fd_b.transpose(0, 2, 1))) > 1e-2


def test_a_misread_hessian_layout_raises_and_the_layout_is_checked_once_per_frame(monkeypatch) -> None:
    real = pin.getFrameKinematicHessian

    def c_order(model, data, frame_id, rf):
        """What a Pinocchio whose strides matched its memory would return: the true tensor in C order."""
        h = real(model, data, frame_id, rf)
        return np.ascontiguousarray(h.ravel(order="C").reshape(h.shape, order="F"))

    q = np.random.default_rng(0).uniform(-2.0, 2.0, 7)
    monkeypatch.setattr(pin, "getFrameKinematicHessian", c_order)
    braced, _ = braced_chain(7, seed=61, brace_link=4)  # fresh models: their Hessians are not checked yet
    with pytest.raises(NumericalError, match="memory layout"):
        braced.state(q, hessians=True)
    braced, _ = braced_chain(7, seed=61, brace_link=4)
    strategy = BracedGradientProjection(Objective([ConditionNumber(), BraceAngle()], [1.0, 1.0]))
    with pytest.raises(NumericalError, match="memory layout"):
        GradientProjectionStep(braced, strategy)(q, np.zeros(6))
    monkeypatch.setattr(pin, "getFrameKinematicHessian", real)
    calls: list[int] = []
    check = kinematics.check_hessian_layout
    monkeypatch.setattr(kinematics, "check_hessian_layout", lambda m, f, **kw: (calls.append(f), check(m, f, **kw)))
    braced, _ = braced_chain(7, seed=61, brace_link=4)
    for _ in range(3):
        braced.state(q, hessians=True)
    assert sorted(calls) == sorted([braced.robot.tip_id, braced.brace_id])


# ---------------------------------------------------------------------------------------------- PUMA facts
def test_puma_flange_at_qn_matches_corkes_toolbox() -> None:
    puma = load_model("puma560").with_point_frame("pad", "link3", offset=(0.1, 0.0, 0.0))
    braced = BracedRobot(puma, Brace("pad", Surface(np.zeros(3), np.array([0.0, 0.0, 1.0]))))
    qn = np.array([0.0, np.pi / 4, np.pi, 0.0, np.pi / 4, 0.0])
    st_ = braced.state(qn)
    np.testing.assert_allclose(st_.e, [0.5963, -0.1501, -0.0144], atol=1e-4)
    np.testing.assert_allclose(skeleton(puma, qn)[-1], st_.e, atol=1e-14)
    assert (braced.split.n1, braced.split.n2) == (3, 3)


def test_skeleton_lists_base_joint_origins_and_tip() -> None:
    text = random_chain_urdf(5, seed=4)
    robot, ref = Robot.from_urdf(text, tip="tip"), pin.buildModelFromXML(text)
    q = np.linspace(-1.0, 1.0, 5)
    pts = skeleton(robot, q)
    data = ref.createData()
    pin.framesForwardKinematics(ref, data, q)
    expected = (
        [np.zeros(3)] + [data.oMi[j].translation for j in range(1, 6)] + [data.oMf[ref.getFrameId("tip")].translation]
    )
    np.testing.assert_allclose(pts, np.array(expected), atol=1e-14)


# ---------------------------------------------------------------------------------------------- errors
def brace_on(robot: Robot, frame: str) -> BracedRobot:
    return BracedRobot(robot, Brace(frame, Surface(np.zeros(3), np.array([0.0, 0.0, 1.0]))))


def test_brace_frame_on_the_base_is_a_contact_error() -> None:
    robot = Robot.from_urdf(random_chain_urdf(6, seed=1), tip="tip").with_point_frame("pad", "base", (0.1, 0, 0))
    with pytest.raises(ContactError, match="base") as info:
        brace_on(robot, "pad")
    assert "\n" not in str(info.value)


def test_brace_frame_on_the_last_link_is_a_contact_error() -> None:
    robot = Robot.from_urdf(random_chain_urdf(6, seed=1), tip="tip").with_point_frame("pad", "l6", (0.1, 0, 0))
    with pytest.raises(ContactError, match="last link"):
        brace_on(robot, "pad")
    with pytest.raises(ContactError):
        brace_on(robot, "tip")


def test_brace_frame_on_a_side_branch_is_a_contact_error() -> None:
    robot = Robot.from_urdf(branched_chain_urdf(), tip="tip")
    with pytest.raises(ContactError, match="not on the chain"):
        brace_on(robot, "side_tool")


def test_unknown_brace_frame_is_a_frame_not_found_error() -> None:
    with pytest.raises(FrameNotFoundError, match="nowhere"):
        brace_on(load_model("paper-robot"), "nowhere")


def test_singular_J1_at_the_puma_wrist_singularity_raises_singularity_error() -> None:
    braced, ref = paper_robot()
    q = WRIST_DOWN_Q.copy()
    q[4] = 0.0  # q5 = 0: joint 4 and joint 6 axes align
    s = np.linalg.svd(pin_frame_jacobian(ref, "brace", q)[:, :6], compute_uv=False)
    assert s[-1] < 1e-12 * s[0]  # premise: J1 is singular
    st_ = braced.state(q)
    with pytest.raises(SingularityError) as info:
        _ = st_.split.chain1_map
    assert "\n" not in str(info.value)


# ---------------------------------------------------------------------------------------------- long chains, bad input
def test_a_long_chain_state_equals_pinocchio_without_its_data() -> None:
    from bracekit.model.chain import DATA_JOINT_LIMIT

    n = 200
    assert n > DATA_JOINT_LIMIT
    braced, ref = braced_chain(n, seed=77, brace_link=120)
    q = np.random.default_rng(2).uniform(-1.0, 1.0, n)
    st = braced.state(q)
    data = ref.createData()  # the reference, one Pinocchio pass
    pin.computeJointJacobians(ref, data, q)
    pin.updateFramePlacements(ref, data)
    for frame, jac in (("tip", st.J_e), ("brace", st.split.J_b)):
        fid = ref.getFrameId(frame)
        np.testing.assert_allclose(jac, pin.getFrameJacobian(ref, data, fid, pin.LOCAL_WORLD_ALIGNED), atol=1e-11)
    np.testing.assert_allclose(st.split.b, data.oMf[ref.getFrameId("brace")].translation, rtol=0, atol=1e-11)
    e, r_e, (b,), (r_b,) = braced.frame_placements(q)
    np.testing.assert_allclose(np.concatenate([b, e]), np.concatenate([st.split.b, st.e]), rtol=0, atol=1e-14)
    np.testing.assert_allclose(np.hstack([r_b, r_e]), np.hstack([st.split.R_b, st.R_e]), rtol=0, atol=1e-14)
    pts = skeleton(braced.robot, q)
    assert pts.shape == (n + 2, 3) and np.allclose(pts[-1], st.e)


def test_hessians_beyond_the_joint_limit_are_refused_with_the_limit() -> None:
    from bracekit.errors import ModelError
    from bracekit.kinematics.braced import MAX_HESSIAN_JOINTS

    n = MAX_HESSIAN_JOINTS + 1
    braced = BracedRobot(
        Robot.from_urdf(random_chain_urdf(n, seed=5, brace_link=10), tip="tip"),
        Brace("brace", Surface(np.zeros(3), np.array([0.0, 0.0, 1.0]))),
    )
    with pytest.raises(ModelError, match=str(MAX_HESSIAN_JOINTS)):
        braced.state(np.zeros(n), hessians=True)
    assert braced.state(np.zeros(n)).J_e.shape == (6, n)  # first order is fine


def test_braced_robot_and_state_refuse_wrong_types() -> None:
    from bracekit.errors import ModelError

    braced, _ = braced_chain(7, seed=3, brace_link=4)
    with pytest.raises(ModelError):
        BracedRobot("robot.urdf", braced.brace)  # type: ignore[arg-type]
    with pytest.raises(ContactError):
        BracedRobot(braced.robot, "brace")  # type: ignore[arg-type]
    with pytest.raises(InputError):
        braced.state(np.zeros(7), hessians="yes")  # type: ignore[arg-type]
    for q in ("0 0 0 0 0 0 0", [[0, 1], [2]], None, np.full(7, np.inf)):
        with pytest.raises(InputError):
            braced.state(q)  # type: ignore[arg-type]


@pytest.mark.parametrize("name", ["paper", "two-braces"])
def test_a_state_from_kinematics_is_the_dataclass_built_from_its_fields(name: str) -> None:
    """Reference: BracedState and ContactState built by their own __init__ from the same fields, and Pinocchio."""
    import dataclasses

    from bracekit import load_scenario
    from bracekit.kinematics.braced import BracedState, ContactState
    from bracekit.kinematics.hessian import LWA

    braced = load_scenario(name).braced
    q = np.random.default_rng(31).uniform(braced.robot.lower, braced.robot.upper)
    for hessians in (False, True):
        st = braced.state(q, hessians=hessians)
        for obj, cls in [(st, BracedState)] + [(c, ContactState) for c in st.contacts]:
            assert not hasattr(cls, "__post_init__")  # the fields are all its __init__ sets
            ref = cls(**{f.name: getattr(obj, f.name) for f in dataclasses.fields(cls)})
            assert obj.__dict__.keys() == ref.__dict__.keys()
            assert all(getattr(obj, key) is getattr(ref, key) for key in ref.__dict__)
            with pytest.raises(dataclasses.FrozenInstanceError):
                obj.q = q  # type: ignore[misc]
        data = braced.robot.model.createData()  # a fresh pass: every frame placed
        pin.computeJointJacobians(braced.robot.model, data, q)
        pin.updateFramePlacements(braced.robot.model, data)
        for fid, (m, j) in zip(
            (braced.robot.tip_id, *braced.brace_ids),
            [(np.vstack([np.hstack([st.R_e, st.e[:, None]]), [0, 0, 0, 1]]), st.J_e)]
            + [(np.vstack([np.hstack([c.R_b, c.b[:, None]]), [0, 0, 0, 1]]), c.J_b) for c in st.contacts],
            strict=True,
        ):
            assert np.array_equal(m, data.oMf[fid].homogeneous)
            assert np.array_equal(j, pin.getFrameJacobian(braced.robot.model, data, fid, LWA))
