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
