"""Every check of ``bracekit validate`` on a robot with two braces (the shipped ``two-braces`` scenario).

References independent of bracekit's compliance: MuJoCo (a sphere contact per brace, gravity, the springs' set
points) and the nonlinear static solve over both contacts. The first-order models checked are the core's
several-brace ones: the stacked constrained C_e, the several-brace statics' tangent-stiffness response
(``contact_responses``) and the sticking contacts' model.
"""

from __future__ import annotations

import pytest

from bracekit.simulation.scenario import load_scenario
from bracekit.validate.environment_check import run_environment_validation
from bracekit.validate.runner import DEFAULT_DIRECTIONS, run_preloaded_validation, validation_configurations
from bracekit.validate.tracking import run_tracking_validation

pytestmark = pytest.mark.slow

LOADS = [DEFAULT_DIRECTIONS[i] for i in (0, 3, 5, 7)]


@pytest.fixture(scope="module")
def scenario():  # type: ignore[no-untyped-def]
    sc = load_scenario("two-braces")
    return sc, validation_configurations(sc, 1)


def test_two_brace_preloaded_compliance_with_gravity_matches_mujoco_and_the_static_solve(scenario) -> None:  # type: ignore[no-untyped-def]
    sc, qs = scenario
    rep = run_preloaded_validation(sc, qs, preloads=(5.0,), directions=LOADS)
    st = rep.model_stats("preloaded")
    assert rep.counts()["failed"] == 0 and st["n_cases"] >= 3
    assert st["median_rel_err_mujoco"] < 0.01 and st["median_rel_err_static"] < 0.01
    # the tangent stiffness of gravity and the preloads matters: the constrained model misses it by far more
    assert rep.model_stats("constrained")["median_rel_err_mujoco"] > 3.0 * st["median_rel_err_mujoco"]
    assert rep.mujoco_vs_static()["max_rel_err"] < 1e-4
    for case in rep.cases:  # each brace carries its own preload at the start of each case
        assert case["status"] != "ok" or min(case["contact_forces_static"]) > 0.0


def test_two_brace_tracking_check_ranks_the_strategies_like_mujoco(scenario) -> None:  # type: ignore[no-untyped-def]
    report = run_tracking_validation("two-braces", points=1)
    assert report.disagreements() == []
    for name in ("braced_min_norm", "braced_gradient_projection"):
        (point,) = report.strategies[name].points
        assert point.rel_err < 0.01 and point.rel_err_sticking is not None and point.rel_err_sticking < 0.01
        assert point.predicted_projection is None  # the paper's projection model is for one brace


def test_two_brace_kenv_rows(scenario) -> None:  # type: ignore[no-untyped-def]
    sc, qs = scenario
    env = run_environment_validation(sc, qs, stiffnesses=(1e3,))
    (row,) = env.rows
    assert row.report.counts()["failed"] == 0
    assert row.report.model_stats("constrained")["median_rel_err_mujoco"] < 0.01
    assert row.report.mujoco_vs_static()["median_rel_err"] < 1e-5
    assert row.softening is not None and row.softening > 0.1
