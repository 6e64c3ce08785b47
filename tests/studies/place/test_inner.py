"""The inner problem: its constraint Jacobians against central differences; its optimum checked independently.

The optimum's constraints are re-checked with the library's own machinery at a scenario built for the place
(the tip pose, the clearance of :func:`bracekit.kinematics.clearance.link_clearance` from a surface through the
pad, C_i of :func:`bracekit.compliance.first_order.constrained_compliance`), not with the inner problem's code.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pinocchio as pin
import pytest

from bracekit.compliance.first_order import constrained_compliance
from bracekit.kinematics.clearance import link_clearance
from bracekit.studies.place.inner import InnerSettings, StartProblem, optimise_start
from bracekit.studies.place.scenario import place_scenario

H = 1e-6


@pytest.fixture(scope="module")
def problem(setup: dict[str, Any]) -> StartProblem:
    return StartProblem(setup["spec"], "link4", setup["q"], InnerSettings())


def _fd(fun: Any, x: np.ndarray) -> np.ndarray:
    cols = []
    for k in range(x.size):
        dx = np.zeros(x.size)
        dx[k] = H
        cols.append((fun(x + dx) - fun(x - dx)) / (2 * H))
    return np.array(cols).T


def test_objective_and_constraint_jacobians(setup: dict[str, Any], problem: StartProblem) -> None:
    rng = np.random.default_rng(5)
    x = np.concatenate([setup["q"] + 0.03 * rng.standard_normal(setup["q"].size), [0.45, 2.9]])
    _, grad = problem.objective(x)
    assert np.allclose(grad, _fd(lambda y: problem.objective(y)[0], x), rtol=1e-5, atol=1e-6)
    assert np.allclose(problem.pose_jacobian(x), _fd(problem.pose, x), atol=1e-6)
    got, fd = problem.inequality_jacobian(x), _fd(problem.inequalities, x)
    assert got.shape == fd.shape and got.shape[0] > 2  # k, tilt and one row per link
    assert np.allclose(got, fd, atol=2e-5)


def test_optimum_meets_its_constraints(setup: dict[str, Any]) -> None:
    spec, settings = setup["spec"], InnerSettings()
    r = optimise_start(spec, "link2", 0.5, setup["q"], settings)
    assert r.success, r.message
    sc = place_scenario(spec, _surface(setup, "link2"), r.place, r.q)
    state = sc.braced.state(r.q)
    assert np.allclose(state.e, sc.task.position(0.0), atol=1e-6)
    rotation = sc.task.rotation
    if rotation is not None:
        assert np.linalg.norm(pin.log3(np.asarray(rotation).T @ state.R_e)) < 1e-6
    clearance, _ = link_clearance(state)
    assert clearance >= spec.feasibility.min_clearance + settings.clearance_margin - 1e-6
    assert math.degrees(math.acos(min(1.0, state.contacts[0].z_b @ sc.braced.braces[0].surface.normal))) <= (
        settings.max_tilt_deg + 1e-4
    )
    assert settings.posture_radius is not None
    assert np.linalg.norm(r.q - setup["q"]) <= settings.posture_radius + 1e-6
    ci = np.linalg.norm(constrained_compliance(state) @ sc.beta_x(0.0))
    assert r.value == pytest.approx(ci, rel=1e-9)
    lower, upper = sc.robot.lower + settings.limit_margin - 1e-9, sc.robot.upper - settings.limit_margin + 1e-9
    assert np.all((r.q >= lower) | ~np.isfinite(lower)) and np.all((r.q <= upper) | ~np.isfinite(upper))


def _surface(setup: dict[str, Any], link: str) -> Any:
    from bracekit.studies.place.surface import link_surface

    return link_surface(setup["scenario"].robot, link)


def test_posture_box_keeps_the_optima(setup: dict[str, Any], monkeypatch: pytest.MonkeyPatch) -> None:
    """The box q0 ± R in SLSQP's bounds (inside which the ball lies) finds the optima found without it.

    Reference: the same seeds with the joint limits alone as bounds (the ball a constraint only), the build
    before the box; the seeds that converge there converge here to the same start C_i. The box also keeps every
    iterate within R of q0 per joint (SLSQP's bounds hold at each iterate).
    """
    spec, settings, q0 = setup["spec"], InnerSettings(), setup["q"]
    boxed = {link: optimise_start(spec, link, 0.5, q0, settings) for link in ("link2", "link4", "link9")}
    original = StartProblem.bounds

    def limits_only(self: StartProblem, angle0: float) -> list[tuple[float | None, float | None]]:
        saved = self.settings
        self.settings = InnerSettings(posture_radius=None)
        try:
            return original(self, angle0)
        finally:
            self.settings = saved

    monkeypatch.setattr(StartProblem, "bounds", limits_only)
    for link, r in boxed.items():
        ref = optimise_start(spec, link, 0.5, q0, settings)
        assert ref.success and r.success, (link, ref.message, r.message)
        assert r.value == pytest.approx(ref.value, rel=1e-6)
        assert settings.posture_radius is not None
        assert np.abs(r.q - q0).max() <= settings.posture_radius + 1e-9
        assert r.iterations <= ref.iterations + 2
