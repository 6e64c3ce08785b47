"""The brace-margin term: residuals against the statics' capacity, exact gradient, scenario key, fused step.

References: :func:`bracekit.statics.load_capacity` (geometric=False) for the contact forces at scale 1, central
finite differences for the gradient, the reference strategy (BracedGradientProjection.velocity) for the fused step.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

import bracekit as bk
from bracekit import BracedGradientProjection
from bracekit.errors import BarrierError, InputError, ScenarioError
from bracekit.objective import (
    TERMS,
    BraceMargin,
    ComplianceIndex,
    ConditionNumber,
    Objective,
    finite_difference_gradient,
)
from bracekit.objective.brace_margin import RELAX_FRACTION, SLIP_SMOOTHING
from bracekit.resolution.fused import GradientProjectionStep
from bracekit.statics import load_capacity
from helpers import scenario_text

#: A downward and a sideways tool force (N), and a twist about z with a push along x (N, N·m).
WRENCHES = np.array([[0.0, 0.0, -4.0, 0.0, 0.0, 0.0], [3.0, 0.0, 0.0, 0.0, 0.0, 0.5]])
PRELOAD, MU = 20.0, 0.5


def _configurations(count: int, seed: int = 3) -> list[np.ndarray]:
    sc = bk.load_scenario("paper")
    rng = np.random.default_rng(seed)
    return [sc.guess + rng.normal(scale=0.1, size=sc.robot.n) for _ in range(count)]


def test_residuals_are_the_capacity_forces_at_scale_one() -> None:
    braced = bk.load_scenario("paper").braced
    term = BraceMargin(braced, WRENCHES, PRELOAD, MU)
    for q in _configurations(3):
        st = braced.state(q)
        cap = load_capacity(braced, q, WRENCHES, preload=PRELOAD, friction=MU, geometric=False)
        f_n, f_t = term.forces(st)
        np.testing.assert_allclose(f_n, cap.normal_force, rtol=1e-12, atol=1e-10)
        np.testing.assert_allclose(f_t, cap.tangential_force, rtol=1e-12, atol=1e-10)
        r = term.residuals(st)
        np.testing.assert_allclose(r[:2], cap.normal_force, rtol=1e-12, atol=1e-10)
        smooth = np.sqrt(cap.tangential_force**2 + SLIP_SMOOTHING**2)
        np.testing.assert_allclose(r[2:], MU * cap.normal_force - smooth, rtol=1e-12, atol=1e-10)
        # scale 1 holds exactly when both residuals are positive: the capacity's margins agree
        assert (np.min(r[:2]) > 0) == (cap.liftoff_margin > 1.0)
        assert (np.min(r[2:]) > 0) == (cap.slip_margin is not None and cap.slip_margin > 1.0)


def test_gravity_does_not_change_the_k_only_residuals() -> None:
    braced = bk.load_scenario("paper").braced
    q = _configurations(1)[0]
    with_g = load_capacity(braced, q, WRENCHES, preload=PRELOAD, friction=MU, gravity=True, geometric=False)
    f_n, f_t = BraceMargin(braced, WRENCHES, PRELOAD, MU).forces(braced.state(q))
    np.testing.assert_allclose(f_n, with_g.normal_force, rtol=1e-12, atol=1e-10)
    np.testing.assert_allclose(f_t, with_g.tangential_force, rtol=1e-12, atol=1e-10)


@pytest.mark.parametrize("strict", [False, True])
def test_gradient_equals_central_differences_on_the_paper_robot(strict: bool) -> None:
    braced = bk.load_scenario("paper").braced
    term = BraceMargin(braced, WRENCHES, PRELOAD, MU, margin=12.0, strict=strict)
    active = 0
    for q in _configurations(4):
        st = braced.state(q, hessians=True)
        value = term.value(st)
        active += value > 0.0
        fd = finite_difference_gradient(braced, term.value, q, 1e-6)
        np.testing.assert_allclose(term.gradient(st), fd, rtol=1e-6, atol=1e-7 * max(1.0, np.max(np.abs(fd))))
    assert active >= 3  # the barrier acts on most of these configurations


def test_relaxed_barrier_below_the_switch_and_on_a_slipping_configuration() -> None:
    braced = bk.load_scenario("paper").braced
    loads = np.array([[0.0, 0.0, -10.0, 0.0, 0.0, 0.0], [10.0, 0.0, 0.0, 0.0, 0.0, 0.0]])
    term = BraceMargin(braced, loads, PRELOAD, MU)
    delta = term.margin
    assert delta == pytest.approx(0.5 * PRELOAD)
    q = _configurations(1)[0]
    st = braced.state(q, hessians=True)
    r = term.residuals(st)
    assert np.min(r) < 0.0  # the downward 10 N load makes the brace slip here
    with pytest.raises(BarrierError, match="slips under tool wrench"):
        BraceMargin(braced, loads, PRELOAD, MU, strict=True).value(st)
    # the relaxed value is the barrier above r_s and its quadratic expansion below, per residual
    r_s = RELAX_FRACTION * delta
    expected = 0.0
    for x in r:
        if x >= delta:
            continue
        y = max(x, r_s)
        phi = (delta - y) ** 2 / (delta * y)
        if x < r_s:
            phi += (1.0 / delta - delta / r_s**2) * (x - r_s) + delta / r_s**3 * (x - r_s) ** 2
        expected += phi
    assert term.value(st) == pytest.approx(expected, rel=1e-12)
    fd = finite_difference_gradient(braced, term.value, q, 1e-6)
    np.testing.assert_allclose(term.gradient(st), fd, rtol=1e-6, atol=1e-7 * np.max(np.abs(fd)))


def test_frictionless_term_has_lift_off_residuals_only() -> None:
    braced = bk.load_scenario("paper").braced
    q = _configurations(1)[0]
    term = BraceMargin(braced, WRENCHES, 5.0, None, margin=10.0)
    st = braced.state(q, hessians=True)
    cap = load_capacity(braced, q, WRENCHES, preload=5.0, geometric=False)
    np.testing.assert_allclose(term.residuals(st), cap.normal_force, rtol=1e-12, atol=1e-10)
    assert term.value(st) > 0.0
    fd = finite_difference_gradient(braced, term.value, q, 1e-6)
    np.testing.assert_allclose(term.gradient(st), fd, rtol=1e-6, atol=1e-7 * np.max(np.abs(fd)))


def test_bad_arguments_are_refused() -> None:
    braced = bk.load_scenario("paper").braced
    with pytest.raises(InputError, match="tool wrench"):
        BraceMargin(braced, [[1.0, 2.0]], PRELOAD, MU)
    with pytest.raises(InputError, match="preload"):
        BraceMargin(braced, WRENCHES, -1.0, MU)
    with pytest.raises(InputError, match="margin"):
        BraceMargin(braced, WRENCHES, PRELOAD, MU, margin=0.0)
    with pytest.raises(InputError, match="margin"):
        BraceMargin(braced, [[0.0, 0.0, 0.0, 1.0, 0.0, 0.0]], 0.0, MU)  # no scale for the default δ


def _holding_text(preload: float = PRELOAD, friction: float | None = MU, loads: bool = True) -> str:
    text = scenario_text(turns=0.05, dt=0.1)
    extra = f"preload = {preload}" + (f"\nfriction = {friction}" if friction is not None else "")
    text = re.sub(r"(?m)^region_radius = .*$", f"region_radius = 0.15\n{extra}", text, count=1)
    text = re.sub(r"(?m)^weights = \{(.*)\}", r"weights = {\1, brace_margin = 0.1 }", text, count=1)
    if loads:
        text += "\n[loads]\nwrenches = [[0.0, 0.0, -4.0, 0.0, 0.0, 0.0], [3.0, 0.0, 0.0, 0.0, 0.0, 0.5]]\n"
    return text


def test_the_scenario_key_builds_the_term_from_the_holding(tmp_path: Path) -> None:
    assert TERMS["brace_margin"] is BraceMargin
    paper = bk.load_scenario("paper")
    assert paper.weights["brace_margin"] == 0.0 and "brace_margin" not in paper.objective().names
    path = tmp_path / "margin.toml"
    path.write_text(_holding_text(), encoding="utf-8")
    sc = bk.load_scenario(path)
    obj = sc.objective()
    term = obj.terms[obj.names.index("brace_margin")]
    assert isinstance(term, BraceMargin)
    assert term.preload == PRELOAD and term.friction == MU and np.array_equal(term.wrenches, WRENCHES)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [({"loads": False}, r"\[loads\] wrenches"), ({"preload": 0.0, "friction": None}, r"\[brace\] preload")],
)
def test_the_scenario_key_is_refused_without_loads_or_holding(tmp_path: Path, kwargs: dict, match: str) -> None:
    path = tmp_path / "margin.toml"
    path.write_text(_holding_text(**kwargs), encoding="utf-8")
    with pytest.raises(ScenarioError, match=match):
        bk.load_scenario(path).objective()


@pytest.mark.parametrize("model", ["constrained", "projection"])
def test_fused_step_with_the_term_equals_the_reference(model: str) -> None:
    sc = bk.load_scenario("paper")
    braced = sc.braced
    terms = [
        ConditionNumber(),
        ComplianceIndex(np.r_[1.0, 0, 0, 0, 0, 0], model),
        BraceMargin(braced, WRENCHES, PRELOAD, MU, margin=12.0),
    ]
    strategy = BracedGradientProjection(Objective(terms, [0.5, 100.0, 0.3]), alpha=-1.0)
    step = GradientProjectionStep(braced, strategy)
    rng = np.random.default_rng(11)
    for q in _configurations(3, seed=7):
        xdot = rng.normal(scale=0.05, size=6)
        st = braced.state(q, hessians=True)
        assert terms[2].value(st) > 0.0
        ref = strategy.velocity(st, xdot)
        np.testing.assert_allclose(step(q, xdot), ref, rtol=1e-10, atol=1e-12 * np.max(np.abs(ref)))
        np.testing.assert_allclose(step.gradient(q), strategy.objective.gradient(st), rtol=1e-10, atol=1e-12)
        assert step.value(q) == pytest.approx(strategy.objective.value(st), rel=1e-13)


@pytest.mark.parametrize(("contact", "k_env"), [("soft_finger", None), ("frictionless_point", 2e3)])
def test_other_contacts_and_a_compliant_surface_match_the_capacity_and_differences(
    contact: str, k_env: float | None
) -> None:
    braced = bk.load_scenario("paper").braced
    brace = braced.brace
    other = bk.BracedRobot(
        braced.robot, bk.Brace(brace.frame, brace.surface, contact=contact, environment_stiffness=k_env)
    )
    term = BraceMargin(other, WRENCHES, PRELOAD, MU, margin=12.0)
    for q in _configurations(2, seed=5):
        st = other.state(q, hessians=True)
        cap = load_capacity(other, q, WRENCHES, preload=PRELOAD, friction=MU, geometric=False)
        f_n, f_t = term.forces(st)
        np.testing.assert_allclose(f_n, cap.normal_force, rtol=1e-10, atol=1e-9)
        np.testing.assert_allclose(f_t, cap.tangential_force, rtol=1e-10, atol=1e-9)
        assert term.value(st) > 0.0
        fd = finite_difference_gradient(other, term.value, q, 1e-6)
        np.testing.assert_allclose(term.gradient(st), fd, rtol=1e-6, atol=1e-7 * np.max(np.abs(fd)))
