"""Tests of the clearance barrier (bracekit.objective.clearance) where the disk's edge cuts the links.

The table top lies a little below the links, so the low links beside or across the disk's edge are nearest its
rim circle, at points that slide along the links as q moves. References: central finite differences of the
term, and the reference strategy (BracedGradientProjection.velocity) for the fused step.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from bracekit import Brace, BracedGradientProjection, BracedRobot, Surface, load_scenario
from bracekit.kinematics.clearance import Clearance
from bracekit.objective import (
    BraceAngle,
    ClearanceBarrier,
    ComplianceIndex,
    ConditionNumber,
    Objective,
    finite_difference_gradient,
)
from bracekit.resolution.fused import GradientProjectionStep

R_MAX = 0.12


def _edge_cut(seed: int) -> tuple[BracedRobot, np.ndarray, bool]:
    """The paper robot at a perturbed start, its table 3 cm under its lowest link, a 0.12 m disk on a low link.

    Returns the braced robot, q and whether the disk's edge cuts that link's capsule (one end over the disk).
    """
    sc = load_scenario("paper")
    q = sc.guess + np.random.default_rng(seed).normal(scale=0.2, size=sc.robot.n)
    surface, frame = sc.braced.brace.surface, sc.braced.brace.frame
    whole = BracedRobot(sc.robot, Brace(frame, surface))
    clearance = Clearance(whole)
    low = clearance.minimum(q)[0]
    model = sc.robot.model
    data = model.createData()
    pin.forwardKinematics(model, data, q)
    ends = [(data.oMi[c.joint].act(c.a), data.oMi[c.joint].act(c.b)) for c in clearance.capsules]
    normal = surface.normal

    def lateral(v: np.ndarray) -> np.ndarray:
        return v - normal * (normal @ v)

    # one of the three lowest capsules 0.15–0.35 m long across the normal; the disk's edge cuts its middle
    fit = [e for e in ends if 0.15 < np.linalg.norm(lateral(e[1] - e[0])) < 0.35]
    pa, pb = sorted(fit, key=lambda e: min(normal @ e[0], normal @ e[1]))[seed % 3]
    if normal @ pb < normal @ pa:
        pa, pb = pb, pa  # pb the higher end: over the disk, pa beyond it, the least point on the edge
    side = lateral(pb - pa) / np.linalg.norm(lateral(pb - pa))
    centre = 0.5 * (pa + pb) + 0.5 * R_MAX * side
    centre = centre - normal * (normal @ (centre - surface.point)) + normal * (low - 0.03)
    braced = BracedRobot(sc.robot, Brace(frame, Surface(centre, surface.normal), region_radius=R_MAX))

    def over(p: np.ndarray) -> bool:
        return bool(np.linalg.norm(lateral(p - centre)) <= R_MAX)

    return braced, q, over(pa) != over(pb)


@pytest.mark.parametrize("seed", range(4))
def test_clearance_barrier_gradient_with_clip_points_matches_finite_differences(seed: int) -> None:
    braced, q, cut = _edge_cut(seed)
    assert cut
    term = ClearanceBarrier(braced, margin=0.3)
    state = braced.state(q)
    assert term.value(state) > 0.0
    fd = finite_difference_gradient(braced, term.value, q, 1e-6)
    np.testing.assert_allclose(term.gradient(state), fd, rtol=1e-5, atol=1e-6)


@pytest.mark.parametrize("model", ["constrained", "projection"])
def test_fused_step_with_clip_points_equals_the_reference(model: str) -> None:
    braced, q, _ = _edge_cut(1)
    terms = [
        ConditionNumber(),
        ComplianceIndex(np.r_[1.0, 0, 0, 0, 0, 0], model),
        BraceAngle(),
        ClearanceBarrier(braced),
    ]
    strategy = BracedGradientProjection(Objective(terms, [0.5, 100.0, 0.6, 0.05]), alpha=-0.7)
    step = GradientProjectionStep(braced, strategy, backend="numpy")
    xdot = np.random.default_rng(3).normal(scale=0.05, size=6)
    st = braced.state(q, hessians=True)
    ref = strategy.velocity(st, xdot)
    np.testing.assert_allclose(step(q, xdot), ref, rtol=1e-10, atol=1e-12 * np.max(np.abs(ref)))
    np.testing.assert_allclose(step.gradient(q), strategy.objective.gradient(st), rtol=1e-10, atol=1e-12)
    assert step.value(q) == pytest.approx(strategy.objective.value(st), rel=1e-13)
