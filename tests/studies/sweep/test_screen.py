from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from bracekit.compliance.first_order import compliance_index, end_effector_compliance
from bracekit.compliance.measures import frobenius_condition
from bracekit.contact import Brace, Surface
from bracekit.kinematics import BracedRobot
from bracekit.kinematics.clearance import link_clearance
from bracekit.studies.sweep.candidates import expand
from bracekit.studies.sweep.context import task_context
from bracekit.studies.sweep.screen import Screened, screen_context, select
from bracekit.studies.sweep.spec import load_spec


def test_screening_equals_the_single_configuration_path(tiny_spec: Path) -> None:
    spec = load_spec(tiny_spec)
    cands = expand(spec)
    ctx = task_context(spec, {}, cands[0].context_key)
    screened = screen_context(spec, ctx, cands)
    robot = spec.base_scenario().robot
    for c, s in zip(cands, screened, strict=True):
        joint = int(c.inputs["link"][4:])
        local = c.inputs["fraction"] * np.asarray(robot.model.jointPlacements[joint + 1].translation)
        point = robot.with_point_frame("p", c.inputs["link"], local)
        braced = BracedRobot(point, Brace("p", Surface(np.zeros(3), np.array([0.0, 0.0, 1.0]))))
        data = point.model.createData()
        pin.framesForwardKinematics(point.model, data, ctx.q_ref)
        at_start = data.oMf[point.frame_id("p")].translation.copy()
        solid = BracedRobot(point, Brace("p", Surface(at_start, np.array([0.0, 0.0, 1.0])), region_radius=0.15))
        assert s.clearance == pytest.approx(link_clearance(solid.state(ctx.q_ref))[0], abs=1e-12)
        ci, k = [], []
        for q, beta in zip(ctx.Q, ctx.beta, strict=True):
            st = braced.state(q)
            ci.append(compliance_index(end_effector_compliance(st, "constrained"), beta))
            k.append(frobenius_condition(st.split.J_braced))
        assert s.candidate == c.id
        assert s.Ci_mean == pytest.approx(np.mean(ci), rel=1e-10)
        assert s.k_max == pytest.approx(np.max(k), rel=1e-10)


def test_selection_keeps_the_best_fraction_under_the_k_bound(tiny_spec: Path) -> None:
    spec = dataclasses.replace(
        load_spec(tiny_spec),
        screening=dataclasses.replace(load_spec(tiny_spec).screening, k_max=10.0, keep_fraction=0.5),
    )
    screened = [
        Screened("a", 3e-3, 5.0),
        Screened("b", 1e-3, 20.0),  # best C_i but k above the bound
        Screened("c", 2e-3, 5.0),
        Screened("d", 4e-3, None),  # singular on the path
        Screened("e", 5e-3, 4.0, failure="screening: x"),  # cannot screen: simulated
        Screened("f", 1.5e-3, 9.0),
        Screened("g", 0.5e-3, 3.0, clearance=-0.01),  # a link inside the solid at the start
    ]
    verdict = select(spec, screened)
    kept = sorted(k for k, v in verdict.items() if v is None)
    assert kept == ["a", "c", "e", "f"]  # the 4 best (ceil(0.5 · 7)) of those that pass, and e (not screened)
    assert (
        "at the start" in verdict["g"]
        and "k of J̃" in verdict["b"]
        and "singular" in verdict["d"]
        and verdict["a"] is None
    )
