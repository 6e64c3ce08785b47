"""evaluate() with several braces: the stacked constrained compliance, checked against a KKT solve."""

from __future__ import annotations

import warnings

import numpy as np
import pinocchio as pin
import pytest
import scipy.linalg

from bracekit import load_model
from bracekit.compliance.first_order import constrained_compliance, end_effector_compliance
from bracekit.contact import Brace, Surface, contact_type
from bracekit.errors import ContactError, InputError, RedundantContactWarning
from bracekit.kinematics import BracedRobot
from bracekit.report.output import to_json
from bracekit.simulation.holding import Holding
from bracekit.studies.evaluate import evaluate

Q = np.array([0.0, 0.194, -2.598, 0.0, -0.737, -2.498, -1.898, 3.142, 2.106, 2.438, 0.867])
OFFSET = np.array([0.1, 0.0, 0.05])
N2 = np.array([1.0, 0.0, 1.0]) / np.sqrt(2.0)


def _robot():
    return load_model("paper-robot").with_point_frame("p2", "link8", OFFSET)


def _kkt_compliance(j_e: np.ndarray, k: np.ndarray, a: np.ndarray) -> np.ndarray:
    """Tip deflection per tip wrench with the joints as springs K and the contacts a Δq = 0 (Lagrange).

    [K  aᵀ; a  0] [Δq; λ] = [J_eᵀ w; 0], deflection J_e Δq: one column of C_e per unit wrench w.
    """
    n, c = k.size, a.shape[0]
    kkt = np.block([[np.diag(k), a.T], [a, np.zeros((c, c))]])
    rhs = np.vstack([j_e.T, np.zeros((c, 6))])
    dq = np.linalg.solve(kkt, rhs)[:n]
    return j_e @ dq


def test_two_braces_match_the_constrained_compliance_and_a_kkt_solve() -> None:
    robot = _robot()
    r = evaluate(
        robot, ["brace", "p2"], Q, normal=[[0, 0, 1], N2], contact=["frictionless_point", "point_with_friction"]
    )
    # independent kinematics: Pinocchio's frame Jacobians and the link's placement acting on the offset
    model, data = robot.model, robot.model.createData()
    j_e = pin.computeFrameJacobian(model, data, Q, robot.tip_id, pin.LOCAL_WORLD_ALIGNED)
    j_1 = pin.computeFrameJacobian(model, data, Q, robot.frame_id("brace"), pin.LOCAL_WORLD_ALIGNED)
    j_2 = pin.computeFrameJacobian(model, data, Q, robot.frame_id("p2"), pin.LOCAL_WORLD_ALIGNED)
    pin.framesForwardKinematics(model, data, Q)
    link8 = data.oMf[robot.frame_id("link8")]
    assert np.allclose(r["braces"][1]["b"], link8.act(OFFSET), atol=1e-12)
    assert np.allclose(r["braces"][0]["b"], data.oMf[robot.frame_id("brace")].translation, atol=1e-12)
    assert np.allclose(r["J"], j_e, atol=1e-12)
    assert np.allclose(r["braces"][1]["J_b"], j_2, atol=1e-12)
    # contacts: a frictionless point pushes along n1, a point with friction along any force (3 rows)
    a = np.vstack([np.array([0, 0, 1.0]) @ j_1[:3], j_2[:3]])
    k = robot.stiffness
    c_kkt = _kkt_compliance(j_e, k, a)
    scale = np.abs(c_kkt).max()
    assert np.allclose(r["C_e_constrained"], c_kkt, rtol=0, atol=1e-10 * scale)
    assert np.allclose(r["C_free"], (j_e / k) @ j_e.T, rtol=0, atol=1e-15)
    braced = BracedRobot(
        robot,
        [
            Brace("brace", Surface(r["braces"][0]["b"], [0, 0, 1])),
            Brace("p2", Surface(r["braces"][1]["b"], N2), contact_type("point_with_friction")),
        ],
    )
    direct = constrained_compliance(braced.state(Q))
    assert np.allclose(r["C_e_constrained"], direct, rtol=0, atol=1e-12 * scale)
    assert r["G_rank"] == 4 and len(r["G_rows"]) == 4 and r["G_dependent_rows"] == []
    assert np.array(r["N"]).shape == (11, 7) and np.array(r["braced_jacobian"]).shape == (6, 7)
    assert [b["frame"] for b in r["braces"]] == ["brace", "p2"]
    assert np.array(r["braces"][1]["X"]).shape == (6, 3) and np.array(r["braces"][1]["H"]).shape == (6, 3)
    # default β_x: along the first brace's normal
    assert np.allclose(r["beta_x"], [0, 0, 1, 0, 0, 0])
    assert np.isclose(r["Ci_constrained"], np.linalg.norm(c_kkt[2]), rtol=1e-10)
    assert 0 < r["Ci_constrained"] < r["Ci_free"]


def test_several_braces_report_no_projection_model_and_say_why() -> None:
    r = evaluate(_robot(), ["brace", "p2"], Q, normal=[0, 0, 1])
    for key in ("C_e_projection", "Ci_projection", "Ci_reduction_projection", "ellipsoid_projection"):
        assert r[key] is None
    assert "one brace" in r["projection_reason"]
    assert np.allclose([b["normal"] for b in r["braces"]], [[0, 0, 1], [0, 0, 1]])  # one normal for each brace


def test_one_frame_in_a_list_gives_exactly_the_one_brace_report() -> None:
    robot = load_model("paper-robot")
    one = evaluate(robot, "brace", Q, normal=[0, 0, 1])
    listed = evaluate(robot, ["brace"], Q, normal=[[0, 0, 1]])
    assert to_json(listed) == to_json(one)


def test_the_same_brace_twice_is_dependent_and_leaves_the_one_brace_compliance() -> None:
    robot = load_model("paper-robot")
    with pytest.warns(RedundantContactWarning):
        r = evaluate(robot, ["brace", "brace"], Q, normal=[0, 0, 1])
    assert r["G_rank"] == 1 and r["G_dependent_rows"] == [1]
    one = BracedRobot(robot, Brace("brace", Surface(r["braces"][0]["b"], [0, 0, 1])))
    c_one = end_effector_compliance(one.state(Q), "constrained")
    assert np.allclose(r["C_e_constrained"], c_one, rtol=0, atol=1e-10 * np.abs(c_one).max())


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"normal": [[0, 0, 1], [0, 0, 1], [1, 0, 0]]}, InputError, "one per brace"),
        ({"contact": ["frictionless_point"]}, InputError, "one per brace"),
        ({"holding": Holding(preloads=(1.0, 2.0, 3.0))}, InputError, "one preload per brace"),
        ({"normal": [[0, 0, 1], [0, 0, 0]]}, ContactError, "normal"),
    ],
)
def test_several_braces_refuse_bad_or_unsupported_input(kwargs: dict, error: type, match: str) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(error, match=match):
            evaluate(_robot(), ["brace", "p2"], Q, **kwargs)


def test_an_empty_or_non_string_brace_list_is_refused() -> None:
    for frames in ([], ["brace", 3]):
        with pytest.raises(InputError, match="list of frame names"):
            evaluate(_robot(), frames, Q)


def _rnea_with_contacts(robot, q: np.ndarray, frames: list[str], forces: list[np.ndarray]) -> np.ndarray:
    """τ = rnea(q, 0, 0, fext): gravity held against each contact force (world, at b_i) as an external force."""
    model = robot.model
    data = model.createData()
    pin.forwardKinematics(model, data, q)
    pin.updateFramePlacements(model, data)
    fext = [pin.Force.Zero() for _ in range(model.njoints)]
    for frame, f in zip(frames, forces, strict=True):
        fid = model.getFrameId(frame)
        joint = model.frames[fid].parentJoint
        world = pin.Force(f, np.cross(data.oMf[fid].translation, f))  # the force at b as a spatial force at 0
        fext[joint] = fext[joint] + data.oMi[joint].actInv(world)
    return np.asarray(pin.rnea(model, data, q, np.zeros(model.nv), np.zeros(model.nv), fext), dtype=float)


def test_statics_with_two_braces_hold_gravity_and_each_preload_as_rnea_says() -> None:
    robot = _robot()
    frames, normals = ["brace", "p2"], np.array([[0.0, 0.0, 1.0], N2])
    w = np.array([[0.0, 0.0, -15.0, 0.0, 0.0, 0.0], [4.0, -2.0, 0.0, 0.0, 0.3, 0.0]])
    holding = Holding(gravity=True, wrenches=w, preloads=(6.0, 9.0), frictions=(0.5, None))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = evaluate(robot, frames, Q, normal=normals, holding=holding)
    forces = [6.0 * normals[0], 9.0 * normals[1]]
    tau_ref = _rnea_with_contacts(robot, Q, frames, forces)
    np.testing.assert_allclose(r["tau0"], tau_ref, rtol=0, atol=1e-10 * np.abs(tau_ref).max())
    np.testing.assert_allclose(r["q_s"], Q + tau_ref / robot.stiffness, rtol=0, atol=1e-12)
    for brace, f, p, mu in zip(r["braces"], forces, (6.0, 9.0), (0.5, None), strict=True):
        np.testing.assert_allclose(brace["contact_wrench"][:3], f, atol=1e-12)
        assert brace["preload_N"] == p and brace["friction"] == mu
    # the robot's scales are the least over the braces; the frictionless brace has no slip limit
    lift = np.array([[np.inf if x is None else x for x in b["liftoff"]] for b in r["braces"]])
    np.testing.assert_array_equal(np.min(lift, axis=0), [np.inf if x is None else x for x in r["liftoff"]])
    assert r["braces"][1]["slip"] is None and r["slip"] == r["braces"][0]["slip"]
    from_rnea = np.max(np.abs(tau_ref) / np.where(robot.model.effortLimit > 0, robot.model.effortLimit, np.inf))
    assert r["torque_ratio"] == pytest.approx(from_rnea, rel=1e-10)
    assert "C_e_preloaded" in r and r["Ci_preloaded"] > 0.0


def test_k_of_two_braces_is_the_condition_number_of_the_braced_tip_jacobian_in_any_basis() -> None:
    # docs/model.md: with several braces k is √(tr(M) tr(M⁻¹)) / 6 of M = J_e N Nᵀ J_eᵀ, N an orthonormal basis of
    # the braced motions; the reference takes SciPy's null space of the contact rows from Pinocchio's Jacobians
    # and turns it by a random rotation (k may not depend on the basis)
    robot = _robot()
    r = evaluate(
        robot, ["brace", "p2"], Q, normal=[[0, 0, 1], N2], contact=["frictionless_point", "point_with_friction"]
    )
    model, data = robot.model, robot.model.createData()
    j_e = pin.computeFrameJacobian(model, data, Q, robot.tip_id, pin.LOCAL_WORLD_ALIGNED)
    j_1 = pin.computeFrameJacobian(model, data, Q, robot.frame_id("brace"), pin.LOCAL_WORLD_ALIGNED)
    j_2 = pin.computeFrameJacobian(model, data, Q, robot.frame_id("p2"), pin.LOCAL_WORLD_ALIGNED)
    null = scipy.linalg.null_space(np.vstack([np.array([0, 0, 1.0]) @ j_1[:3], j_2[:3]]))
    turn, _ = np.linalg.qr(np.random.default_rng(3).normal(size=(null.shape[1], null.shape[1])))
    m = j_e @ null @ turn @ turn.T @ null.T @ j_e.T
    k_ref = np.sqrt(np.trace(m) * np.trace(np.linalg.inv(m))) / 6.0
    assert r["k_braced"] == pytest.approx(k_ref, rel=1e-10)
