"""Actuator relief: the LP's preload against a brute-force scan, the torques against Pinocchio's RNEA."""

from __future__ import annotations

import importlib

import numpy as np
import pinocchio as pin
import pytest
import scipy.optimize

from bracekit.errors import InputError, NumericalError
from bracekit.statics import actuator_relief, actuator_torques, effort_limits
from bracekit.statics.relief import PEAK_RTOL

WRENCHES = np.array([[0.0, 0.0, -30.0, 0.0, 0.0, 0.0], [15.0, 0.0, 0.0, 0.0, 2.0, 0.0]])


def test_free_space_torques_match_rnea_with_the_tool_wrench_as_external_force(paper) -> None:
    braced, q = paper
    tau, _ = actuator_torques(braced, q, WRENCHES, gravity=True)
    model = braced.robot.model
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    tip = braced.robot.tip_id
    joint = model.frames[tip].parentJoint
    e = data.oMf[tip].translation
    for j, w in enumerate(WRENCHES):
        fext = pin.StdVec_Force()
        for _ in range(model.njoints):
            fext.append(pin.Force.Zero())
        fext[joint] = data.oMi[joint].actInv(pin.Force(w[:3], w[3:] + np.cross(e, w[:3])))
        ref = pin.rnea(model, data, q, np.zeros(model.nv), np.zeros(model.nv), fext)
        np.testing.assert_allclose(tau[0, j], ref, rtol=0, atol=1e-10 * np.max(np.abs(ref)))


def test_optimal_preload_matches_a_brute_force_scan(paper, paper_path) -> None:
    braced = paper[0]
    relief = actuator_relief(braced, paper_path, WRENCHES, gravity=True)
    tau, a = actuator_torques(braced, paper_path, WRENCHES, gravity=True)
    effort = effort_limits(braced.robot)
    assert relief.preloads.shape == (1,)
    grid = np.linspace(0.0, 3.0 * max(relief.preloads[0], 50.0), 6001)
    peaks = np.array([np.max(np.abs(tau - p * a[:, None, 0, :]) / effort) for p in grid])
    near = peaks.min() * (1.0 + PEAK_RTOL)
    assert relief.braced_peak <= near + 1e-12
    assert relief.braced_peak == pytest.approx(peaks.min(), rel=2 * PEAK_RTOL)
    # the smallest preload whose peak is within PEAK_RTOL of the optimum (the grid's first such point)
    assert relief.preloads[0] == pytest.approx(grid[np.argmax(peaks <= near)], abs=2 * (grid[1] - grid[0]))
    assert relief.braced_peak_unloaded == pytest.approx(relief.free_peak) == pytest.approx(peaks[0])
    assert relief.braced_peak <= relief.free_peak and relief.ratio == relief.braced_peak / relief.free_peak
    np.testing.assert_allclose(relief.braced_peaks.max(), relief.braced_peak)


def test_a_bound_on_the_preload_is_respected(paper, paper_path) -> None:
    braced = paper[0]
    free = actuator_relief(braced, paper_path, WRENCHES, gravity=True)
    capped = actuator_relief(braced, paper_path, WRENCHES, gravity=True, max_preload=0.25 * free.preloads[0])
    assert capped.preloads[0] <= 0.25 * free.preloads[0] + 1e-9
    assert free.braced_peak <= capped.braced_peak <= capped.free_peak


def test_a_failed_solve_is_a_numerical_error(paper, monkeypatch) -> None:
    braced, q = paper

    def failing(*args, **kwargs):
        return scipy.optimize.OptimizeResult(status=4, x=None, message="numerical difficulties")

    monkeypatch.setattr(importlib.import_module("bracekit.statics.relief"), "linprog", failing)
    with pytest.raises(NumericalError, match="HiGHS status 4"):
        actuator_relief(braced, q, WRENCHES, gravity=True)


def test_no_effort_limit_is_an_input_error(paper) -> None:
    braced, q = paper
    with pytest.raises(InputError, match="effort"):
        actuator_relief(braced, q, WRENCHES, effort=np.full(braced.robot.n, np.inf))
