"""Batch evaluation (bracekit.compliance.batch) equals the single-configuration path to 1e-12.

References: Pinocchio's own placements and frame Jacobians for the vectorised product of exponentials, and
``end_effector_compliance`` / ``compliance_index`` / ``frobenius_condition`` on ``braced.state(q)`` for the
measures, one configuration at a time. The NumPy backend (the numba backend: test_batch_numba.py). No timing is
asserted here.
"""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pinocchio as pin
import pytest

from bracekit import (
    Brace,
    BracedRobot,
    InputError,
    NumericalError,
    Robot,
    Surface,
    compliance_index,
    end_effector_compliance,
    frobenius_condition,
    load_model,
)
from bracekit.compliance.batch import BatchEvaluator, evaluate_batch
from bracekit.compliance.chain_kinematics import ChainKinematics
from bracekit.contact import contact_type
from bracekit.errors import SingularityError, UnloadedContactWarning
from helpers import random_chain_urdf

TOL = 1e-12


def _rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(np.abs(np.asarray(a) - b)) / max(float(np.max(np.abs(b))), 1e-300))


def _pinocchio_frames(robot: Robot, frame_ids, q: np.ndarray):
    data = robot.model.createData()
    pin.computeJointJacobians(robot.model, data, q)
    pin.updateFramePlacements(robot.model, data)
    return [
        (
            data.oMf[f].translation.copy(),
            data.oMf[f].rotation.copy(),
            pin.getFrameJacobian(robot.model, data, f, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED),
        )
        for f in frame_ids
    ]


def _check_chain(robot: Robot, frame_ids, Q: np.ndarray) -> None:
    kin = ChainKinematics(robot, frame_ids)
    assert kin.exact
    fr = kin.frames(Q)
    for i, q in enumerate(Q):
        for f, (p, r, j) in enumerate(_pinocchio_frames(robot, frame_ids, q)):
            assert np.max(np.abs(fr.position[f, i] - p)) < TOL
            assert np.max(np.abs(fr.rotation[f, i] - r)) < TOL
            assert np.max(np.abs(fr.jacobian[f, i] - j)) < TOL


def test_product_of_exponentials_equals_pinocchio_on_the_paper_robot(paper) -> None:
    sc, Q = paper
    _check_chain(sc.robot, (sc.robot.tip_id, sc.braced.brace_id), Q)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_product_of_exponentials_equals_pinocchio_on_random_axes(seed: int) -> None:
    robot = Robot.from_urdf(random_chain_urdf(8, seed=seed, brace_link=4), tip="tip")
    Q = np.random.default_rng(seed).uniform(-3, 3, size=(20, robot.n))
    _check_chain(robot, (robot.tip_id, robot.frame_id("brace")), Q)


def test_product_of_exponentials_handles_prismatic_joints() -> None:
    urdf = random_chain_urdf(6, seed=9, brace_link=3)
    urdf = urdf.replace('name="j2" type="revolute"', 'name="j2" type="prismatic"')
    urdf = urdf.replace('name="j5" type="revolute"', 'name="j5" type="prismatic"')
    robot = Robot.from_urdf(urdf, tip="tip")
    assert "JointModelP" in robot.model.joints[2].shortname()
    Q = np.random.default_rng(1).uniform(-1, 1, size=(15, robot.n))
    _check_chain(robot, (robot.tip_id, robot.frame_id("brace")), Q)


def test_pinocchio_loop_fallback_gives_the_same_frames(paper) -> None:
    sc, Q = paper
    kin = ChainKinematics(sc.robot, (sc.robot.tip_id,))
    a = kin.frames(Q[:10])
    kin.exact = False  # as for a joint the product of exponentials does not model
    b = kin.frames(Q[:10])
    for x, y in zip((a.position, a.rotation, a.jacobian), (b.position, b.rotation, b.jacobian), strict=True):
        assert np.max(np.abs(x - y)) < TOL


def _single(braced: BracedRobot, q: np.ndarray, beta: np.ndarray) -> dict:
    st = braced.state(q)
    out = {"k": frobenius_condition(st.J_e), "k_braced": frobenius_condition(st.split.J_braced)}
    for m in ("constrained", "projection"):
        c_e = end_effector_compliance(st, m)  # type: ignore[arg-type]
        out[m] = c_e
        out["Ci_" + m] = compliance_index(c_e, beta)
    return out


def _check_batch(braced: BracedRobot, Q: np.ndarray, beta: np.ndarray, **kw) -> None:
    res = evaluate_batch(braced, Q, beta, k_braced=True, **kw)
    betas = np.broadcast_to(beta, (len(Q), 6))
    for i, q in enumerate(Q):
        ref = _single(braced, q, betas[i])
        for m in ("constrained", "projection"):
            assert _rel(res.C_e[m][i], ref[m]) < TOL
            assert res.Ci[m][i] == pytest.approx(ref["Ci_" + m], rel=TOL)
        assert res.k[i] == pytest.approx(ref["k"], rel=TOL)
        assert res.k_braced[i] == pytest.approx(ref["k_braced"], rel=TOL)


def test_batch_equals_the_single_configuration_path_on_the_paper_robot(paper) -> None:
    sc, Q = paper
    _check_batch(sc.braced, Q, sc.beta_x(0.0))


def test_batch_takes_one_beta_per_configuration_and_any_chunk_size(paper) -> None:
    sc, Q = paper
    rng = np.random.default_rng(2)
    betas = rng.normal(size=(len(Q), 6))
    betas /= np.linalg.norm(betas, axis=1)[:, None]
    res = BatchEvaluator(sc.braced)(Q, betas, chunk=7)
    for i in range(0, len(Q), 5):
        st = sc.braced.state(Q[i])
        for m in ("constrained", "projection"):
            assert res.Ci[m][i] == pytest.approx(compliance_index(end_effector_compliance(st, m), betas[i]), rel=TOL)
    whole = BatchEvaluator(sc.braced)(Q, betas)
    for m in ("constrained", "projection"):
        assert np.array_equal(whole.C_e[m], res.C_e[m]) or _rel(whole.C_e[m], res.C_e[m]) < 1e-15
    one = BatchEvaluator(sc.braced)(Q[3], betas[3], models=("projection",))  # a single configuration
    assert set(one.C_e) == {"projection"} and one.k.shape == (1,)
    assert one.k_braced is None


@pytest.mark.parametrize("contact", ["frictionless_point", "point_with_friction", "soft_finger"])
def test_batch_equals_the_single_path_on_random_chains_and_contacts(contact: str) -> None:
    robot = Robot.from_urdf(random_chain_urdf(9, seed=5, brace_link=5), tip="tip", stiffness=np.linspace(80, 200, 9))
    rng = np.random.default_rng(3)
    braced = BracedRobot(robot, Brace("brace", Surface(np.zeros(3), rng.normal(size=3)), contact_type(contact)))
    Q = rng.uniform(-3, 3, size=(25, robot.n))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UnloadedContactWarning)
        _check_batch(braced, Q, rng.normal(size=6))


def test_batch_with_a_compliant_environment(paper) -> None:
    sc, Q = paper
    braced = BracedRobot(sc.robot, dataclasses.replace(sc.braced.brace, environment_stiffness=5e3))
    _check_batch(braced, Q[:20], np.r_[0.0, 0.0, 1.0, 0.0, 0.0, 0.0])


def test_batch_reports_singular_configurations_like_frobenius_condition() -> None:
    robot = load_model("puma560").with_point_frame("pad", "link3", (0.1, 0.0, 0.0))
    braced = BracedRobot(robot, Brace("pad", Surface(np.zeros(3), (0.0, 0.0, 1.0))))
    Q = np.random.default_rng(4).uniform(-1.5, 1.5, size=(6, 6))
    Q[4] = 0.0  # the PUMA's zero pose is singular: k is unbounded
    with pytest.raises(SingularityError) as err:
        frobenius_condition(braced.state(Q[4]).J_e)
    with pytest.raises(SingularityError, match="configuration 4"):
        evaluate_batch(braced, Q, np.r_[1.0, 0, 0, 0, 0, 0])
    res = evaluate_batch(braced, Q, np.r_[1.0, 0, 0, 0, 0, 0], errors="nan")
    assert np.isnan(res.k[4]) and np.all(np.isfinite(np.delete(res.k, 4)))
    for i in (0, 1, 2, 3, 5):
        assert res.k[i] == pytest.approx(frobenius_condition(braced.state(Q[i]).J_e), rel=TOL)
    assert "singular" in str(err.value)


@pytest.mark.parametrize("model", ["constrained", "projection"])
def test_batch_raises_numerical_error_when_the_compliance_overflows(model: str) -> None:
    robot = Robot.from_urdf(random_chain_urdf(8, seed=6, brace_link=4), tip="tip")
    object.__setattr__(robot, "stiffness", np.full(robot.n, 1e-320))  # 1/K overflows (range check bypassed)
    braced = BracedRobot(robot, Brace("brace", Surface(np.zeros(3), (0.0, 0.0, 1.0))))
    Q = np.random.default_rng(1).uniform(-2, 2, size=(4, robot.n))
    with np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("error", UnloadedContactWarning)
        for errors in ("raise", "nan"):
            with pytest.raises(NumericalError, match="configuration 0"):
                evaluate_batch(braced, Q, np.r_[1.0, 0, 0, 0, 0, 0], models=(model,), errors=errors)


def test_batch_warns_once_when_the_contact_is_unloaded() -> None:
    # {b} on the first link of a chain whose first joint turns about the surface normal: Xᵀ C1 X = 0
    robot = Robot.from_urdf(random_chain_urdf(6, seed=4), tip="tip").with_point_frame("pad", "l1", (0.2, 0.1, 0.0))
    data = robot.model.createData()
    pin.computeJointJacobians(robot.model, data, np.zeros(robot.n))
    z = pin.getJointJacobian(robot.model, data, 1, pin.ReferenceFrame.WORLD)[3:, 0]  # fixed in the world
    braced = BracedRobot(robot, Brace("pad", Surface(np.zeros(3), z)))
    Q = np.random.default_rng(0).uniform(-2, 2, size=(5, robot.n))
    with pytest.warns(UnloadedContactWarning, match="at 5 of 5 configurations"):
        res = evaluate_batch(braced, Q, np.r_[1.0, 0, 0, 0, 0, 0], models=("constrained",))
    for i, q in enumerate(Q):
        with pytest.warns(UnloadedContactWarning):
            ref = end_effector_compliance(braced.state(q), "constrained")
        assert _rel(res.C_e["constrained"][i], ref) < TOL


def test_batch_rejects_bad_input(paper) -> None:
    sc, Q = paper
    ev = BatchEvaluator(sc.braced)
    with pytest.raises(InputError):
        ev(Q[:, :-1], sc.beta_x(0.0))
    with pytest.raises(InputError):
        ev(np.full((2, sc.robot.n), np.nan), sc.beta_x(0.0))
    with pytest.raises(InputError):
        ev(Q, np.zeros(6))
    with pytest.raises(InputError):
        ev(Q, np.ones((3, 6)))
    with pytest.raises(InputError):
        ev(Q, np.ones(6), models=("stiff",))
    with pytest.raises(InputError):
        ev(Q, np.ones(6), errors="ignore")


# ---------------------------------------------------------------------------------------------- bad input, long chains
@pytest.fixture(scope="module")
def paper_braced() -> BracedRobot:
    return BracedRobot(load_model("paper-robot"), Brace("brace", Surface(np.zeros(3), (0.0, 0.0, 1.0))))


@pytest.mark.parametrize(
    "kwargs",
    [
        {"Q": [[0.0] * 11, [0.0] * 10]},  # ragged
        {"Q": "zeros"},
        {"Q": np.zeros((2, 10))},
        {"Q": np.zeros((0, 11))},
        {"Q": np.zeros((2, 3, 11))},
        {"Q": np.full((2, 11), np.nan)},
        {"beta_x": "z"},
        {"beta_x": np.zeros(6)},
        {"beta_x": np.full((2, 6), np.inf)},
        {"models": ["exact"]},
        {"models": []},
        {"models": None},
        {"errors": 3},
        {"k_braced": "yes"},
    ],
)
def test_evaluate_batch_refuses_bad_input_with_one_line_input_errors(paper_braced: BracedRobot, kwargs: dict) -> None:
    args = {"Q": np.zeros((2, 11)), "beta_x": [0, 0, 1, 0, 0, 0], **kwargs}
    with pytest.raises(InputError) as info:
        evaluate_batch(paper_braced, **args)
    assert "\n" not in str(info.value)
    with pytest.raises(InputError):
        BatchEvaluator("braced")  # type: ignore[arg-type]
    with pytest.raises(InputError):
        BatchEvaluator(paper_braced)(np.zeros((2, 11)), [0, 0, 1, 0, 0, 0], chunk=0)


def test_a_model_name_alone_is_accepted_for_models(paper_braced: BracedRobot) -> None:
    ev = evaluate_batch(paper_braced, np.zeros((1, 11)) + 0.3, [0, 0, 1, 0, 0, 0], models="projection")
    assert ev.models == ("projection",)


def test_batch_on_a_long_chain_equals_the_single_configuration_path() -> None:
    from bracekit.model.chain import DATA_JOINT_LIMIT

    n = DATA_JOINT_LIMIT + 36
    robot = Robot.from_urdf(random_chain_urdf(n, seed=12, brace_link=50), tip="tip")
    braced = BracedRobot(robot, Brace("brace", Surface(np.zeros(3), (0.0, 0.0, 1.0))))
    Q = np.random.default_rng(4).uniform(-1.0, 1.0, size=(3, n))
    beta = np.array([0.0, 0.0, 1.0, 0.0, 0.0, 0.0])
    ev = evaluate_batch(braced, Q, beta)
    for i, q in enumerate(Q):
        st = braced.state(q)
        for model in ("constrained", "projection"):
            c = end_effector_compliance(st, model)
            assert _rel(ev.C_e[model][i], c) < 1e-10
            assert ev.Ci[model][i] == pytest.approx(compliance_index(c, beta), rel=1e-10)
        assert ev.k[i] == pytest.approx(frobenius_condition(st.J_e), rel=1e-10)
