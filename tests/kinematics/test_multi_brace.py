"""Tests of several braces at once (bracekit.kinematics.constraint and the stacked C_e of compliance.first_order).

References: Pinocchio models built independently from the same URDF text (computeFrameJacobian), the bordered
KKT system of the Lagrange-multiplier equilibrium built here, validate.statics.lagrange_compliance, SciPy's
null_space, and the one-brace model of bracekit (the path the paper's run uses).
"""

from __future__ import annotations

import warnings

import numpy as np
import pinocchio as pin
import pytest
from scipy.linalg import null_space

from bracekit.compliance.first_order import (
    C1,
    braced_C1,
    constrained_compliance,
    end_effector_compliance,
    free_space_compliance,
)
from bracekit.contact import Brace, Surface
from bracekit.errors import ContactError, InputError, RedundantContactWarning, UnloadedContactWarning
from bracekit.kinematics import BracedRobot, BracedState
from bracekit.model.robot import Robot
from bracekit.model.shipped import load_model
from bracekit.validate.statics import lagrange_compliance
from helpers import pin_frame_jacobian, pin_frame_placement, random_chain_urdf, random_unit

CONTACTS = ("frictionless_point", "point_with_friction", "soft_finger")


def chain_with_pads(n: int, seed: int, pads: list[tuple[str, int]]) -> str:
    """URDF of a random n-joint chain with a fixed frame `name` on link l`link` for each (name, link) pad."""
    rng = np.random.default_rng(seed + 77)
    extra = []
    for name, link in pads:
        x, y, z = rng.uniform(-0.08, 0.08, 3)
        r, p, w = rng.uniform(-np.pi, np.pi, 3)
        extra.append(
            f'<link name="{name}"/><joint name="{name}_joint" type="fixed"><parent link="l{link}"/>'
            f'<child link="{name}"/><origin xyz="{x} {y} {z}" rpy="{r} {p} {w}"/></joint>'
        )
    return random_chain_urdf(n, seed=seed).replace("</robot>", "\n".join(extra) + "\n</robot>")


def random_braces(rng: np.random.Generator, pads: list[str], contacts: list[str], k_env: list[float | None]) -> list:
    return [
        Brace(name, Surface(rng.normal(size=3), random_unit(rng)), contact=c, environment_stiffness=k)
        for name, c, k in zip(pads, contacts, k_env, strict=True)
    ]


def kkt_compliance(j_e: np.ndarray, k: np.ndarray, g: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Tip compliance from the bordered system of the Lagrange-multiplier equilibrium.

    K Δq − Gᵀ λ = J_eᵀ w (springs against load plus contact reaction Gᵀλ) and G Δq + D λ = 0 (a contact
    row of compliance d_r = 1/k_env deflects by −d_r λ_r; rigid: d_r = 0). C = J_e Δq per unit wrench.
    """
    n, c = k.size, g.shape[0]
    bordered = np.block([[np.diag(k), -g.T], [g, np.diag(d)]])
    rhs = np.vstack([j_e.T, np.zeros((c, 6))])
    return j_e @ np.linalg.solve(bordered, rhs)[:n]


def reference_constraint(model: pin.Model, braces: list, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """G = [X_iᵀ J_b_i] from an independent Pinocchio model, and D = 1/k_env per row."""
    blocks, d = [], []
    for brace in braces:
        x = brace.X()
        blocks.append(x.T @ pin_frame_jacobian(model, brace.frame, q))
        d += [0.0 if brace.environment_stiffness is None else 1.0 / brace.environment_stiffness] * x.shape[1]
    return np.vstack(blocks), np.array(d)


def rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.linalg.norm(a - b) / np.linalg.norm(b))


@pytest.mark.parametrize(
    ("seed", "pads", "contacts", "k_env"),
    [
        (1, [("pa", 3), ("pb", 7)], ["point_with_friction", "frictionless_point"], [None, None]),
        (
            2,
            [("pa", 2), ("pb", 5), ("pc", 9)],
            ["frictionless_point", "soft_finger", "point_with_friction"],
            [None] * 3,
        ),
        (3, [("pa", 4), ("pb", 4)], ["frictionless_point", "point_with_friction"], [None, None]),  # one link twice
        (
            4,
            [("pa", 3), ("pb", 6), ("pc", 8)],
            ["soft_finger", "frictionless_point", "point_with_friction"],
            [2e3, None, 5e4],
        ),
    ],
)
def test_constrained_compliance_equals_the_bordered_kkt_solve_on_random_chains(
    seed: int, pads: list[tuple[str, int]], contacts: list[str], k_env: list[float | None]
) -> None:
    n = 12
    text = chain_with_pads(n, seed, pads)
    rng = np.random.default_rng(seed)
    robot = Robot.from_urdf(text, tip="tip").with_stiffness(rng.uniform(50.0, 500.0, n))
    braces = random_braces(rng, [p for p, _ in pads], contacts, k_env)
    model = pin.buildModelFromXML(text)
    braced = BracedRobot(robot, braces)
    for _ in range(3):
        q = rng.uniform(-np.pi, np.pi, n)
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # generic configurations: independent, loaded rows
            st = braced.state(q)
            c_e = end_effector_compliance(st)
        g, d = reference_constraint(model, braces, q)
        j_e = pin_frame_jacobian(model, "tip", q)
        np.testing.assert_allclose(st.G, g, rtol=0, atol=1e-12)
        assert rel(c_e, kkt_compliance(j_e, robot.stiffness, g, d)) < 1e-10
        if not any(k_env):
            assert rel(c_e, lagrange_compliance(j_e, robot.stiffness, g.T)) < 1e-10
        for brace, b, r_b in zip(braces, st.b_i, st.R_b_i, strict=True):
            ref = pin_frame_placement(model, brace.frame, q)
            np.testing.assert_allclose(b, ref.translation, atol=1e-12)
            np.testing.assert_allclose(r_b, ref.rotation, atol=1e-12)
        np.testing.assert_allclose(c_e, c_e.T, atol=0)
        assert np.linalg.eigvalsh(free_space_compliance(st) - c_e).min() > -1e-12 * np.abs(c_e).max()


def test_constrained_compliance_on_the_paper_robot_with_two_and_three_braces_equals_the_kkt_solve() -> None:
    base = load_model("paper-robot").with_point_frames(
        [
            ("pad_a", "link3", (0.05, 0.02, 0.1), None),
            ("pad_b", "link7", (0.0, 0.04, 0.05), None),
            ("pad_c", "link9", (0.03, 0.0, 0.0), None),
        ]
    )
    rng = np.random.default_rng(11)
    q = np.array([0.0, 0.194, -2.598, 0.0, -0.737, -2.498, -1.898, 3.142, 2.106, 2.438, 0.867])
    for pads, contacts in (
        (["pad_a", "brace"], ["point_with_friction", "frictionless_point"]),
        (["pad_a", "pad_b", "pad_c"], ["frictionless_point", "soft_finger", "frictionless_point"]),
    ):
        braces = random_braces(rng, pads, contacts, [None] * len(pads))
        st = BracedRobot(base, braces).state(q)
        g, d = reference_constraint(base.model, braces, q)
        j_e = pin_frame_jacobian(base.model, base.tip, q)
        c_e = end_effector_compliance(st, "constrained")
        assert rel(c_e, kkt_compliance(j_e, base.stiffness, g, d)) < 1e-10
        assert rel(c_e, lagrange_compliance(j_e, base.stiffness, g.T)) < 1e-10


def test_braced_motions_are_an_orthonormal_complete_basis_of_the_null_space_of_g() -> None:
    n = 12
    text = chain_with_pads(n, 5, [("pa", 3), ("pb", 8)])
    rng = np.random.default_rng(5)
    braces = random_braces(rng, ["pa", "pb"], ["point_with_friction", "soft_finger"], [None, None])
    braced = BracedRobot(Robot.from_urdf(text, tip="tip"), braces)
    st = braced.state(rng.uniform(-np.pi, np.pi, n))
    g, nn = st.G, st.N
    assert g.shape == (7, n) and nn.shape == (n, n - 7) and st.constraint.rank == 7
    np.testing.assert_allclose(g @ nn, 0.0, atol=1e-12 * np.abs(g).max())
    np.testing.assert_allclose(nn.T @ nn, np.eye(n - 7), atol=1e-12)
    ref = null_space(g)  # SciPy's basis of the same space: N Nᵀ projects it onto itself
    np.testing.assert_allclose(nn @ (nn.T @ ref), ref, atol=1e-12)
    np.testing.assert_allclose(st.braced_jacobian, st.J_e @ nn, atol=0)


def test_a_duplicated_brace_warns_and_gives_the_one_brace_compliance() -> None:
    n = 10
    text = random_chain_urdf(n, seed=8, brace_link=5)
    robot = Robot.from_urdf(text, tip="tip")
    rng = np.random.default_rng(8)
    for contact in CONTACTS:
        brace = Brace("brace", Surface(np.zeros(3), random_unit(rng)), contact=contact)
        twice = BracedRobot(robot, [brace, brace])
        q = rng.uniform(-np.pi, np.pi, n)
        with pytest.warns(RedundantContactWarning, match=r"braces\[1\] .* row 0 depends on braces\[0\]"):
            st = twice.state(q)
            c_two = end_effector_compliance(st)
        c_one = end_effector_compliance(BracedRobot(robot, brace).state(q))
        assert np.abs(c_two - c_one).max() < 1e-12 * np.abs(c_one).max()
        c = 6 - brace.kind.l
        assert st.constraint.dependent == tuple(range(c, 2 * c)) and st.N.shape == (n, n - c)


def test_a_duplicated_compliant_brace_is_two_springs_in_parallel() -> None:
    n = 9
    robot = Robot.from_urdf(random_chain_urdf(n, seed=4, brace_link=4), tip="tip")
    rng = np.random.default_rng(4)
    surface = Surface(np.zeros(3), random_unit(rng))
    brace = Brace("brace", surface, contact="point_with_friction", environment_stiffness=3e3)
    stiffer = Brace("brace", surface, contact="point_with_friction", environment_stiffness=6e3)
    q = rng.uniform(-np.pi, np.pi, n)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # compliant rows never make G K⁻¹ Gᵀ + D singular
        c_two = end_effector_compliance(BracedRobot(robot, [brace, brace]).state(q))
    c_one = end_effector_compliance(BracedRobot(robot, stiffer).state(q))
    assert rel(c_two, c_one) < 1e-12


def test_two_contacts_locking_the_same_joints_drop_the_dependent_rows() -> None:
    """Two friction points on link 3: six rows on three joints; the rank-3 constraint locks joints 1–3."""
    n = 10
    text = chain_with_pads(n, 6, [("pa", 3), ("pb", 3)])
    robot = Robot.from_urdf(text, tip="tip")
    rng = np.random.default_rng(6)
    braces = random_braces(rng, ["pa", "pb"], ["point_with_friction"] * 2, [None, None])
    q = rng.uniform(-np.pi, np.pi, n)
    with pytest.warns(RedundantContactWarning, match=r"braces\[1\] \(frame 'pb'"):
        st = BracedRobot(robot, braces).state(q)
        c_e = end_effector_compliance(st)
    assert st.constraint.independent == (0, 1, 2) and st.constraint.dependent == (3, 4, 5)
    assert np.all(np.isfinite(c_e))
    locked = np.hstack([np.eye(3), np.zeros((3, n - 3))])
    j_e = pin_frame_jacobian(pin.buildModelFromXML(text), "tip", q)
    assert rel(c_e, kkt_compliance(j_e, robot.stiffness, locked, np.zeros(3))) < 1e-10
    assert st.N.shape == (n, n - 3)


def test_a_row_no_joint_can_push_warns_unloaded_and_is_dropped() -> None:
    """A point on link 1 braced along joint 1's axis: it moves on a circle about that axis, never along it."""
    n = 8
    text = chain_with_pads(n, 9, [("pa", 1), ("pb", 5)])
    robot = Robot.from_urdf(text, tip="tip")
    rng = np.random.default_rng(9)
    q = rng.uniform(-np.pi, np.pi, n)
    axis = pin_frame_jacobian(pin.buildModelFromXML(text), "pa", q)[3:, 0]
    along = Brace("pa", Surface(np.zeros(3), axis))
    other = random_braces(rng, ["pb"], ["soft_finger"], [None])[0]
    with pytest.warns(UnloadedContactWarning, match=r"braces\[0\] \(frame 'pa'"):
        c_e = end_effector_compliance(BracedRobot(robot, [along, other]).state(q))
    c_other = end_effector_compliance(BracedRobot(robot, other).state(q))
    assert rel(c_e, c_other) < 1e-10


@pytest.mark.parametrize("contact", CONTACTS)
@pytest.mark.parametrize("k_env", [None, 4e3])
def test_a_list_of_one_brace_is_the_one_brace_model(contact: str, k_env: float | None) -> None:
    n = 9
    robot = Robot.from_urdf(random_chain_urdf(n, seed=12, brace_link=4), tip="tip")
    rng = np.random.default_rng(12)
    brace = Brace("brace", Surface(np.zeros(3), random_unit(rng)), contact=contact, environment_stiffness=k_env)
    single, listed = BracedRobot(robot, brace), BracedRobot(robot, [brace])
    assert listed.braces == (brace,) and listed.split.brace is brace and single.braces == (brace,)
    assert (listed.split.brace_id, listed.split.n1, listed.split.n2) == (
        single.split.brace_id,
        single.split.n1,
        single.split.n2,
    )
    for name in ("H", "X", "P"):
        assert np.array_equal(getattr(listed.split, name), getattr(single.split, name))
    for _ in range(3):
        q = rng.uniform(-np.pi, np.pi, n)
        one, other = single.state(q), listed.state(q)
        assert np.array_equal(one.J_e, other.J_e)
        for name in ("J_b", "J1", "J2", "A", "J_braced", "chain1_map"):
            assert np.array_equal(getattr(one.split, name), getattr(other.split, name))
        for model in ("constrained", "projection"):
            assert np.array_equal(end_effector_compliance(one, model), end_effector_compliance(other, model))
        # the stacked constrained C_e of one brace is the paper's eq:Ce through the chain split, with the
        # constrained C̃1 = C1 − C1 X (Xᵀ C1 X + I/k_env)⁻¹ Xᵀ C1 (assembled here by hand)
        sp, k = one.split, robot.stiffness
        c1 = sp.J1 @ np.diag(1.0 / k[: sp.n1]) @ sp.J1.T
        c2 = sp.J2 @ np.diag(1.0 / k[sp.n1 :]) @ sp.J2.T
        m = sp.X.T @ c1 @ sp.X + (0.0 if k_env is None else 1.0 / k_env) * np.eye(sp.X.shape[1])
        c1t = c1 - c1 @ sp.X @ np.linalg.pinv(m, rcond=1e-10, hermitian=True) @ sp.X.T @ c1
        reference = sp.S_t1 @ c1t @ sp.S_t1.T + sp.S_t2 @ c2 @ sp.S_t2.T
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UnloadedContactWarning)
            stacked = end_effector_compliance(listed.state(q))
        assert np.abs(stacked - reference).max() < 1e-12 * np.abs(reference).max()
        np.testing.assert_array_equal(listed.state(q).J_b_i[0], one.split.J_b)


def test_one_brace_quantities_refuse_several_braces_with_a_pointer() -> None:
    n = 9
    robot = Robot.from_urdf(chain_with_pads(n, 13, [("pa", 2), ("pb", 6)]), tip="tip")
    braces = random_braces(np.random.default_rng(13), ["pa", "pb"], ["frictionless_point"] * 2, [None, None])
    braced = BracedRobot(robot, braces)
    assert braced.braces == tuple(braces) and len(braced.brace_ids) == 2
    for name in ("split", "brace", "brace_id"):  # the chain split (n1, n2, H, X, P) and what needs it
        with pytest.raises(ContactError, match=r"defined for one brace; this robot has 2 braces .*: use"):
            getattr(braced, name)
    st = braced.state(np.zeros(n))
    assert isinstance(st, BracedState)
    with pytest.raises(ContactError, match=r"defined for one brace; this robot has 2 braces .*: use the stacked"):
        _ = st.split  # b, R_b, J_b, n1, H, X, P, J1, J2, S_t1, S_t2, J, A, J̃, dq1/db̃
    placements = braced.frame_placements(np.zeros(n))
    for i in range(2):  # what has a meaning for every brace count is there for each brace
        np.testing.assert_array_equal(placements.b_i[i], st.contacts[i].b)
        np.testing.assert_array_equal(placements.R_b_i[i], st.R_b_i[i])
    with pytest.raises(ContactError, match=r"projection model .* is defined for one brace"):
        end_effector_compliance(st, "projection")
    for fn in (C1, braced_C1):
        with pytest.raises(ContactError, match="defined for one brace"):
            fn(st)  # type: ignore[arg-type]
    with pytest.raises(InputError, match="expected a BracedState"):
        constrained_compliance(np.zeros(n))  # type: ignore[arg-type]


def test_braced_robot_refuses_bad_brace_lists() -> None:
    robot = Robot.from_urdf(chain_with_pads(6, 14, [("pa", 2)]), tip="tip")
    brace = Brace("pa", Surface(np.zeros(3), (0.0, 0.0, 1.0)))
    with pytest.raises(ContactError, match="at least one Brace"):
        BracedRobot(robot, [])
    with pytest.raises(ContactError, match="needs a bracekit Brace, got str"):
        BracedRobot(robot, [brace, "pb"])  # type: ignore[list-item]
    with pytest.raises(ContactError, match="last link"):
        BracedRobot(robot, [brace, Brace("tip", brace.surface)])


def test_stacked_state_of_a_long_chain_matches_pinocchio_beyond_the_data_limit() -> None:
    """Beyond DATA_JOINT_LIMIT joints the frames come from ChainFK: compare with Pinocchio's own Jacobians."""
    n = 70
    text = chain_with_pads(n, 15, [("pa", 20), ("pb", 50)])
    rng = np.random.default_rng(15)
    braces = random_braces(rng, ["pa", "pb"], ["soft_finger", "point_with_friction"], [None, None])
    q = rng.uniform(-np.pi, np.pi, n)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        st = BracedRobot(Robot.from_urdf(text, tip="tip"), braces).state(q)
        c_e = end_effector_compliance(st)
    model = pin.buildModelFromXML(text)
    for brace, j_b in zip(braces, st.J_b_i, strict=True):
        np.testing.assert_allclose(j_b, pin_frame_jacobian(model, brace.frame, q), atol=1e-10)
    g, d = reference_constraint(model, braces, q)
    assert rel(c_e, kkt_compliance(pin_frame_jacobian(model, "tip", q), st.K, g, d)) < 1e-10
