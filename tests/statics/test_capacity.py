"""Load capacity against the nonlinear unilateral static solve and brute-force scans of the scale."""

from __future__ import annotations

import numpy as np
import pytest

from bracekit.errors import InputError
from bracekit.model.robot import Robot
from bracekit.statics import (
    capacity_along,
    contact_response,
    effort_limits,
    load_capacity,
    slip_scale,
)
from bracekit.validate.statics import solve_static_equilibrium
from helpers import continuous_chain_urdf

SCAN = np.linspace(0.0, 4.0, 40001)  # step 1e-4


def scan_first_violation(violated) -> float:
    """The first scanned scale at which `violated(s)` holds (inf if none within the scan); s is SCAN[:, None]."""
    bad = np.flatnonzero(violated(SCAN[:, None]))
    return float(SCAN[bad[0]]) if bad.size else np.inf


def test_liftoff_margin_brackets_where_the_unilateral_static_solve_opens(paper) -> None:
    braced, q = paper
    stiff = type(braced)(braced.robot.with_stiffness(1e5), braced.brace)
    robot, surface = stiff.robot, stiff.brace.surface
    r = contact_response(stiff, q, preload=5.0)
    w = -r.contact_gain[2] / np.linalg.norm(r.contact_gain[2]) * 10.0  # pulls b off the table (normal +z)
    s_star = load_capacity(stiff, q, w, preload=5.0).liftoff_margin
    assert 0.0 < s_star < np.inf
    args = (robot.model, q, robot.stiffness, stiff.brace_id, robot.tip_id, surface.point, surface.normal)
    below = solve_static_equilibrium(*args, 0.97 * s_star * w, bilateral=False, preload=5.0)
    above = solve_static_equilibrium(*args, 1.03 * s_star * w, bilateral=False, preload=5.0)
    assert not below.contact_opened and below.contact_force > 0.0
    assert above.contact_opened
    # the nonlinear normal force falls linearly to zero at s_star: it is 3 % of P left at 0.97 s_star
    assert below.contact_force == pytest.approx(0.03 * 5.0, rel=0.05)


def test_liftoff_and_torque_margins_match_scans_of_the_first_order_response(paper) -> None:
    braced, q = paper
    rng = np.random.default_rng(0)
    ws = rng.normal(size=(5, 6)) * np.array([20, 20, 20, 2, 2, 2])
    cap = load_capacity(braced, q, ws, preload=8.0, gravity=True)
    r = contact_response(braced, q, preload=8.0, gravity=True)
    effort = effort_limits(braced.robot)
    for j, w in enumerate(ws):
        lift = scan_first_violation(lambda s, w=w: r.contact_wrench(s * w)[:, 2] < 0.0)
        sat = scan_first_violation(lambda s, w=w: np.any(np.abs(r.torque(s * w)) > effort, axis=1))
        for found, exact in ((lift, cap.liftoff[j]), (sat, cap.torque[j])):
            assert (found == np.inf and exact > SCAN[-1]) or exact <= found <= exact + 1.1e-4
    assert cap.liftoff_margin == np.min(cap.liftoff) and cap.torque_margin == np.min(cap.torque)
    np.testing.assert_allclose(cap.peak_unloaded, np.max(np.abs(r.tau0) / effort))
    np.testing.assert_allclose(cap.peak_loaded, np.max(np.abs(r.torque(ws)) / effort, axis=1))
    np.testing.assert_allclose(cap.normal_force, r.contact_wrench(ws)[:, 2])


def test_slip_margin_matches_a_scan_of_the_coulomb_cone(paper) -> None:
    braced, q = paper
    mu = 0.3
    rng = np.random.default_rng(1)
    ws = rng.normal(size=(6, 6)) * np.array([5, 5, 5, 0.5, 0.5, 0.5])
    cap = load_capacity(braced, q, ws, preload=8.0, friction=mu)
    r = contact_response(braced, q, preload=8.0, friction=mu)
    assert cap.slip is not None
    for j, w in enumerate(ws):

        def slips(s, w=w):
            f = r.contact_wrench(s * w)
            return np.hypot(f[:, 0], f[:, 1]) > mu * f[:, 2]

        found = scan_first_violation(slips)
        assert (found == np.inf and cap.slip[j] > SCAN[-1]) or cap.slip[j] <= found <= cap.slip[j] + 1.1e-4


def test_slip_scale_from_a_loaded_start_matches_a_scan() -> None:
    """The quadratic case: a tangential force already at s = 0, random rates (some in and out of the cone)."""
    rng = np.random.default_rng(2)
    mu = 0.5
    for _ in range(30):
        fn0 = rng.uniform(1.0, 5.0)
        ft0 = np.append(rng.normal(size=2), 0.0)
        ft0 *= rng.uniform(0.0, mu * fn0) / np.linalg.norm(ft0)
        dt, dn = np.append(rng.normal(size=2), 0.0), rng.normal()
        exact = float(slip_scale(ft0, dt, fn0, dn, mu))
        violated = ft0, dt, fn0, dn
        found = scan_first_violation(
            lambda s, v=violated: np.linalg.norm(v[0] + s * v[1], axis=1) > mu * (v[2] + s[:, 0] * v[3]) + 1e-12
        )
        assert (found == np.inf and exact > SCAN[-1]) or exact <= found <= exact + 1.1e-4
    assert slip_scale(np.array([1.0, 0, 0]), np.zeros(3), 1.0, 1.0, 0.5) == 0.0  # outside the cone at s = 0


def test_pulling_from_no_preload_lifts_at_once_and_pressing_never(paper) -> None:
    braced, q = paper
    r = contact_response(braced, q)
    pull = -r.contact_gain[2]
    cap = load_capacity(braced, q, np.array([pull, -pull]))
    assert cap.liftoff[0] == 0.0 and cap.liftoff[1] == np.inf
    assert cap.slip is None and cap.slip_margin is None


def test_capacity_along_a_path_equals_one_configuration_at_a_time(paper, paper_path) -> None:
    braced = paper[0]
    ws = np.array([[0, 0, -10.0, 0, 0, 0], [5.0, 0, 0, 0, 0.5, 0]])
    along = capacity_along(braced, paper_path, ws, preload=5.0, gravity=True, friction=0.4)
    assert along.liftoff.shape == (3, 2) and along.torque_margin.shape == (3,)
    for i, q in enumerate(paper_path):
        one = load_capacity(braced, q, ws, preload=5.0, gravity=True, friction=0.4)
        np.testing.assert_allclose(along.at(i).liftoff, one.liftoff, rtol=1e-10)
        np.testing.assert_allclose(along.at(i).torque, one.torque, rtol=1e-10)
        assert one.slip is not None
        np.testing.assert_allclose(along.at(i).slip, one.slip, rtol=1e-10)


def test_effort_limits_follow_the_chain_order_and_unlimited_joints_are_inf() -> None:
    text, _ = continuous_chain_urdf(4, seed=5, continuous=(2,))
    for i, value in ((1, 11.0), (3, 33.0), (4, 44.0)):
        head = f'<joint name="j{i}" type="revolute">'
        start = text.index(head)
        end = text.index("</joint>", start)
        text = text[:start] + text[start:end].replace('effort="10"', f'effort="{value}"') + text[end:]
    robot = Robot.from_urdf(text, tip="tip")
    assert robot.joint_names == ("j1", "j2", "j3", "j4")
    np.testing.assert_array_equal(effort_limits(robot), [11.0, np.inf, 33.0, 44.0])
    with pytest.raises(InputError, match="effort"):
        effort_limits(robot, [1.0, 2.0, -3.0, 4.0])


def test_bad_wrenches_are_input_errors(paper) -> None:
    braced, q = paper
    with pytest.raises(InputError, match="wrench"):
        load_capacity(braced, q, np.ones((2, 5)))
    with pytest.raises(InputError, match="wrench"):
        load_capacity(braced, q, [[np.nan] * 6])
