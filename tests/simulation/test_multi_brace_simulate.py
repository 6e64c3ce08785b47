"""Tests of runs with several braces (bracekit.simulation.simulate with len(braced.braces) > 1).

References: every contact, the tip and C_i are recomputed from the run's joint values with Pinocchio models
built independently (helpers.pin_frame_placement / pin_frame_jacobian, a fresh Data), C_e from the bordered
Lagrange system [[K, −Gᵀ], [G, 0]].
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from bracekit.contact import Brace, Surface
from bracekit.kinematics import BracedRobot
from bracekit.model.robot import Robot
from bracekit.model.shipped import load_model
from bracekit.objective import ComplianceIndex, Objective, RegionBarrier
from bracekit.resolution import BracedGradientProjection, BracedMinNorm, TaskSpace
from bracekit.simulation.simulate import simulate, solve_start
from bracekit.simulation.tasks import Line
from helpers import pin_frame_jacobian, pin_frame_placement, random_chain_urdf, random_unit

PAPER_GUESS = np.array([0.0, 0.194, -2.598, 0.0, -0.737, -2.498, -1.898, 3.142, 2.106, 2.438, 0.867])
RADIAL = np.array([1.0, 0.0, 0.0, 0.0, 0.0, 0.0])


def several_objective(braced: BracedRobot, w_ci: float, w_d: float) -> Objective:
    """w_Ci C_i (radial β_x) + w_d Σ_i d_i over the braces with a region."""
    terms: list = [ComplianceIndex(RADIAL)]
    for i, b in enumerate(braced.braces):
        if w_d and b.region_radius is not None:
            terms.append(RegionBarrier(b.region_radius, b.surface.point, name=f"d_{i}", brace=i))
    return Objective(terms, [w_ci] + [w_d] * (len(terms) - 1))


def paper_two_braces() -> BracedRobot:
    """The paper's pad on the table and a point of the HEBI link `link9` on a wall (normal −y)."""
    robot = load_model("paper-robot").with_stiffness(170.0)
    robot = robot.with_point_frames([("pad", "link9", (0.0, 0.0, 0.0), None)])
    table = Brace("brace", Surface([0.70, -0.15, -0.30], [0, 0, 1]), contact="frictionless_point", region_radius=0.15)
    wall = Brace(
        "pad",
        Surface([1.02, 0.0098, -0.29], [0, -1, 0]),
        contact="frictionless_point",
        region_radius=0.15,
        pad_axis=False,
    )
    return BracedRobot(robot, [table, wall])


def contact_distances(braced: BracedRobot, q: np.ndarray) -> np.ndarray:
    """|distance| (m) of each brace frame from its plane, from an independent Pinocchio evaluation."""
    return np.array(
        [
            abs(b.surface.normal @ (pin_frame_placement(braced.robot.model, b.frame, q).translation - b.surface.point))
            for b in braced.braces
        ]
    )


def reference_ci(braced: BracedRobot, q: np.ndarray, beta: np.ndarray) -> float:
    """‖βᵀ C_e‖ with C_e from the bordered system of the rigid contacts."""
    model, k = braced.robot.model, braced.robot.stiffness
    g = np.vstack([b.X().T @ pin_frame_jacobian(model, b.frame, q) for b in braced.braces])
    j_e = pin_frame_jacobian(model, braced.robot.tip, q)
    n, c = q.size, g.shape[0]
    c_e = (
        j_e
        @ np.linalg.solve(np.block([[np.diag(k), -g.T], [g, np.zeros((c, c))]]), np.vstack([j_e.T, np.zeros((c, 6))]))[
            :n
        ]
    )
    return float(np.linalg.norm(beta @ c_e))


@pytest.fixture(scope="module")
def paper_start() -> tuple[BracedRobot, np.ndarray]:
    braced = paper_two_braces()
    st = solve_start(braced, [1.34, -0.32, -0.17], PAPER_GUESS)
    return braced, st.q


def test_the_several_brace_start_puts_the_tip_on_target_and_every_brace_on_its_plane(paper_start) -> None:
    braced, q = paper_start
    tip = pin_frame_placement(braced.robot.model, braced.robot.tip, q).translation
    np.testing.assert_allclose(tip, [1.34, -0.32, -0.17], atol=1e-9)
    assert np.all(contact_distances(braced, q) <= 1e-9)


@pytest.mark.parametrize("space", [TaskSpace("pose"), TaskSpace("position")])
def test_a_line_task_with_two_braces_keeps_every_contact_and_the_task(paper_start, space) -> None:
    braced, q0 = paper_start
    e0 = pin_frame_placement(braced.robot.model, braced.robot.tip, q0)
    task = Line(e0.translation, e0.translation + np.array([0.0, 0.0, 0.05]), 1.0)
    run = simulate(braced, BracedMinNorm(space=space), task, q0, 0.05, lambda t: RADIAL)
    assert run.completed, run.failure
    assert run.steps == 20
    for t, q in zip(run.t, run.q, strict=True):
        assert np.all(contact_distances(braced, q) <= 1e-9)
        tip = pin_frame_placement(braced.robot.model, braced.robot.tip, q)
        np.testing.assert_allclose(tip.translation, task.position(t), atol=1e-9)
        if space.is_pose:
            assert np.linalg.norm(pin.log3(e0.rotation @ tip.rotation.T)) <= 1e-9
    summary = run.summary()
    assert [set(b) for b in summary["braces"]] == [{"max_contact_violation_m", "max_region_radius_m"}] * 2
    for i in range(2):
        assert summary["braces"][i]["max_contact_violation_m"] <= 1e-9
        radii = [
            np.linalg.norm(
                pin_frame_placement(braced.robot.model, braced.braces[i].frame, q).translation
                - braced.braces[i].surface.point
            )
            for q in run.q
        ]
        assert summary["braces"][i]["max_region_radius_m"] == pytest.approx(max(radii), abs=1e-12)
    assert summary["max_region_radius_m"] == max(b["max_region_radius_m"] for b in summary["braces"])
    ci = run.measures["Ci_constrained"]
    for j in (0, len(ci) - 1):
        assert ci[j] == pytest.approx(reference_ci(braced, run.q[j], RADIAL), rel=1e-9)
    assert "Ci_projection" not in run.measures and run.summary("projection")["Ci_mean"] is None
    assert run.redundancy == 11 - 2 - space.rows


def test_gradient_projection_lowers_the_mean_constrained_compliance_index_against_braced_min_norm(paper_start) -> None:
    braced, q0 = paper_start
    e0 = pin_frame_placement(braced.robot.model, braced.robot.tip, q0).translation
    task = Line(e0, e0 + np.array([0.0, 0.0, 0.05]), 1.0)
    space = TaskSpace("position")
    mn = simulate(braced, BracedMinNorm(space=space), task, q0, 0.05, lambda t: RADIAL)
    gp = simulate(
        braced,
        BracedGradientProjection(several_objective(braced, 100.0, 0.01), space=space),
        task,
        q0,
        0.05,
        lambda t: RADIAL,
    )
    assert mn.completed and gp.completed, (mn.failure, gp.failure)
    assert gp.summary()["Ci_mean"] < 0.97 * mn.summary()["Ci_mean"]
    assert max(b["max_contact_violation_m"] for b in gp.summary()["braces"]) <= 1e-9
    assert max(b["max_region_radius_m"] for b in gp.summary()["braces"]) < 0.15


def test_a_random_chain_with_a_sticking_and_a_sliding_brace_keeps_both_contacts() -> None:
    rng = np.random.default_rng(21)
    n = 10
    robot = Robot.from_urdf(random_chain_urdf(n, seed=21, brace_link=3), tip="tip")
    robot = robot.with_point_frames([("pad", "l6", (0.03, -0.02, 0.05), None)]).with_stiffness(rng.uniform(50, 500, n))
    q0 = rng.uniform(-2.0, 2.0, n)
    braces = []
    for frame, contact in (("brace", "point_with_friction"), ("pad", "frictionless_point")):
        b = pin_frame_placement(robot.model, frame, q0).translation
        braces.append(Brace(frame, Surface(b, random_unit(rng)), contact=contact, pad_axis=False))
    braced = BracedRobot(robot, braces)
    e0 = pin_frame_placement(robot.model, "tip", q0).translation
    task = Line(e0, e0 + 0.03 * random_unit(rng), 0.5)
    stuck = pin_frame_placement(robot.model, "brace", q0).translation
    for strategy in (
        BracedMinNorm(space=TaskSpace("position")),
        BracedGradientProjection(several_objective(braced, 1.0, 0.0), alpha=-0.2, space=TaskSpace("position")),
    ):
        run = simulate(braced, strategy, task, q0, 0.05, lambda t: RADIAL)
        assert run.completed, run.failure
        for t, q in zip(run.t, run.q, strict=True):
            assert np.all(contact_distances(braced, q) <= 1e-9)
            np.testing.assert_allclose(pin_frame_placement(robot.model, "brace", q).translation, stuck, atol=1e-9)
            np.testing.assert_allclose(
                pin_frame_placement(robot.model, "tip", q).translation, task.position(t), atol=1e-9
            )


def test_any_braced_strategy_runs_with_several_braces_over_the_state_s_braced_motions(paper_start) -> None:
    # a strategy of the user's own (not a bracekit class): the loop calls its velocity for any brace count
    braced, q0 = paper_start

    class Other:
        name = "other"
        braced = True
        needs_hessians = False
        space = TaskSpace("position")

        def velocity(self, state, xdot):
            motions = state.motions  # q̇ = N y keeps every contact; the task rows by least squares
            a = motions.A[:3]
            return motions.to_joint(np.linalg.lstsq(a, xdot[:3], rcond=None)[0])

    e0 = pin_frame_placement(braced.robot.model, braced.robot.tip, q0).translation
    task = Line(e0, e0 + np.array([0.0, 0.0, 0.02]), 1.0)
    run = simulate(braced, Other(), task, q0, 0.1, lambda t: RADIAL)
    assert run.completed, run.failure
    for t, q in zip(run.t, run.q, strict=True):
        assert np.all(contact_distances(braced, q) <= 1e-9)  # independent: Pinocchio placements of each {b_i}
        tip = pin_frame_placement(braced.robot.model, braced.robot.tip, q).translation
        np.testing.assert_allclose(tip, task.position(t), atol=1e-9)
