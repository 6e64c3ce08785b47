"""Tests of the clearance barrier term (bracekit.objective.clearance): value, exact gradient, fused step, scenario.

References: central finite differences of the term and the reference strategy (BracedGradientProjection.velocity).
"""

from __future__ import annotations

import numpy as np
import pytest

from bracekit import Brace, BracedGradientProjection, BracedRobot, Surface, load_scenario
from bracekit.errors import BarrierError, InputError
from bracekit.kinematics.clearance import Clearance
from bracekit.objective import (
    TERMS,
    BraceAngle,
    ClearanceBarrier,
    ComplianceIndex,
    ConditionNumber,
    Objective,
    RegionBarrier,
    finite_difference_gradient,
)
from bracekit.resolution.fused import GradientProjectionStep


@pytest.fixture(scope="module")
def lowered():
    """The paper robot braced on a table lowered so that every sampled q keeps its links 2 cm or more above it."""
    sc = load_scenario("paper")
    qs = sc.guess + np.random.default_rng(5).normal(scale=0.2, size=(8, sc.robot.n))
    surface, frame = sc.braced.brace.surface, sc.braced.brace.frame
    wide = BracedRobot(sc.robot, Brace(frame, surface, region_radius=0.8))
    low = min(Clearance(wide).minimum(q)[0] for q in qs)
    point = surface.point + surface.normal * min(0.0, low - 0.02)
    braced = BracedRobot(sc.robot, Brace(frame, Surface(point, surface.normal), region_radius=0.8))
    return braced, qs


def test_clearance_barrier_gradient_matches_finite_differences(lowered) -> None:
    braced, qs = lowered
    term = ClearanceBarrier(braced, margin=0.6)
    used = 0
    for q in qs:
        state = braced.state(q)
        fd = finite_difference_gradient(braced, term.value, q, 1e-6)
        np.testing.assert_allclose(term.gradient(state), fd, rtol=1e-5, atol=1e-6)
        used += term.value(state) > 0
    assert used >= 4  # the links are within the margin at most samples: the test sees the barrier


def test_clearance_barrier_is_zero_beyond_the_margin_and_refuses_penetration(lowered) -> None:
    braced, qs = lowered
    state = braced.state(qs[0])
    far = ClearanceBarrier(braced, margin=1e-3)
    assert far.value(state) == 0.0 and not np.any(far.gradient(state))
    surface = braced.brace.surface
    raised = BracedRobot(
        braced.robot, Brace(braced.brace.frame, Surface(surface.point + 2.0 * surface.normal, surface.normal))
    )
    with pytest.raises(BarrierError, match="reaches the bracing plane"):
        ClearanceBarrier(raised).value(raised.state(qs[0]))
    for bad in ({"margin": 0.0}, {"margin": "a"}, {"link_radius": -1.0}):
        with pytest.raises(InputError):
            ClearanceBarrier(braced, **bad)
    with pytest.raises(InputError):
        ClearanceBarrier("robot")


@pytest.mark.parametrize("model", ["constrained", "projection"])
def test_fused_step_with_the_clearance_barrier_equals_the_reference(lowered, model: str) -> None:
    braced, qs = lowered
    surface = braced.brace.surface
    terms = [
        ConditionNumber(),
        ComplianceIndex(np.r_[1.0, 0, 0, 0, 0, 0], model),
        BraceAngle(),
        RegionBarrier(5.0, surface.point),
        ClearanceBarrier(braced, margin=0.6),
    ]
    strategy = BracedGradientProjection(Objective(terms, [0.5, 100.0, 0.6, 0.01, 0.05]), alpha=-0.7)
    step = GradientProjectionStep(braced, strategy, backend="numpy")
    rng = np.random.default_rng(2)
    for q in qs:
        xdot = rng.normal(scale=0.05, size=6)
        st = braced.state(q, hessians=True)
        ref = strategy.velocity(st, xdot)
        np.testing.assert_allclose(step(q, xdot), ref, rtol=1e-10, atol=1e-12 * np.max(np.abs(ref)))
        np.testing.assert_allclose(step.gradient(q), strategy.objective.gradient(st), rtol=1e-10, atol=1e-12)
        assert step.value(q) == pytest.approx(strategy.objective.value(st), rel=1e-13)


def test_the_scenario_weight_key_is_registered_and_zero_by_default() -> None:
    assert "clearance" in TERMS and TERMS["clearance"] is ClearanceBarrier
    sc = load_scenario("paper")
    assert sc.weights["clearance"] == 0.0
    assert "clearance" not in sc.objective().names
