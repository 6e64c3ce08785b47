"""Bracing-location study: each candidate's compliance equals the KKT equilibrium with a brace at that point."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from bracekit import InputError, load_model
from bracekit.studies.brace_location import brace_location_study
from bracekit.validate.statics import lagrange_compliance

Q = np.array([0.0, 0.194, -2.598, 0.0, -0.737, -2.498, -1.898, 3.142, 2.106, 2.438, 0.867])


def test_candidates_match_the_kkt_equilibrium_of_a_brace_at_their_point() -> None:
    robot = load_model("paper-robot")
    cands = brace_location_study(robot, Q, points_per_link=2)
    assert 2 <= len(cands) <= 2 * (robot.n - 1)  # coincident candidates (zero-length links) are dropped
    keys = [(c.n1, tuple(np.round(c.point, 9))) for c in cands]
    assert len(keys) == len(set(keys))
    model, data = robot.model, robot.model.createData()
    pin.forwardKinematics(model, data, Q)
    pin.computeJointJacobians(model, data, Q)
    j_e = pin.getFrameJacobian(model, data, robot.tip_id, pin.LOCAL_WORLD_ALIGNED)
    n_hat = np.array([0.0, 0.0, 1.0])
    beta = np.concatenate([n_hat, np.zeros(3)])
    for c in cands:
        joint = model.frames[model.getFrameId(c.link)].parentJoint
        # Jacobian of the world point c.point carried by that joint, from the joint's own Jacobian
        j_joint = pin.getJointJacobian(model, data, joint, pin.WORLD)
        v_point = j_joint[:3] - np.cross(c.point, j_joint[3:].T).T  # v at the point, world axes
        a = v_point.T @ n_hat
        if np.linalg.norm(a) < 1e-9:
            assert c.unloaded and c.Ci_constrained == pytest.approx(c.Ci_free, rel=1e-9)
            continue
        c_true = lagrange_compliance(j_e, robot.stiffness, a[:, None])
        assert c.Ci_constrained == pytest.approx(np.linalg.norm(beta @ c_true), rel=1e-8)
        assert c.Ci_constrained <= c.Ci_free * (1 + 1e-12)
    values = [c.Ci_constrained for c in cands]
    assert values == sorted(values)


def test_bracing_nearer_the_tip_stiffens_the_tip_more_on_the_paper_robot() -> None:
    cands = brace_location_study(load_model("paper-robot"), Q, points_per_link=1)
    by_n1 = {c.n1: c.Ci_constrained for c in cands}
    assert by_n1[10] < by_n1[6] < by_n1[3]


@pytest.mark.parametrize("points", [0, 10_000])
def test_study_rejects_a_number_of_points_out_of_range(points: int) -> None:
    with pytest.raises(InputError):
        brace_location_study(load_model("paper-robot"), Q, points_per_link=points)


@pytest.mark.parametrize(
    "kwargs",
    [
        {"points_per_link": 2.5},
        {"points_per_link": True},
        {"points_per_link": "3"},
        {"points_per_link": None},
        {"normal": [0, 0, 0]},
        {"normal": "up"},
        {"normal": [np.nan, 0, 1]},
        {"beta_x": [1, 0, 0]},
        {"beta_x": "z"},
        {"contact": "glue"},
        {"q": Q[:3]},
        {"robot": None},
    ],
)
def test_study_refuses_bad_arguments_with_one_line_input_errors(kwargs: dict) -> None:
    args = {"robot": load_model("paper-robot"), "q": Q, **kwargs}
    with pytest.raises(InputError) as info:
        brace_location_study(**args)
    assert "\n" not in str(info.value)


def test_study_on_a_200_joint_chain_completes_and_matches_the_kkt_equilibrium() -> None:
    from bracekit import Robot
    from helpers import random_chain_urdf

    n = 200
    robot = Robot.from_urdf(random_chain_urdf(n, seed=21), tip="tip")
    q = np.random.default_rng(5).uniform(-1.0, 1.0, n)
    cands = brace_location_study(robot, q, points_per_link=2)
    assert (n - 1) <= len(cands) <= 2 * (n - 1)
    values = [c.Ci_constrained for c in cands]
    assert values == sorted(values) and all(np.isfinite(values))
    model = robot.model
    data = model.createData()
    pin.computeJointJacobians(model, data, q)
    j_e = pin.getFrameJacobian(model, data, robot.tip_id, pin.LOCAL_WORLD_ALIGNED)
    beta = np.array([0.0, 0.0, 1.0, 0.0, 0.0, 0.0])
    for c in cands[:: max(1, len(cands) // 8)]:  # a sample along the ranking
        j_joint = pin.getJointJacobian(model, data, c.n1, pin.WORLD)
        a = (j_joint[:3] - np.cross(c.point, j_joint[3:].T).T).T @ beta[:3]
        c_true = lagrange_compliance(j_e, robot.stiffness, a[:, None])
        assert c.Ci_constrained == pytest.approx(np.linalg.norm(beta @ c_true), rel=1e-7)


def test_long_chains_are_studied_without_pinocchios_data(monkeypatch: pytest.MonkeyPatch) -> None:
    """Pinocchio's Data holds n³-sized tensors (0.9 GB at 300 joints); beyond 64 joints neither evaluate nor
    the study may build one (one per candidate made `bracekit study` take minutes on long chains)."""
    from bracekit import Robot
    from bracekit.studies.evaluate import evaluate
    from helpers import random_chain_urdf

    n = 200
    robot = Robot.from_urdf(random_chain_urdf(n, seed=21, brace_link=90), tip="tip")
    q = np.random.default_rng(5).uniform(-1.0, 1.0, n)

    def refuse(model: pin.Model) -> pin.Data:
        raise AssertionError(f"pinocchio.Data built for {model.nv} joints")

    monkeypatch.setattr(pin.Model, "createData", refuse)
    monkeypatch.setattr(pin, "Data", refuse)
    assert len(brace_location_study(robot, q, points_per_link=3)) > n
    assert evaluate(robot, "brace", q)["n1"] == 90
