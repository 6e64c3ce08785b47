"""Statics with several braces against Pinocchio's rnea, the nonlinear several-contact static solve and scans.

References: ``pin.rnea`` with each contact force as an external force on its joint (τ0), central differences
of :func:`bracekit.validate.statics.solve_statics` with the set points fixed (the response),
bisection of that nonlinear solve for the scale at which a brace's normal force reaches zero (lift-off), and the
one-brace statics of bracekit (one brace's view of the same record).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from bracekit.contact import Brace, Surface
from bracekit.errors import ContactError, InputError
from bracekit.kinematics import BracedRobot
from bracekit.model.shipped import load_model
from bracekit.simulation.holding import (
    Holding,
    holding_measures,
    per_brace_summary,
    relief_summary,
)
from bracekit.statics import actuator_relief, actuator_torques
from bracekit.statics.capacity import capacity_along, effort_limits, load_capacity
from bracekit.statics.relief import PEAK_RTOL
from bracekit.statics.stacked import contact_response, contact_responses
from helpers import solve_planes

Q = np.array([0.0, 0.194, -2.598, 0.0, -0.737, -2.498, -1.898, 3.142, 2.106, 2.438, 0.867])
NORMALS = (np.array([0.3, -0.2, 1.0]), np.array([-1.0, 0.4, 0.2]))


def two_braces(stiffness: float | None = None) -> BracedRobot:
    """The paper robot with a pad on link3 and its own brace frame, each on a plane through {b_i} at Q."""
    robot = load_model("paper-robot").with_point_frames([("pad_a", "link3", (0.05, 0.02, 0.1), None)])
    if stiffness is not None:
        robot = robot.with_stiffness(stiffness)
    probe = BracedRobot(
        robot, [Brace(f, Surface(np.zeros(3), nh)) for f, nh in zip(("pad_a", "brace"), NORMALS, strict=True)]
    )
    points = probe.state(Q).b_i
    return BracedRobot(
        robot, [Brace(f, Surface(b, nh)) for f, b, nh in zip(("pad_a", "brace"), points, NORMALS, strict=True)]
    )


def rnea_with_contacts(braced: BracedRobot, q: np.ndarray, forces: list[np.ndarray]) -> np.ndarray:
    """τ = rnea(q, 0, 0, fext): gravity held against each contact force (world, at b_i) as an external force."""
    model = braced.robot.model
    data = model.createData()
    pin.forwardKinematics(model, data, q)
    pin.updateFramePlacements(model, data)
    fext = [pin.Force.Zero() for _ in range(model.njoints)]
    for fid, f in zip(braced.brace_ids, forces, strict=True):
        b = data.oMf[fid].translation
        joint = model.frames[fid].parentJoint
        world = pin.Force(f, np.cross(b, f))  # the force at b as a spatial force at the world origin
        fext[joint] = fext[joint] + data.oMi[joint].actInv(world)
    return np.asarray(pin.rnea(model, data, q, np.zeros(model.nv), np.zeros(model.nv), fext), dtype=float)


def test_tau0_equals_rnea_with_every_preload_as_an_external_force() -> None:
    braced = two_braces()
    preloads = [7.0, 12.0]
    r = contact_responses(braced, Q, preload=preloads, gravity=True)
    forces = [p * b.surface.normal for p, b in zip(preloads, braced.braces, strict=True)]
    tau_ref = rnea_with_contacts(braced, Q, forces)
    np.testing.assert_allclose(r.tau0[0], tau_ref, atol=1e-10 * np.max(np.abs(tau_ref)))
    np.testing.assert_allclose(r.q_s[0], Q + tau_ref / braced.robot.stiffness, atol=1e-12)
    np.testing.assert_allclose(r.f_c0[0, :, :3], np.array(forces), atol=0.0)


def test_response_matches_central_differences_of_the_nonlinear_several_contact_solve() -> None:
    braced = two_braces()
    preloads, frictions = [5.0, 8.0], [0.5, None]  # brace 0 sticks (3 force rows), brace 1 a frictionless point
    r = contact_responses(braced, Q, preload=preloads, friction=frictions)
    assert [x.shape[1] for x in r.X] == [3, 1]
    robot = braced.robot
    surfaces = [(b.surface.point, b.surface.normal) for b in braced.braces]
    h = 1e-3
    for j in range(6):
        res = []
        for sign in (1.0, -1.0):
            w = np.zeros(6)
            w[j] = sign * h
            res.append(
                solve_planes(
                    robot.model,
                    Q,
                    robot.stiffness,
                    braced.brace_ids,
                    robot.tip_id,
                    surfaces,
                    w,
                    preload=preloads,
                    constraint_wrenches=list(r.X),
                )
            )
        for i in range(2):
            d_f = (res[0].contact_wrenches[i] - res[1].contact_wrenches[i]) / (2 * h)
            np.testing.assert_allclose(r.contact_gain[0, i][:, j], d_f, atol=1e-6 * max(1.0, np.abs(d_f).max()))
        d_q = (res[0].q - res[1].q) / (2 * h)
        np.testing.assert_allclose(r.joint_gain[0][:, j], d_q, atol=1e-8 + 1e-6 * np.abs(d_q).max())
        np.testing.assert_allclose(r.torque_gain[0][:, j], -robot.stiffness * d_q, atol=1e-5)


@pytest.mark.parametrize(
    ("contact", "k_env", "friction"),
    [("frictionless_point", None, 0.4), ("soft_finger", None, None), ("frictionless_point", 2e4, None)],
)
def test_one_brace_given_as_a_list_of_one_gives_the_one_brace_numbers(chain, contact, k_env, friction) -> None:
    braced, q = chain(contact=contact, k_env=k_env)
    qs = np.array([q, q + 0.0])
    kw = {"gravity": True, "geometric": True}
    one = contact_responses(braced, qs, preload=3.0, friction=friction, **kw)
    many = contact_responses(braced, qs, preload=[3.0], friction=[friction], **kw)
    for a, b in ((one.contact_gain, many.contact_gain), (one.torque_gain, many.torque_gain), (one.q_s, many.q_s)):
        np.testing.assert_array_equal(a, b)
    view = contact_response(braced, q, preload=3.0, friction=friction, **kw)  # one brace's record
    assert view.f_c0.shape == (6,) and view.preload == 3.0 and view.friction == friction
    np.testing.assert_allclose(view.contact_gain, one.contact_gain[0, 0], rtol=0, atol=0)
    np.testing.assert_allclose(view.torque_gain, one.torque_gain[0], rtol=0, atol=0)
    ws = np.random.default_rng(5).normal(size=(4, 6)) * 5.0
    e = np.full(braced.robot.n, 30.0)
    cm = capacity_along(braced, qs, ws, preload=[3.0], friction=[friction], effort=e, **kw)
    c1 = load_capacity(braced, q, ws, preload=3.0, friction=friction, effort=e, **kw)
    np.testing.assert_array_equal(cm.liftoff[0], c1.liftoff)  # the least over one brace is that brace's
    np.testing.assert_array_equal(cm.brace_liftoff[0, 0], c1.liftoff)
    np.testing.assert_array_equal(cm.torque[0], c1.torque)
    assert cm.liftoff_margin[0] == c1.liftoff_margin
    if friction is not None:
        assert cm.slip is not None and c1.slip is not None
        np.testing.assert_array_equal(cm.slip[0], c1.slip)
    else:
        assert cm.slip is None and cm.slip_margin is None and c1.slip is None


def test_one_brace_records_of_several_braces_name_the_brace() -> None:
    braced = two_braces()
    r = contact_responses(braced, Q, preload=[7.0, 12.0])
    with pytest.raises(ContactError, match="name one with brace"):
        contact_response(braced, Q, preload=[7.0, 12.0])
    second = contact_response(braced, Q, preload=[7.0, 12.0], brace=1)
    np.testing.assert_array_equal(second.f_c0, r.f_c0[0, 1])
    w = np.array([1.0, -2.0, -5.0, 0.1, 0.0, 0.2])
    np.testing.assert_allclose(second.contact_wrench(w), r.f_c0[0, 1] + r.contact_gain[0, 1] @ w, rtol=1e-14)
    with pytest.raises(InputError, match="brace must be an index"):
        contact_response(braced, Q, brace=2)


def test_liftoff_scale_of_a_brace_matches_a_bisection_of_the_nonlinear_solve() -> None:
    braced = two_braces(stiffness=1e5)  # stiff joints: the first-order response is close to the exact one
    robot = braced.robot
    preloads = [5.0, 9.0]
    r = contact_responses(braced, Q, preload=preloads)
    nhat0 = braced.braces[0].surface.normal
    w = -(nhat0 @ r.contact_gain[0, 0, :3]) * 10.0 / np.linalg.norm(nhat0 @ r.contact_gain[0, 0, :3])
    cap = capacity_along(braced, Q, w, preload=preloads)
    s_star = float(cap.brace_liftoff[0, 0, 0])
    assert 0.0 < s_star < np.inf
    assert cap.liftoff_margin[0] == pytest.approx(min(s_star, float(cap.brace_liftoff[0, 1, 0])))
    surfaces = [(b.surface.point, b.surface.normal) for b in braced.braces]

    def normal_force(s: float) -> float:
        res = solve_planes(
            robot.model, Q, robot.stiffness, braced.brace_ids, robot.tip_id, surfaces, s * w, preload=preloads
        )
        return float(res.contact_forces[0])

    lo, hi = 0.0, 2.0 * s_star
    assert normal_force(lo) > 0.0 > normal_force(hi)
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if normal_force(mid) > 0.0 else (lo, mid)
    assert s_star == pytest.approx(0.5 * (lo + hi), rel=1e-3)


def test_holding_measures_with_two_braces_are_the_least_over_braces_and_loads() -> None:
    braced = two_braces()
    loads = np.array([[0.0, 0.0, -20.0, 0.0, 0.0, 0.0], [10.0, 5.0, 0.0, 0.0, 1.0, 0.0]])
    holding = Holding(gravity=True, wrenches=loads, preloads=(6.0, 10.0), frictions=(0.6, None))
    qs = np.array([Q, Q])
    m = holding_measures(braced, qs, holding, True)
    per_brace = {f"{k}_{i}" for k in ("liftoff_margin", "slip_margin") for i in range(2)}
    plain = {"torque_ratio", "torque_ratio_loaded", "contact_force_N", "liftoff_margin", "slip_margin"}
    assert plain | {"torque_margin", "unstable"} | per_brace <= set(m)
    np.testing.assert_allclose(m["slip_margin"], np.minimum(m["slip_margin_0"], m["slip_margin_1"]))
    cap = capacity_along(
        braced, qs, loads, preload=[6.0, 10.0], gravity=True, friction=[0.6, None], effort=effort_limits(braced.robot)
    )
    np.testing.assert_allclose(m["liftoff_margin"], np.min(cap.brace_liftoff, axis=(1, 2)))
    np.testing.assert_allclose(m["liftoff_margin"], np.minimum(m["liftoff_margin_0"], m["liftoff_margin_1"]))
    assert cap.brace_slip is not None
    np.testing.assert_allclose(m["slip_margin_0"], np.min(cap.brace_slip[:, 0], axis=1))
    assert np.all(np.isinf(m["slip_margin_1"]))
    np.testing.assert_allclose(m["torque_margin"], np.min(cap.torque, axis=1))
    assert np.all(m["unstable"] == 0.0)
    summary = per_brace_summary(m, 2)
    assert summary[0]["min_liftoff_margin"] == pytest.approx(float(np.min(m["liftoff_margin_0"])))
    assert summary[1]["min_slip_margin"] is None


def test_wrong_number_of_per_brace_values_is_an_input_error() -> None:
    braced = two_braces()
    with pytest.raises(InputError, match="for each of the 2 braces"):
        contact_responses(braced, Q, preload=[1.0, 2.0, 3.0])
    with pytest.raises(InputError, match="one preload per brace"):
        holding_measures(braced, Q[None, :], Holding(preloads=(1.0,)), True)


def test_free_space_run_and_relief_with_two_braces_against_rnea() -> None:
    braced = two_braces()
    w = np.array([0.0, 0.0, -10.0, 0.0, 0.0, 0.0])
    holding = Holding(gravity=True, wrenches=w[None, :], preloads=(6.0, 10.0))
    e = effort_limits(braced.robot)
    free = holding_measures(braced, Q[None, :], holding, False)
    j_e = braced.state(Q).J_e
    tau_free = rnea_with_contacts(braced, Q, [np.zeros(3), np.zeros(3)]) - j_e.T @ w
    np.testing.assert_allclose(free["torque_ratio_loaded"][0], np.max(np.abs(tau_free) / e), rtol=1e-12)
    forces = [p * b.surface.normal for p, b in zip((6.0, 10.0), braced.braces, strict=True)]
    tau_braced = rnea_with_contacts(braced, Q, forces) - j_e.T @ w
    rel = relief_summary(braced, Q[None, :], holding)
    assert rel["free_peak_torque_ratio"] == pytest.approx(np.max(np.abs(tau_free) / e), rel=1e-12)
    assert rel["braced_peak_torque_ratio"] == pytest.approx(np.max(np.abs(tau_braced) / e), rel=1e-12)
    best = rel["best_preload_N"]
    assert isinstance(best, list) and len(best) == 2 and min(best) >= 0.0
    assert rel["best_braced_peak_torque_ratio"] <= rel["free_peak_torque_ratio"] + 1e-12


def test_relief_lp_of_two_braces_matches_a_brute_force_scan_of_both_preloads() -> None:
    braced = two_braces()
    qs = np.array([Q, Q + 0.03, Q - 0.03])
    w = np.array([[0.0, 0.0, -40.0, 0.0, 0.0, 0.0], [20.0, 0.0, 0.0, 0.0, 2.0, 0.0]])
    e = effort_limits(braced.robot)
    relief = actuator_relief(braced, qs, w, gravity=True)
    assert relief.preloads.shape == (2,)
    tau, a = actuator_torques(braced, qs, w, gravity=True)
    # the torques against rnea with each preload as an external force at its b_i
    forces = [2.0 * b.surface.normal for b in braced.braces]
    ref = rnea_with_contacts(braced, qs[0], forces) - braced.state(qs[0]).J_e.T @ w[0]
    np.testing.assert_allclose(tau[0, 0] - 2.0 * a[0].sum(axis=0), ref, atol=1e-10 * np.abs(ref).max())
    top = 3.0 * max(float(relief.preloads.max()), 20.0)
    grid = np.linspace(0.0, top, 301)
    best = min(float(np.max(np.abs(tau - (p1 * a[:, 0] + p2 * a[:, 1])[:, None, :]) / e)) for p1 in grid for p2 in grid)
    assert relief.braced_peak <= best * (1.0 + PEAK_RTOL) + 1e-12  # the LP is at least as good as the grid
    assert relief.braced_peak >= best - 2.0 * (grid[1] - grid[0]) * float(np.max(np.abs(a) / e))  # …and near it
    free = float(np.max(np.abs(tau) / e))
    assert relief.free_peak == pytest.approx(free, rel=1e-12) and relief.braced_peak <= free
