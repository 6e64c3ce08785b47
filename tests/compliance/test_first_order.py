"""Tests of bracekit.compliance.first_order (Section IV): C1, C2, C̃1 (both models), C_e and unloaded contacts.

The readings of C_e (directional compliance, C_i, ellipsoids) are tested in test_first_order_readings.

References, all computed from an independent Pinocchio model of the same URDF:
* the bordered KKT (Lagrange-multiplier) equilibrium of the WHOLE robot, `lagrange_compliance(J_e, K, a)`
  with a = J_bᵀ X (chain-2 rows are zero because chain 2 does not move b);
* the nonlinear static equilibrium (`solve_static_equilibrium`) under small tip loads;
* direct formulas: J K⁻¹ Jᵀ (free space), J (K + k_env a aᵀ)⁻¹ Jᵀ (elastic environment), and the paper's
  projection formula assembled by hand from eq:C1_def, eq:C1wave_detail, eq:twists.
"""

from __future__ import annotations

import warnings

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from bracekit.compliance.first_order import (
    C1,
    C2,
    braced_C1,
    check_model,
    compliance_index,
    constraint_gain,
    directional_compliance,
    end_effector_compliance,
    free_space_compliance,
    loaded_gain,
)
from bracekit.contact import FRICTIONLESS_POINT, POINT_WITH_FRICTION, SOFT_FINGER, Brace, ContactType, Surface
from bracekit.errors import InputError, NumericalError, UnloadedContactWarning
from bracekit.kinematics import BracedRobot
from bracekit.model.robot import Robot
from bracekit.model.shipped import load_model, model_path
from bracekit.validate.statics import lagrange_compliance, solve_static_equilibrium
from helpers import pin_frame_jacobian, pin_frame_placement, random_chain_urdf, random_unit

SETTINGS = settings(max_examples=30, deadline=None)
PAPER_URDF = model_path("paper-robot")
WRIST_DOWN_Q = np.array([0.0, 0.1924, -2.594, 0.0, -0.74, -3.1416, 0.2, -3.0734, 1.9224, 0.2834, 0.3])
PAPER_K = np.linspace(120.0, 220.0, 11)

CHAINS = st.tuples(st.integers(7, 10), st.integers(0, 10_000)).flatmap(
    lambda t: st.tuples(st.just(t[0]), st.just(t[1]), st.integers(2, t[0] - 1))
)


class Case:
    """A braced robot at a configuration, with the independent Pinocchio reference quantities."""

    def __init__(
        self,
        urdf: str | None,
        q: np.ndarray,
        normal: np.ndarray,
        stiffness: np.ndarray,
        contact: ContactType = FRICTIONLESS_POINT,
        env: float | None = None,
    ) -> None:
        if urdf is None:  # the paper robot
            robot, self.tip = load_model("paper-robot", stiffness=stiffness), "tool"
            self.ref = pin.buildModelFromUrdf(str(PAPER_URDF))
        else:
            robot, self.tip = Robot.from_urdf(urdf, tip="tip", stiffness=stiffness), "tip"
            self.ref = pin.buildModelFromXML(urdf)
        self.surface = Surface(np.zeros(3), normal)
        self.braced = BracedRobot(robot, Brace("brace", self.surface, contact=contact, environment_stiffness=env))
        self.q, self.K, self.n1 = q, np.asarray(stiffness, dtype=float), self.braced.split.n1
        self.state = self.braced.state(q)
        self.J_e = pin_frame_jacobian(self.ref, self.tip, q)
        self.J_b = pin_frame_jacobian(self.ref, "brace", q)
        assert np.all(self.J_b[:, self.n1 :] == 0.0)  # premise of a = [J1ᵀX; 0]

    def X(self) -> np.ndarray:
        """Constraint wrenches of the contact, written out by hand (Salisbury)."""
        x, y, z = self.surface.frame.T
        o = np.zeros(3)
        name = self.braced.brace.contact.name
        if name == "frictionless_point":
            cols = [np.r_[z, o]]
        elif name == "point_with_friction":
            cols = [np.r_[x, o], np.r_[y, o], np.r_[z, o]]
        else:
            cols = [np.r_[x, o], np.r_[y, o], np.r_[z, o], np.r_[o, z]]
        return np.array(cols).T

    def a(self) -> np.ndarray:
        """Constraint gradients a = [J1ᵀ X; 0] (n × m)."""
        return self.J_b.T @ self.X()

    def kkt(self) -> np.ndarray:
        return lagrange_compliance(self.J_e, self.K, self.a())

    def free(self) -> np.ndarray:
        return (self.J_e / self.K) @ self.J_e.T


def random_case(
    n: int, seed: int, link: int, contact: ContactType = FRICTIONLESS_POINT, env: float | None = None
) -> Case:
    rng = np.random.default_rng(seed + 7)
    return Case(
        random_chain_urdf(n, seed=seed, brace_link=link),
        rng.uniform(-3.0, 3.0, n),
        random_unit(rng),
        rng.uniform(50.0, 500.0, n),
        contact,
        env,
    )


def paper_case(q: np.ndarray = WRIST_DOWN_Q, normal: tuple[float, ...] = (0.0, 0.0, 1.0), **kw: object) -> Case:
    return Case(None, q, np.array(normal), PAPER_K, **kw)  # type: ignore[arg-type]


def paper_configurations(count: int, seed: int) -> list[np.ndarray]:
    ref = pin.buildModelFromUrdf(str(PAPER_URDF))
    rng = np.random.default_rng(seed)
    return [rng.uniform(ref.lowerPositionLimit, ref.upperPositionLimit) for _ in range(count)]


def cross_matrix(v: np.ndarray) -> np.ndarray:
    """[v]× of eq:skew_sym, written out."""
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.linalg.norm(a - b) / np.linalg.norm(b))


# ---------------------------------------------------------------------------------------------- C1, C2, free
def test_C1_and_C2_are_the_chain_compliances_of_eq_C1_def_and_eq_C2_def() -> None:
    c = random_case(9, seed=4, link=5)
    j1 = c.J_b[:, :5]
    np.testing.assert_allclose(C1(c.state), j1 @ np.diag(1.0 / c.K[:5]) @ j1.T, rtol=1e-12, atol=1e-15)
    R = pin_frame_placement(c.ref, "brace", c.q).rotation
    Rt = np.kron(np.eye(2), R.T)  # diag(ᵇR_0, ᵇR_0)
    j2 = Rt @ c.J_e[:, 5:]  # chain 2's twist of e in {b}'s axes
    np.testing.assert_allclose(C2(c.state), j2 @ np.diag(1.0 / c.K[5:]) @ j2.T, rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize("which", ["paper", "chain"])
def test_free_space_compliance_is_J_Kinv_Jt_with_the_whole_robot_jacobian(which: str) -> None:
    c = paper_case() if which == "paper" else random_case(8, seed=9, link=3)
    np.testing.assert_allclose(free_space_compliance(c.state), c.free(), rtol=1e-12, atol=1e-15)


def test_unknown_compliance_model_is_an_input_error() -> None:
    c = paper_case()
    with pytest.raises(InputError, match="projection"):
        end_effector_compliance(c.state, "exact")  # type: ignore[arg-type]
    with pytest.raises(InputError):
        check_model("Constrained")


# ---------------------------------------------------------------------------------------------- C_e
@SETTINGS
@given(chain=CHAINS)
def test_end_effector_compliance_is_symmetric_positive_semidefinite(chain: tuple[int, int, int]) -> None:
    c = random_case(*chain)
    with warnings.catch_warnings():
        warnings.simplefilter("error", UnloadedContactWarning)
        for model in ("constrained", "projection"):
            ce = end_effector_compliance(c.state, model)
            scale = np.linalg.norm(ce)
            np.testing.assert_allclose(ce, ce.T, atol=1e-12 * scale)
            assert np.linalg.eigvalsh(ce).min() >= -1e-12 * scale
            c1t = braced_C1(c.state, model)  # the chain-1 part on its own, too
            assert np.linalg.eigvalsh(c1t).min() >= -1e-12 * np.linalg.norm(c1t)


@SETTINGS
@given(chain=CHAINS)
def test_constrained_compliance_equals_the_kkt_equilibrium_of_the_whole_robot(chain: tuple[int, int, int]) -> None:
    c = random_case(*chain)
    with warnings.catch_warnings():
        warnings.simplefilter("error", UnloadedContactWarning)
        ce = end_effector_compliance(c.state, "constrained")
    assert rel(ce, c.kkt()) < 1e-10
    assert rel(end_effector_compliance(c.state), ce) == 0.0  # constrained is the default


def test_constrained_compliance_equals_the_kkt_equilibrium_on_the_paper_robot() -> None:
    for q in [WRIST_DOWN_Q, *paper_configurations(6, seed=1)]:
        c = paper_case(q, normal=(0.1, -0.2, 0.97))
        assert rel(end_effector_compliance(c.state, "constrained"), c.kkt()) < 1e-10


@pytest.mark.parametrize("contact", [POINT_WITH_FRICTION, SOFT_FINGER], ids=["friction", "soft-finger"])
@pytest.mark.parametrize("link", [5, 7])
def test_constrained_compliance_of_friction_contacts_equals_the_kkt_equilibrium(
    contact: ContactType, link: int
) -> None:
    c = random_case(9, seed=60 + link, link=link, contact=contact)
    with warnings.catch_warnings():
        warnings.simplefilter("error", UnloadedContactWarning)
        ce = end_effector_compliance(c.state)
    assert rel(ce, c.kkt()) < 1e-10
    # more constraints, stiffer: the friction contact is below the frictionless one in the Loewner order
    c_fl = random_case(9, seed=60 + link, link=link)
    assert np.linalg.eigvalsh(end_effector_compliance(c_fl.state) - ce).min() > -1e-12 * np.linalg.norm(ce)


def test_soft_finger_on_the_paper_robot_equals_the_kkt_equilibrium() -> None:
    c = paper_case(contact=SOFT_FINGER)
    assert rel(end_effector_compliance(c.state), c.kkt()) < 1e-10


@pytest.mark.parametrize("which", ["paper", "chain"])
def test_constrained_compliance_agrees_with_the_nonlinear_static_equilibrium(which: str) -> None:
    c = paper_case() if which == "paper" else random_case(9, seed=12, link=5)
    ce = end_effector_compliance(c.state, "constrained")
    cp = end_effector_compliance(c.state, "projection")
    model = c.ref  # an independent Pinocchio model of the same URDF
    brace_id, tip_id = model.getFrameId("brace"), model.getFrameId(c.tip)
    b = pin_frame_placement(model, "brace", c.q).translation
    rng = np.random.default_rng(3)
    directions = [*np.eye(6), *(random_unit(rng, 6) for _ in range(2))]
    worst_projection = 0.0
    for d in directions:
        w = np.r_[0.1 * d[:3], 0.01 * d[3:]]  # 0.1 N, 0.01 N·m: small loads
        res = solve_static_equilibrium(model, c.q, c.K, brace_id, tip_id, b, c.surface.normal, w)
        assert res.converged
        assert rel(ce @ w, res.deflection) < 0.01
        worst_projection = max(worst_projection, rel(cp @ w, res.deflection))
    assert worst_projection > 0.05  # the paper's projection model misses the true deflection


def test_projection_model_is_the_papers_formula_and_differs_from_the_constrained_one() -> None:
    diffs = []
    for q in paper_configurations(8, seed=2):
        c = paper_case(q)
        n = c.surface.normal
        P = np.zeros((6, 6))
        P[:3, :3] = np.outer(n, n)  # X (XᵀX)⁻¹ Xᵀ with X = [n̂; 0]
        j1, je2 = c.J_b[:, :6], c.J_e[:, 6:]
        c1t = (np.eye(6) - P) @ j1 @ np.diag(1.0 / c.K[:6]) @ j1.T @ (np.eye(6) - P)  # eq:C1wave_detail
        b, e = c.state.split.b, c.state.e
        S1 = np.eye(6)
        S1[:3, 3:] = cross_matrix(b - e)  # [b − e]×
        paper = S1 @ c1t @ S1.T + je2 @ np.diag(1.0 / c.K[6:]) @ je2.T  # S_t2 C2 S_t2ᵀ = J_e2 K2⁻¹ J_e2ᵀ
        proj = end_effector_compliance(c.state, "projection")
        assert rel(proj, paper) < 1e-12
        np.testing.assert_allclose(braced_C1(c.state, "projection"), c1t, rtol=1e-12, atol=1e-16)
        diffs.append(rel(proj, end_effector_compliance(c.state, "constrained")))
    assert min(diffs) > 1e-3 and np.median(diffs) > 0.1, diffs


@SETTINGS
@given(chain=CHAINS)
def test_bracing_never_increases_compliance_in_the_loewner_order(chain: tuple[int, int, int]) -> None:
    c = random_case(*chain)
    diff = free_space_compliance(c.state) - end_effector_compliance(c.state, "constrained")
    assert np.linalg.eigvalsh(diff).min() >= -1e-12 * np.linalg.norm(c.free())
    # and the brace removes at least the normal compliance at b: strictly stiffer somewhere
    assert np.linalg.eigvalsh(diff).max() > 1e-9 * np.linalg.norm(c.free())


def test_printed_S_w2_would_make_C_e_non_symmetric_while_the_dual_map_keeps_it_symmetric() -> None:
    for c in (paper_case(), random_case(9, seed=5, link=4)):
        b, e, R = c.state.split.b, c.state.e, c.state.split.R_b
        S1 = np.eye(6)
        S1[:3, 3:] = cross_matrix(b - e)  # [b − e]×
        S2 = np.kron(np.eye(2), R)
        c1t, c2 = braced_C1(c.state), C2(c.state)
        # the paper's wrench maps as printed
        S_w1 = np.eye(6)
        S_w1[3:, :3] = cross_matrix(e - b)  # [e − b]×
        S_w2_printed = np.zeros((6, 6))
        S_w2_printed[:3, :3] = R.T
        S_w2_printed[3:, 3:] = R.T
        S_w2_printed[3:, :3] = R.T @ cross_matrix(b - e)
        np.testing.assert_allclose(S_w1, S1.T, atol=1e-15)  # printed S_w1 is already the dual of S_t1
        printed = S1 @ c1t @ S_w1 + S2 @ c2 @ S_w2_printed
        ours = S1 @ c1t @ S1.T + S2 @ c2 @ S2.T
        assert np.linalg.norm(printed - printed.T) / np.linalg.norm(printed) > 0.01
        assert np.linalg.norm(ours - ours.T) / np.linalg.norm(ours) < 1e-14
        assert rel(end_effector_compliance(c.state), ours) < 1e-12
        assert rel(ours, c.kkt()) < 1e-10 and rel(printed, c.kkt()) > 0.01


# ---------------------------------------------------------------------------------------------- environment
def test_finite_environment_stiffness_is_a_spring_in_the_contact_and_has_the_right_limits() -> None:
    base = random_case(9, seed=33, link=5)
    a = base.a()
    rigid, free = base.kkt(), base.free()
    previous = None
    for k_env in (1e-9, 1e2, 1e3, 1e4, 1e12):
        c = random_case(9, seed=33, link=5, env=k_env)
        ce = end_effector_compliance(c.state)
        # independent: Δq = (K + k_env a aᵀ)⁻¹ Jᵀ w for a joint-spring chain with a contact spring
        spring = c.J_e @ np.linalg.solve(np.diag(c.K) + k_env * (a @ a.T), c.J_e.T)
        assert rel(ce, spring) < 1e-8
        if previous is not None:  # stiffer environment, stiffer tip
            assert np.linalg.eigvalsh(previous - ce).min() >= -1e-12 * np.linalg.norm(free)
        previous = ce
        if k_env == 1e-9:
            assert rel(ce, free) < 1e-6
        if k_env == 1e12:
            assert rel(ce, rigid) < 1e-6
    assert rel(free, rigid) > 0.01  # the two limits are far apart, so the limits are informative


def on_axis_urdf() -> str:
    """Joint 1 turns about z; the brace point sits on that axis (chain 1 cannot move it)."""
    text = random_chain_urdf(6, seed=13)
    brace = (
        '<link name="brace"/><joint name="brace_joint" type="fixed"><parent link="l1"/><child link="brace"/>'
        '<origin xyz="0 0 0.05" rpy="0 0 0"/></joint></robot>'
    )
    text = text.replace("</robot>", brace)
    # make joint 1's axis z (its origin is (0, 0, 0.1) with a random rpy: set rpy to 0)
    head, rest = text.split('<joint name="j1"', 1)
    j1, tail = rest.split("</joint>", 1)
    j1 = j1.split("<origin")[0] + '<origin xyz="0 0 0.1" rpy="0 0 0"/><axis xyz="0 0 1"/>'
    j1 += '<limit lower="-3.14" upper="3.14" effort="10" velocity="1"/>'
    return head + '<joint name="j1"' + j1 + "</joint>" + tail


def test_unloaded_contact_warns_and_gives_the_free_space_compliance() -> None:
    text = on_axis_urdf()
    q = np.random.default_rng(0).uniform(-2.0, 2.0, 6)
    c = Case(text, q, np.array([0.0, 0.0, 1.0]), np.full(6, 170.0))
    assert c.n1 == 1
    assert np.allclose(c.J_b[:3, :1], 0.0)  # premise: b does not move with q1
    with pytest.warns(UnloadedContactWarning, match="no load"):
        ce = end_effector_compliance(c.state)
    assert np.all(np.isfinite(ce))
    assert rel(ce, c.free()) < 1e-12  # the brace carries nothing: the robot is as compliant as in free space


def test_friction_contact_on_a_two_joint_chain_1_locks_it_and_warns() -> None:
    # chain 1 (2 joints) moves b in at most 2 of the 3 constrained force directions: one is unloaded
    c = random_case(8, seed=44, link=2, contact=POINT_WITH_FRICTION)
    with pytest.warns(UnloadedContactWarning):
        ce = end_effector_compliance(c.state)
    je2 = c.J_e[:, 2:]
    assert rel(ce, je2 @ np.diag(1.0 / c.K[2:]) @ je2.T) < 1e-9  # only chain 2 deflects


def test_an_overflowing_compliance_raises_numerical_error_and_is_never_reported_as_no_load() -> None:
    c = paper_case()
    # stiffnesses so small that 1/K overflows (Robot's range check bypassed on purpose): C1 is inf/nan
    object.__setattr__(c.braced.robot, "stiffness", np.full(c.braced.n, 1e-320))
    state = c.braced.state(c.q)
    with np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("error", UnloadedContactWarning)  # NaN must not pass for "no load"
        for fn in (constraint_gain, end_effector_compliance, free_space_compliance):
            with pytest.raises(NumericalError, match="not finite"):
                fn(state)
        with pytest.raises(NumericalError, match="not finite"):
            end_effector_compliance(state, "projection")
    e_x = np.r_[1.0, 0, 0, 0, 0, 0]
    with np.errstate(all="ignore"):
        with pytest.raises(NumericalError):
            compliance_index(np.full((6, 6), 1e300), e_x)  # ‖β_xᵀ C_e‖ overflows
    with pytest.raises(InputError, match="finite"):  # a NaN compliance is refused as input
        directional_compliance(np.full((6, 6), np.nan), e_x, e_x)


def test_loaded_gain_of_a_stack_equals_each_matrix_and_counts_the_unloaded_directions() -> None:
    rng = np.random.default_rng(8)
    a = rng.normal(size=(5, 3, 3))
    m = a @ a.transpose(0, 2, 1)
    w, v = np.linalg.eigh(m[2])
    m[2] -= w[0] * np.outer(v[:, 0], v[:, 0])  # rank 2: one direction carries no load
    trace = np.trace(m, axis1=1, axis2=2)
    g, unloaded = loaded_gain(m, trace)
    assert unloaded.tolist() == [0, 0, 1, 0, 0]
    for i in range(5):
        g_i, u_i = loaded_gain(m[i], trace[i])
        np.testing.assert_allclose(g[i], g_i, rtol=1e-12, atol=1e-12)
        assert int(u_i) == unloaded[i]
        if not u_i:
            np.testing.assert_allclose(g_i @ m[i], np.eye(3), atol=1e-9)
    np.testing.assert_allclose(g[2] @ m[2] @ g[2], g[2], atol=1e-9)  # the pseudo-inverse on the loaded part
    g1, u1 = loaded_gain(m[:, :1, :1], trace)  # one direction: exactly 1/m
    assert np.array_equal(g1[:, 0, 0], 1.0 / m[:, 0, 0]) and not u1.any()
    g_env, _ = loaded_gain(m, trace, k_env=50.0)
    np.testing.assert_allclose(g_env, np.linalg.inv(m + np.eye(3) / 50.0), rtol=1e-12)
    with pytest.raises(NumericalError):
        loaded_gain(np.full((1, 1), np.nan), 1.0)


def test_generic_contact_emits_no_unloaded_warning() -> None:
    c = paper_case()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        end_effector_compliance(c.state)
        end_effector_compliance(c.state, "projection")


# ---------------------------------------------------------------------------------------------- bad input
def test_compliance_functions_need_a_braced_state() -> None:
    for fn in (C1, C2, end_effector_compliance, free_space_compliance):
        with pytest.raises(InputError, match="BracedState"):
            fn("state")  # type: ignore[arg-type]
    state = paper_case().braced.state(WRIST_DOWN_Q)
    with pytest.raises(InputError):
        end_effector_compliance(state, ["constrained"])  # type: ignore[arg-type]


def test_a_robot_whose_compliance_overflows_float64_gives_a_numerical_error_not_a_warning() -> None:
    # links of 1e200 m: J K⁻¹ Jᵀ overflows in the matrix product ("overflow encountered in matmul")
    # (a URDF with such an origin is refused at load, so the tip frame of the loaded model is moved instead)
    robot = Robot.from_urdf(random_chain_urdf(7, seed=2, brace_link=4), tip="tip")
    m = pin.Model(robot.model)
    fid = m.getFrameId("tip")
    frame = m.frames[fid]
    placement = frame.placement.copy()
    placement.translation = np.array([1e200, 0.02, 0.03])
    frame.placement = placement
    m.frames[fid] = frame
    far = Robot(model=m, tip="tip", stiffness=robot.stiffness)
    braced = BracedRobot(far, Brace("brace", Surface(np.zeros(3), [0.0, 0.0, 1.0])))
    state = braced.state(np.full(7, 0.3))
    for call in (
        lambda: free_space_compliance(state),
        lambda: end_effector_compliance(state),
        lambda: end_effector_compliance(state, "projection"),
    ):
        with pytest.raises(NumericalError) as info:
            call()
        assert "\n" not in str(info.value)
