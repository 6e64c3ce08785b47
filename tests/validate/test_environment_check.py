"""Tests of bracekit.validate.environment_check: the compliance with a finite surface stiffness k_env.

The references are independent of bracekit's compliance: MuJoCo with a soft contact whose stiffness is k_env
(solref derived in docs/validation.md) and the nonlinear static solve with a penalty contact.
"""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest

from bracekit.errors import InputError
from bracekit.kinematics import BracedRobot
from bracekit.simulation.scenario import load_scenario
from bracekit.validate.environment_check import run_environment_validation
from bracekit.validate.mjcf import SOFT_IMPEDANCE, build_mujoco_model, soft_contact_solref
from bracekit.validate.plane_contact import PlaneContact
from bracekit.validate.runner import run_validation, validation_configurations

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def report():  # type: ignore[no-untyped-def]
    sc = load_scenario("paper")
    return run_environment_validation(sc, validation_configurations(sc, 2))


def test_kenv_rows_agree_with_mujoco_and_the_static_solve_within_one_percent(report) -> None:  # type: ignore[no-untyped-def]
    assert [r.k_env for r in report.rows] == [1e3, 1e4, 1e5]
    for row in report.rows:
        st = row.report.model_stats("constrained")
        assert row.report.counts()["failed"] == 0
        assert st["n_cases"] >= 10
        assert st["median_rel_err_mujoco"] <= 0.01
        assert st["median_rel_err_static"] <= 0.01
        # the two references model the same soft contact: they agree far below the first-order error
        assert row.report.mujoco_vs_static()["median_rel_err"] < 1e-5


def test_a_soft_surface_changes_the_deflection(report) -> None:  # type: ignore[no-untyped-def]
    # the rows test k_env, not the rigid case again: 1e3 N/m changes the deflection by several percent,
    # and the change shrinks as the surface stiffens
    soft = [r.softening for r in report.rows]
    assert soft[0] > 0.05
    assert soft[0] > soft[1] > soft[2]


@pytest.mark.parametrize("friction", [None, 0.5])
def test_mujoco_soft_contact_is_a_spring_of_stiffness_kenv(friction: float | None) -> None:
    # the settled contact force divided by the penetration is k_env (solref of soft_contact_solref), frictionless
    # (condim 1) and with friction in the elliptic cone (one normal row too)
    sc = load_scenario("paper")
    q = validation_configurations(sc, 1)[0]
    br, robot = sc.braced, sc.robot
    for k_env in (1e3, 1e5):
        contact = PlaneContact(br.brace_id, br.brace.surface.point, br.brace.surface.normal, 2.0, None, k_env)
        xml = build_mujoco_model(robot.model, q, robot.stiffness, robot.tip_id, [contact], friction=friction)
        m = mujoco.MjModel.from_xml_string(xml)
        d = mujoco.MjData(m)
        d.qpos[:] = q
        for _ in range(4000):
            mujoco.mj_step(m, d, 10)
            if np.max(np.abs(d.qvel)) < 1e-12:
                break
        assert d.ncon == 1
        f = np.zeros(6)
        mujoco.mj_contactForce(m, d, 0, f)
        depth = -float(d.contact[0].dist)
        assert f[0] / depth == pytest.approx(k_env, rel=1e-6)
        assert f[0] == pytest.approx(2.0, rel=1e-6)  # the preload, pressed in by P / k_env at q


def test_a_soft_contact_with_friction_in_a_pyramidal_cone_is_refused() -> None:
    # the pyramid's rows would make the contact stiffer than k_env (6.4x measured at k_env = 1e4, mu = 0.5)
    sc = load_scenario("paper")
    q = validation_configurations(sc, 1)[0]
    br, robot = sc.braced, sc.robot
    contact = PlaneContact(br.brace_id, br.brace.surface.point, br.brace.surface.normal, 2.0, None, 1e4)
    with pytest.raises(InputError, match="cone='elliptic'"):
        build_mujoco_model(robot.model, q, robot.stiffness, robot.tip_id, [contact], friction=0.5, cone="pyramidal")


def test_soft_contact_solref_formula() -> None:
    s, b = soft_contact_solref(1e4, 2.0)
    assert s == pytest.approx(1e4 * (1.0 - SOFT_IMPEDANCE) * 2.0)
    assert b == pytest.approx(2.0 * np.sqrt(s))


def test_rigid_block_runs_a_scenario_with_kenv() -> None:
    # a scenario with environment_stiffness is validated (no longer refused), against the soft references
    sc = load_scenario("paper")
    soft = dataclasses.replace(
        sc, braced=BracedRobot(sc.robot, dataclasses.replace(sc.braced.brace, environment_stiffness=1e3))
    )
    rep = run_validation(soft, 1, directions=[("force -z", [0.0, 0.0, -1.0, 0.0, 0.0, 0.0])])
    assert rep.counts()["ok"] == 1
    assert rep.model_stats("constrained")["median_rel_err_mujoco"] < 0.01


def test_bad_stiffness_is_an_input_error() -> None:
    with pytest.raises(InputError, match="environment stiffness"):
        run_environment_validation("paper", 1, stiffnesses=[0.0])
