"""Bracing-location study: each candidate's compliance equals the KKT equilibrium with a brace at that point."""

from __future__ import annotations

import json
import warnings

import numpy as np
import pinocchio as pin
import pytest

from bracekit import InputError, load_model
from bracekit.cli.main import main
from bracekit.compliance.first_order import compliance_index, end_effector_compliance
from bracekit.compliance.measures import frobenius_condition
from bracekit.contact import Brace, Surface
from bracekit.errors import ContactError, FrameNotFoundError
from bracekit.kinematics import BracedRobot
from bracekit.studies.brace_location import brace_location_study
from bracekit.validate.statics import lagrange_compliance

Q = np.array([0.0, 0.194, -2.598, 0.0, -0.737, -2.498, -1.898, 3.142, 2.106, 2.438, 0.867])


def test_candidates_match_the_kkt_equilibrium_of_a_brace_at_their_point() -> None:
    robot = load_model("paper-robot")
    cands = brace_location_study(robot, Q, points_per_link=2)
    assert 2 <= len(cands) <= 2 * (robot.n - 1)  # coincident candidates (zero-length links) are dropped
    keys = [(c.joint, tuple(np.round(c.point, 9))) for c in cands]
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
            assert c.unloaded and c.Ci_constrained == pytest.approx(c.Ci_before, rel=1e-9)
            continue
        c_true = lagrange_compliance(j_e, robot.stiffness, a[:, None])
        assert c.Ci_constrained == pytest.approx(np.linalg.norm(beta @ c_true), rel=1e-8)
        assert c.Ci_constrained <= c.Ci_before * (1 + 1e-12)
    values = [c.Ci_constrained for c in cands]
    assert values == sorted(values)


def test_bracing_nearer_the_tip_stiffens_the_tip_more_on_the_paper_robot() -> None:
    cands = brace_location_study(load_model("paper-robot"), Q, points_per_link=1)
    by_n1 = {c.joint: c.Ci_constrained for c in cands}
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
        j_joint = pin.getJointJacobian(model, data, c.joint, pin.WORLD)
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


# --- a second brace added to a first one -------------------------------------------------------
def _point_constraint(
    model: pin.Model, data: pin.Data, joint: int, point: np.ndarray, normal: np.ndarray
) -> np.ndarray:
    """a (n,) with aᵀΔq = the motion of the world point carried by `joint` along `normal` (Pinocchio, WORLD)."""
    j_joint = pin.getJointJacobian(model, data, joint, pin.WORLD)
    v_point = j_joint[:3] - np.cross(point, j_joint[3:].T).T
    return v_point.T @ normal


def _kkt_compliance(j_e: np.ndarray, k: np.ndarray, a: np.ndarray) -> np.ndarray:
    """Tip compliance from the bordered equilibrium K Δq = J_eᵀ w + a λ, aᵀ Δq = 0 (six unit w); C = J_e Δq."""
    n, m = a.shape
    kkt = np.zeros((n + m, n + m))
    kkt[:n, :n] = np.diag(k)
    kkt[:n, n:] = -a
    kkt[n:, :n] = -a.T
    rhs = np.vstack([j_e.T, np.zeros((m, 6))])
    return j_e @ np.linalg.solve(kkt, rhs)[:n]


def test_pair_candidates_match_the_constrained_compliance_and_a_kkt_solve_with_both_braces() -> None:
    robot = load_model("paper-robot")
    n_1, n_2 = np.array([0.0, 0.0, 1.0]), np.array([0.0, -1.0, 0.0])
    cands = brace_location_study(robot, Q, fixed=[("brace", n_1)], normal=n_2, points_per_link=2)
    values = [c.Ci_constrained for c in cands]
    assert len(cands) >= robot.n - 1 and values == sorted(values)
    model, data = robot.model, robot.model.createData()
    pin.forwardKinematics(model, data, Q)
    pin.computeJointJacobians(model, data, Q)
    pin.updateFramePlacements(model, data)
    j_e = pin.getFrameJacobian(model, data, robot.tip_id, pin.LOCAL_WORLD_ALIGNED)
    frame = model.frames[model.getFrameId("brace")]
    b_1 = data.oMf[model.getFrameId("brace")].translation.copy()
    a_1 = _point_constraint(model, data, frame.parentJoint, b_1, n_1)
    beta = np.concatenate([n_1, np.zeros(3)])
    c_first = _kkt_compliance(j_e, robot.stiffness, a_1[:, None])
    assert cands[0].Ci_before == pytest.approx(np.linalg.norm(beta @ c_first), rel=1e-10)
    checked = 0
    for c in cands:
        assert c.reduction == pytest.approx(1.0 - c.Ci_constrained / c.Ci_before, abs=1e-15)
        a_2 = _point_constraint(model, data, c.joint, c.point, n_2)
        w = np.column_stack([a_1, a_2]) / np.sqrt(robot.stiffness)[:, None]
        s = np.linalg.svd(w, compute_uv=False)
        if c.unloaded or c.redundant:  # the candidate's row is dropped: the first brace alone
            assert s[-1] < 1e-6 * s[0] or np.linalg.norm(a_2) < 1e-9
            assert c.Ci_constrained == pytest.approx(c.Ci_before, rel=1e-10)
            continue
        c_true = _kkt_compliance(j_e, robot.stiffness, np.column_stack([a_1, a_2]))
        assert c.Ci_constrained == pytest.approx(np.linalg.norm(beta @ c_true), rel=1e-10)
        assert beta @ c_true @ beta <= beta @ c_first @ beta * (1 + 1e-12)  # a second brace never softens β_x
        checked += 1
    assert checked >= len(cands) // 2
    for c in cands[:3]:  # the library's stacked model, built directly with the candidate as a frame of its own
        offset = c.fraction * np.asarray(model.jointPlacements[c.joint + 1].translation)
        two = robot.with_point_frame("second", c.link, offset)
        braced = BracedRobot(two, [Brace("brace", Surface(b_1, n_1)), Brace("second", Surface(c.point, n_2))])
        c_e = end_effector_compliance(braced.state(Q), "constrained")
        assert c.Ci_constrained == pytest.approx(compliance_index(c_e, beta), rel=1e-10)
        assert c.k_braced == pytest.approx(frobenius_condition(braced.state(Q).braced_jacobian), rel=1e-10)


def test_a_second_brace_on_the_first_braces_own_point_is_marked_redundant_without_warnings() -> None:
    robot = load_model("paper-robot")
    offset = 0.5 * np.asarray(robot.model.jointPlacements[7].translation)  # the middle of link6: a candidate
    robot = robot.with_point_frame("first", "link6", offset)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        cands = brace_location_study(robot, Q, fixed=[("first", (0, 0, 2))], normal=(0, 0, 1), points_per_link=1)
    own = [c for c in cands if c.link == "link6"]
    assert len(own) == 1 and own[0].redundant and not own[0].unloaded
    assert own[0].Ci_constrained == pytest.approx(own[0].Ci_before, rel=1e-12) and own[0].reduction == pytest.approx(
        0, abs=1e-12
    )
    assert any(not c.redundant and c.reduction is not None and c.reduction > 0.5 for c in cands)  # link10 near the tip


@pytest.mark.parametrize(
    ("kwargs", "error"),
    [
        ({"first_frame": "nosuch"}, FrameNotFoundError),
        ({"first_frame": "tool"}, ContactError),
        ({"first_frame": 3}, InputError),
        ({"first_normal": [0, 0, 0]}, ContactError),
        ({"second_normal": "up"}, ContactError),
        ({"points_per_link": 0}, InputError),
        ({"beta_x": [1, 0, 0]}, InputError),
        ({"q": Q[:3]}, InputError),
    ],
)
def test_pair_study_refuses_bad_arguments_with_one_line_input_errors(kwargs: dict, error: type) -> None:
    args = {"robot": load_model("paper-robot"), "q": Q, "first_frame": "brace", "first_normal": (0, 0, 1), **kwargs}
    args["fixed"] = [(args.pop("first_frame"), args.pop("first_normal"))]
    if "second_normal" in args:
        args["normal"] = args.pop("second_normal")
    with pytest.raises(error) as info:
        brace_location_study(**args)
    assert isinstance(info.value, InputError) and "\n" not in str(info.value)


QS = ",".join(str(v) for v in Q)


def test_study_cli_ranks_second_braces_in_json_and_text(capsys: pytest.CaptureFixture[str]) -> None:
    argv = ["study", "--model", "paper-robot", "--q", QS, "--first-brace", "brace", "--second-normal", "0,-1,0"]
    assert main([*argv, "--points-per-link", "2", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    api = brace_location_study(
        load_model("paper-robot"), Q, fixed=[("brace", (0, 0, 1))], normal=(0, -1, 0), points_per_link=2
    )
    assert [c["Ci_pair"] for c in out["candidates"]] == pytest.approx([c.Ci_constrained for c in api], rel=1e-12)
    assert [c["gain"] for c in out["candidates"]] == pytest.approx([c.reduction for c in api], rel=1e-9, abs=1e-15)
    assert out["first_brace"]["frame"] == "brace" and out["first_brace"]["Ci"] == pytest.approx(api[0].Ci_before)
    assert out["second_normal"] == [0.0, -1.0, 0.0]
    assert main(argv) == 0
    text = capsys.readouterr().out
    assert "first brace 'brace'" in text and "gain" in text and "no load" in text


@pytest.mark.parametrize(
    ("extra", "fragment"),
    [
        (["--first-brace", "nosuch"], "nosuch"),
        (["--first-brace", "brace", "--second-normal", "0,0,0"], "normal"),
        (["--first-brace", "brace", "--normal", "0,0,1"], "--normal"),
        (["--second-normal", "0,-1,0"], "--first-brace"),
        (["--first-normal", "-1,0,0"], "--first-brace"),
        (["--first-brace", "brace", "--first-normal", "up"], "--first-normal"),
    ],
)
def test_study_cli_refuses_bad_pair_flags_with_one_error_line(
    capsys: pytest.CaptureFixture[str], extra: list[str], fragment: str
) -> None:
    assert main(["study", "--model", "paper-robot", "--q", QS, *extra]) == 2
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert captured.out == "" and len(lines) == 1 and lines[0].startswith("bracekit: error:") and fragment in lines[0]


def test_one_study_for_a_brace_alone_keeps_the_paper_s_split_measures() -> None:
    """A set of one brace: n1, the projection model and k of J̃ of the chain split; with a fixed brace: none."""
    robot = load_model("paper-robot")
    alone = brace_location_study(robot, Q, points_per_link=1)
    for c in alone[:3]:
        offset = c.fraction * np.asarray(robot.model.jointPlacements[c.joint + 1].translation)
        braced = BracedRobot(robot.with_point_frame("c", c.link, offset), Brace("c", Surface(c.point, (0, 0, 1))))
        st = braced.state(Q)
        beta = np.array([0.0, 0.0, 1.0, 0.0, 0.0, 0.0])
        assert braced.split.n1 == c.joint and c.redundant is False
        assert c.Ci_projection == pytest.approx(compliance_index(end_effector_compliance(st, "projection"), beta))
        assert c.k_braced == pytest.approx(frobenius_condition(st.split.J_braced), rel=1e-12)
    paired = brace_location_study(robot, Q, fixed=[("brace", (0, 0, 1))], points_per_link=1)
    assert all(c.Ci_projection is None for c in paired)  # the projection model needs one brace's chain split


def test_candidates_added_to_two_fixed_braces_match_a_kkt_solve_with_three_braces() -> None:
    robot = load_model("paper-robot")
    robot = robot.with_point_frame("wall", "link9", np.zeros(3))
    n_1, n_w, n_c = np.array([0.0, 0.0, 1.0]), np.array([0.0, -1.0, 0.0]), np.array([1.0, 0.0, 0.0])
    cands = brace_location_study(robot, Q, fixed=[("brace", n_1), ("wall", n_w)], normal=n_c, points_per_link=2)
    model, data = robot.model, robot.model.createData()
    pin.forwardKinematics(model, data, Q)
    pin.computeJointJacobians(model, data, Q)
    pin.updateFramePlacements(model, data)
    j_e = pin.getFrameJacobian(model, data, robot.tip_id, pin.LOCAL_WORLD_ALIGNED)
    fixed = [
        _point_constraint(
            model, data, model.frames[model.getFrameId(f)].parentJoint, data.oMf[model.getFrameId(f)].translation, n
        )
        for f, n in (("brace", n_1), ("wall", n_w))
    ]
    beta = np.concatenate([n_1, np.zeros(3)])
    c_two = _kkt_compliance(j_e, robot.stiffness, np.column_stack(fixed))
    assert cands[0].Ci_before == pytest.approx(np.linalg.norm(beta @ c_two), rel=1e-10)
    checked = 0
    for c in cands:
        if c.unloaded or c.redundant:
            assert c.Ci_constrained == pytest.approx(c.Ci_before, rel=1e-9)
            continue
        a = np.column_stack([*fixed, _point_constraint(model, data, c.joint, c.point, n_c)])
        assert c.Ci_constrained == pytest.approx(
            np.linalg.norm(beta @ _kkt_compliance(j_e, robot.stiffness, a)), rel=1e-9
        )
        checked += 1
    assert checked >= len(cands) // 2
