"""evaluate(): one configuration, every matrix of the model, checked against independent computations."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from bracekit import load_model
from bracekit.studies.evaluate import evaluate

Q = np.array([0.0, 0.194, -2.598, 0.0, -0.737, -2.498, -1.898, 3.142, 2.106, 2.438, 0.867])


def test_evaluate_matches_pinocchio_and_the_lagrange_equilibrium() -> None:
    from bracekit.validate.statics import lagrange_compliance

    robot = load_model("paper-robot")
    r = evaluate(robot, "brace", Q, normal=[0, 0, 1])
    data = robot.model.createData()
    j = pin.computeFrameJacobian(robot.model, data, Q, robot.tip_id, pin.LOCAL_WORLD_ALIGNED)
    assert np.allclose(r["J"], j, atol=1e-12)
    assert np.allclose(r["e"], data.oMf[robot.tip_id].translation)
    k = robot.stiffness
    assert np.allclose(r["C_free"], (j / k) @ j.T, atol=1e-15)
    jb = pin.computeFrameJacobian(robot.model, data, Q, robot.frame_id("brace"), pin.LOCAL_WORLD_ALIGNED)
    a = np.concatenate([jb[:3, :6].T @ np.array([0, 0, 1.0]), np.zeros(5)])
    c_true = lagrange_compliance(j, k, a[:, None])
    assert np.allclose(r["C_e_constrained"], c_true, rtol=1e-9, atol=1e-15)
    assert r["n1"] == 6 and r["n2"] == 5
    assert np.array(r["H"]).shape == (6, 5) and np.array(r["A"]).shape == (6, 10)
    assert 0 < r["Ci_constrained"] < r["Ci_free"]


def test_default_beta_x_is_along_the_normal_and_reductions_are_consistent() -> None:
    r = evaluate(load_model("paper-robot"), "brace", Q, normal=[0, 0, 2])
    assert np.allclose(r["beta_x"], [0, 0, 1, 0, 0, 0])
    assert np.isclose(r["Ci_reduction_constrained"], 1 - r["Ci_constrained"] / r["Ci_free"])


def test_evaluate_reports_chain_1_at_a_regular_configuration() -> None:
    r = evaluate(load_model("paper-robot"), "brace", Q, normal=[0, 0, 1])
    assert r["J1_singular"] is False and 1 < r["J1_condition"] < 1e3
    assert r["braced_motions"] == 5 and r["A_rank"] == np.linalg.matrix_rank(r["A"]) == 6


def test_evaluate_at_a_singular_J1_warns_and_counts_the_braced_motions_chain_1_realises() -> None:
    import pytest

    from bracekit.errors import ChainSingularWarning

    q = Q.copy()
    q[4] = 0.0  # the PUMA's wrist singularity: joints 4 and 6 aligned, J1 (n1 = 6) has rank 5
    with pytest.warns(ChainSingularWarning, match="realises 4 of the 5 braced motions") as caught:
        r = evaluate(load_model("paper-robot"), "brace", q, normal=[0, 0, 1])
    assert len(caught) == 1 and "\n" not in str(caught[0].message)
    assert r["J1_singular"] is True and (r["J1_condition"] is None or r["J1_condition"] > 1e8)
    assert r["braced_motions"] == 4
    # A (built from H) still has 5 chain-1 columns; the rank of what chain 1 realises is reported beside it
    assert np.array(r["A"]).shape == (6, 10) and r["A_rank"] <= 6
    import json

    from bracekit.report.output import to_json

    json.loads(to_json(r))  # the new keys are JSON


def test_evaluate_refuses_bad_arguments_with_one_line_bracekit_errors() -> None:
    import pytest

    from bracekit.errors import InputError

    robot = load_model("paper-robot")
    for kwargs in (
        {"robot": "paper-robot"},
        {"brace_frame": None},
        {"brace_frame": "elbow"},
        {"q": Q[:5]},
        {"q": "zeros"},
        {"normal": [0, 0, 0]},
        {"normal": "up"},
        {"contact": "glue"},
        {"beta_x": [1, 0, 0]},
        {"beta_x": "z"},
        {"beta_x": np.zeros(6)},
        {"beta_x": [np.nan, 0, 0, 0, 0, 0]},
    ):
        args = {"robot": robot, "brace_frame": "brace", "q": Q, **kwargs}
        with pytest.raises(InputError) as info:
            evaluate(**args)
        msg = str(info.value)
        assert "\n" not in msg and "--" not in msg, msg


def test_evaluate_on_a_200_joint_chain_completes_and_matches_pinocchio() -> None:
    from bracekit import Robot
    from bracekit.validate.statics import lagrange_compliance
    from helpers import pin_frame_jacobian, random_chain_urdf

    n = 200
    robot = Robot.from_urdf(random_chain_urdf(n, seed=9, brace_link=120), tip="tip")
    q = np.random.default_rng(0).uniform(-1.0, 1.0, n)
    r = evaluate(robot, "brace", q, normal=[0, 0, 1])
    assert r["n"] == n and r["n1"] == 120
    j = pin_frame_jacobian(robot.model, "tip", q)
    np.testing.assert_allclose(r["J"], j, rtol=0, atol=1e-11)
    jb = pin_frame_jacobian(robot.model, "brace", q)
    a = jb[:3].T @ np.array([0.0, 0.0, 1.0])
    c_true = lagrange_compliance(j, robot.stiffness, a[:, None])
    np.testing.assert_allclose(r["C_e_constrained"], c_true, rtol=1e-8, atol=1e-14)
    assert 0 < r["Ci_constrained"] < r["Ci_free"]
