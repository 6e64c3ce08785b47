"""Task spaces that leave redundancy on a 7-joint arm braced with a frictionless point.

An iiwa-like arm (axes z, y, z, y, z, y, z; offsets 0.36, 0.42, 0.4, 0.126 m) braces a point of its forearm
(link 4) on a horizontal plane: n1 = 4, n2 = 3, l = 3 braced coordinates of chain 1 (the contact removes
one of its four DOF). A full pose (6 rows) takes all 6 braced coordinates: no redundancy; the position
(3 rows) leaves 3, position + tool axis (5 rows) leaves 1. References: Pinocchio's own frame Jacobians and
placements, recomputed at every recorded sample.
"""

from __future__ import annotations

import tomllib
import warnings

import numpy as np
import pinocchio as pin
import pytest

from bracekit import (
    Brace,
    BracedGradientProjection,
    BracedMinNorm,
    BracedRobot,
    ComplianceIndex,
    ConditionNumber,
    FreeSpaceMinNorm,
    InputError,
    Line,
    Objective,
    Robot,
    Surface,
    TaskSpace,
    simulate,
)
from bracekit.contact import contact_type
from bracekit.errors import NoRedundancyWarning, ScenarioError
from bracekit.resolution.fused import GradientProjectionStep, numba_available
from bracekit.simulation.scenario import parse_scenario
from helpers import pin_frame_jacobian, pin_frame_placement, random_chain_urdf, scenario_text

Q0 = np.array([0.1, 0.9, 0.1, -1.4, 0.2, 0.9, 0.3])
BETA = np.array([0.0, 0.0, 1.0, 0.0, 0.0, 0.0])  # along the surface normal
DT = 0.05


def iiwa_urdf() -> str:
    """An iiwa-like 7-joint arm; the brace point sits on the forearm (link 4), 0.2 m past joint 4."""
    joints = [("0 0 1", 0.36), ("0 1 0", 0.0), ("0 0 1", 0.42), ("0 1 0", 0.0), ("0 0 1", 0.4), ("0 1 0", 0.0)]
    joints.append(("0 0 1", 0.0))
    parts = ['<robot name="iiwa_like">', '<link name="base"/>']
    parent = "base"
    for i, (axis, dz) in enumerate(joints, 1):
        parts.append(f'<link name="l{i}"/>')
        parts.append(
            f'<joint name="j{i}" type="revolute"><parent link="{parent}"/><child link="l{i}"/>'
            f'<origin xyz="0 0 {dz}"/><axis xyz="{axis}"/>'
            '<limit lower="-2.9" upper="2.9" effort="100" velocity="1.5"/></joint>'
        )
        parent = f"l{i}"
    parts.append(
        '<link name="tip"/><joint name="tip_joint" type="fixed"><parent link="l7"/><child link="tip"/>'
        '<origin xyz="0 0 0.126"/></joint>'
    )
    parts.append(
        '<link name="brace"/><joint name="brace_joint" type="fixed"><parent link="l4"/><child link="brace"/>'
        '<origin xyz="0 0 0.2" rpy="3.14159 0 0"/></joint>'
    )
    parts.append("</robot>")
    return "\n".join(parts)


def braced_at(urdf: str, q0: np.ndarray) -> BracedRobot:
    """The robot braced with a frictionless point on the horizontal plane through {b} at q0."""
    robot = Robot.from_urdf(urdf, tip="tip")
    b = pin_frame_placement(robot.model, "brace", q0).translation
    brace = Brace(frame="brace", surface=Surface(b, [0.0, 0.0, 1.0]), contact=contact_type("frictionless_point"))
    return BracedRobot(robot, brace)


@pytest.fixture(scope="module")
def arm() -> tuple[BracedRobot, Line]:
    braced = braced_at(iiwa_urdf(), Q0)
    e0 = pin_frame_placement(braced.robot.model, "tip", Q0).translation
    return braced, Line(e0, e0 + np.array([0.0, 0.08, 0.0]), 2.0)


def _objective() -> Objective:
    return Objective([ComplianceIndex(BETA, "constrained")], [100.0])


def _run(braced: BracedRobot, strategy, task):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        tr = simulate(braced, strategy, task, Q0, DT, lambda t: BETA)
    assert tr.completed, tr.failure
    return tr, caught


def _on_task_and_contact(braced: BracedRobot, tr, task, space: TaskSpace) -> None:
    """Every sample, recomputed by Pinocchio: selected task rows ≤ 1e-9, {b} on the plane ≤ 1e-9 m."""
    model, surface = braced.robot.model, braced.brace.surface
    r0 = pin_frame_placement(model, "tip", Q0).rotation
    for q, t in zip(tr.q, tr.t, strict=True):
        tip = pin_frame_placement(model, "tip", q)
        assert np.linalg.norm(tip.translation - task.position(t)) <= 1e-9
        assert abs(surface.normal @ (pin_frame_placement(model, "brace", q).translation - surface.point)) <= 1e-9
        if space.kind == "pose":
            assert np.linalg.norm(pin.log3(r0 @ tip.rotation.T)) <= 1e-9
        if space.kind == "position+axis":
            assert (tip.rotation @ space.axis) @ (r0 @ space.axis) >= 1.0 - 1e-9


def test_selection_matrices_pick_the_rows_of_each_space() -> None:
    rot = pin.exp3(np.array([0.3, -0.5, 0.9]))
    assert np.array_equal(TaskSpace().selection(rot), np.eye(6))
    assert np.array_equal(TaskSpace("position").selection(rot), np.eye(6)[:3])
    space = TaskSpace("position+axis", [1.0, 2.0, 2.0])
    s = space.selection(rot)
    a = rot @ np.array([1.0, 2.0, 2.0]) / 3.0
    assert s.shape == (5, 6)
    assert np.allclose(s @ s.T, np.eye(5), atol=1e-15)
    assert np.array_equal(s[:3], np.eye(6)[:3])
    assert np.allclose(s[3:, 3:] @ a, 0.0, atol=1e-15)  # rotation about the world tool axis is free
    assert np.array_equal(TaskSpace("position+axis").axis, [0.0, 0.0, 1.0])  # the tip's z by default


@pytest.mark.parametrize(
    "kwargs",
    [{"kind": "orientation"}, {"kind": "position", "axis": [0, 0, 1]}, {"kind": "position+axis", "axis": [0, 0, 0]}],
)
def test_bad_task_spaces_are_input_errors(kwargs) -> None:
    with pytest.raises(InputError):
        TaskSpace(**kwargs)


def test_pose_space_leaves_no_redundancy_and_gradient_projection_warns(arm) -> None:
    braced, task = arm
    mn, _ = _run(braced, BracedMinNorm(), task)
    gp, caught = _run(braced, BracedGradientProjection(_objective()), task)
    assert mn.redundancy == gp.redundancy == 0 and gp.task_space == "pose"
    assert [w for w in caught if issubclass(w.category, NoRedundancyWarning)]
    assert any("no redundancy" in note for note in gp.warnings)
    assert gp.summary()["redundancy"] == 0 and gp.summary()["task_space"] == "pose"
    assert np.max(np.abs(gp.q - mn.q)) < 1e-10  # gradient projection cannot act
    free, _ = _run(braced, FreeSpaceMinNorm(), task)
    assert free.redundancy == 1  # 7 − rank(J)


def test_position_space_gradient_projection_lowers_mean_compliance_index(arm) -> None:
    braced, task = arm
    space = TaskSpace("position")
    mn, _ = _run(braced, BracedMinNorm(space=space), task)
    gp, caught = _run(braced, BracedGradientProjection(_objective(), space=space), task)
    assert mn.redundancy == gp.redundancy == 3  # 7 − 1 − 3
    assert not [w for w in caught if issubclass(w.category, NoRedundancyWarning)]
    assert np.max(np.abs(gp.q - mn.q)) > 1e-2
    ci_gp, ci_mn = gp.summary()["Ci_mean"], mn.summary()["Ci_mean"]
    assert ci_gp < 0.97 * ci_mn  # observed 3.02e-4 vs 3.18e-4 m/N
    for tr in (mn, gp):
        _on_task_and_contact(braced, tr, task, space)
        assert tr.summary()["task_space"] == "position"
    free, _ = _run(braced, FreeSpaceMinNorm(space=space), task)
    assert free.redundancy == 4  # 7 − 3


def test_position_axis_space_keeps_the_tool_axis_and_rotates_about_it(arm) -> None:
    braced, task = arm
    space = TaskSpace("position+axis", [1.0, 0.0, 0.0])
    objective = Objective([ComplianceIndex(BETA, "constrained"), ConditionNumber()], [100.0, 0.5])
    r0 = pin_frame_placement(braced.robot.model, "tip", Q0).rotation
    for strategy in (BracedMinNorm(space=space), BracedGradientProjection(objective, space=space)):
        tr, _ = _run(braced, strategy, task)
        assert tr.redundancy == 1  # 7 − 1 − 5
        _on_task_and_contact(braced, tr, task, space)
        r_end = pin_frame_placement(braced.robot.model, "tip", tr.q[-1]).rotation
        turn = pin.log3(r_end @ r0.T)
        assert np.linalg.norm(turn) > 0.05  # the tip turned, about the tool axis only
        assert np.linalg.norm(np.cross(turn, r0 @ space.axis)) < 1e-6


def _kinematics(braced: BracedRobot, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    model = braced.robot.model
    return (
        pin_frame_jacobian(model, "tip", q),
        pin_frame_jacobian(model, "brace", q),
        pin_frame_placement(model, "tip", q).rotation,
    )


@pytest.mark.parametrize("kind", ["pose", "position", "position+axis"])
def test_resolved_velocities_realise_the_selected_rows(arm, kind: str) -> None:
    braced, _ = arm
    space = TaskSpace(kind)
    rng = np.random.default_rng(3)
    strategies = [FreeSpaceMinNorm(space=space), BracedMinNorm(space=space)]
    strategies.append(BracedGradientProjection(_objective(), space=space))
    for _ in range(3):
        q = Q0 + rng.uniform(-0.1, 0.1, 7)
        xdot = rng.normal(size=6)
        je, jb, r_e = _kinematics(braced, q)
        s = np.eye(6) if kind == "pose" else np.eye(6)[:3] if kind == "position" else None
        if s is None:  # the two directions perpendicular to the world tool axis, built here independently
            a = r_e[:, 2]
            u = np.linalg.svd(a[None, :])[2][1:]
            s = np.zeros((5, 6))
            s[:3, :3], s[3:, 3:] = np.eye(3), u
        state = braced.state(q, hessians=True)
        for strategy in strategies:
            qdot = strategy.velocity(state, xdot)
            assert np.allclose(s @ je @ qdot, s @ xdot, rtol=0, atol=1e-10)
            if strategy.braced:
                assert abs(braced.brace.surface.normal @ (jb[:3] @ qdot)) < 1e-10


@pytest.mark.parametrize("kind", ["pose", "position", "position+axis"])
@pytest.mark.parametrize("backend", ["numpy", "numba"])
def test_fused_step_equals_the_reference_for_every_space(kind: str, backend: str) -> None:
    if backend == "numba" and not numba_available():
        pytest.skip("numba is not installed")
    q0 = np.array([0.4, -0.7, 0.9, 1.1, -0.5, 0.8, 0.3])
    braced = braced_at(random_chain_urdf(7, seed=4, brace_link=4), q0)
    space = TaskSpace(kind)
    objective = Objective([ConditionNumber(), ComplianceIndex(BETA, "constrained")], [0.5, 100.0])
    strategy = BracedGradientProjection(objective, space=space)
    step = GradientProjectionStep(braced, strategy, backend=backend)  # type: ignore[arg-type]
    rng = np.random.default_rng(9)
    for _ in range(4):
        q = q0 + rng.uniform(-0.2, 0.2, 7)
        xdot = rng.normal(size=6)
        ref = strategy.velocity(braced.state(q, hessians=True), xdot)
        got = step(q, xdot)
        assert np.allclose(got, ref, rtol=1e-10, atol=1e-12 * np.max(np.abs(ref)))
        if kind == "pose":
            assert np.array_equal(got, step(q, xdot))


def _scenario(**task_keys: object):
    data = tomllib.loads(scenario_text())
    data["task"].update(task_keys)
    return parse_scenario(data)


def test_scenario_task_space_keys() -> None:
    assert _scenario().task_space.kind == "pose"
    sc = _scenario(space="position+axis", axis=[0.0, 2.0, 0.0])
    assert sc.task_space.kind == "position+axis" and np.array_equal(sc.task_space.axis, [0.0, 1.0, 0.0])
    for name in ("free_space_min_norm", "braced_min_norm", "braced_gradient_projection"):
        assert sc.strategy(name).space is sc.task_space  # type: ignore[attr-defined]
    assert np.array_equal(_scenario(space="position+axis").task_space.axis, [0.0, 0.0, 1.0])


@pytest.mark.parametrize(
    ("keys", "named"),
    [
        ({"space": "orientation"}, "'task.space'"),
        ({"space": 3}, "'task.space'"),
        ({"axis": [0.0, 0.0, 1.0]}, "'task.axis'"),
        ({"space": "position", "axis": [0.0, 0.0, 1.0]}, "'task.axis'"),
        ({"space": "position+axis", "axis": [0.0, 1.0]}, "'task.axis'"),
        ({"space": "position+axis", "axis": [0.0, 0.0, 0.0]}, "'task.axis'"),
        ({"space": "position+axis", "axis": "z"}, "'task.axis'"),
    ],
)
def test_scenario_task_space_mistakes_name_the_key(keys: dict[str, object], named: str) -> None:
    with pytest.raises(ScenarioError, match=named):
        _scenario(**keys)


@pytest.mark.parametrize("kind", ["position", "position+axis"])
def test_correction_holds_the_selected_rows_only(arm, kind: str) -> None:
    from bracekit.simulation.simulate import correct

    braced, _ = arm
    space = TaskSpace(kind)
    model = braced.robot.model
    start = pin_frame_placement(model, "tip", Q0)
    b0 = pin_frame_placement(model, "brace", Q0)
    target_p = start.translation + np.array([0.01, -0.02, 0.005])
    target_r = pin.exp3(np.array([0.05, -0.04, 0.03])) @ start.rotation  # the pose correction would reach it
    q = Q0 + np.array([0.01, -0.02, 0.015, 0.01, -0.01, 0.02, -0.03])
    st = correct(braced, q, target_p, target_r, [(b0.translation, b0.rotation)], space=space)
    tip = pin_frame_placement(model, "tip", st.q)
    assert np.linalg.norm(tip.translation - target_p) <= 1e-9
    surface = braced.brace.surface
    assert abs(surface.normal @ (pin_frame_placement(model, "brace", st.q).translation - surface.point)) <= 1e-9
    if kind == "position+axis":
        assert (tip.rotation[:, 2]) @ (target_r[:, 2]) >= 1.0 - 1e-12
    # a free row is left free: the orientation is not pulled onto the target
    assert np.linalg.norm(pin.log3(target_r @ tip.rotation.T)) > 1e-3
    pose = correct(braced, q, target_p, target_r, [(b0.translation, b0.rotation)])
    assert np.linalg.norm(pin.log3(target_r @ pose.R_e.T)) < 1e-9
    assert np.linalg.norm(st.q - q) < np.linalg.norm(pose.q - q)  # fewer rows, a smaller correction
