"""Tests of bracekit.validate.holding_check: the holding statics (gravity, preload, friction) against MuJoCo."""

from __future__ import annotations

import json
import re
from pathlib import Path

import mujoco
import numpy as np
import pytest

import bracekit as bk
from bracekit.errors import InputError
from bracekit.simulation.holding import Holding
from bracekit.statics import contact_response, load_contact_wrenches
from bracekit.validate import holding_check
from bracekit.validate.capacity_check import mujoco_capacity_ramp, static_capacity_scale
from bracekit.validate.contacts import plane_contacts
from bracekit.validate.holding_check import (
    FAIL_ABOVE,
    HOLD_BELOW,
    HOLDING_SETTINGS,
    HoldingCheck,
    mujoco_holding_check,
)
from bracekit.validate.mjcf import brace_geom_names, build_mujoco_model
from bracekit.validate.runner import run_capacity_validation, run_holding_validation, validation_configurations
from bracekit.validate.statics import solve_static_equilibrium
from helpers import scenario_text

pytestmark = pytest.mark.slow  # MuJoCo simulations

LOADS = "\n[loads]\nwrenches = [[0.0, 0.0, -10.0, 0.0, 0.0, 0.0], [10.0, 0.0, 0.0, 0.0, 0.0, 0.0]]\n"


def _holding_text() -> str:
    """The paper scenario with gravity, P = 20 N, μ = 0.5 and two tool wrenches (k = 170 N·m/rad)."""
    text = scenario_text(turns=0.05, dt=0.1)
    text = re.sub(r"(?m)^stiffness = .*$", "stiffness = 170.0\ngravity = true", text, count=1)
    text = re.sub(r"(?m)^region_radius = .*$", "region_radius = 0.15\npreload = 20.0\nfriction = 0.5", text, count=1)
    return text + LOADS


@pytest.fixture(scope="module")
def setup(tmp_path_factory: pytest.TempPathFactory) -> dict:
    path = tmp_path_factory.mktemp("hold") / "hold.toml"
    path.write_text(_holding_text(), encoding="utf-8")
    sc = bk.load_scenario(path)
    return {"path": path, "sc": sc, "q": validation_configurations(sc, 1)[0]}


@pytest.fixture(scope="module")
def down(setup: dict) -> HoldingCheck:
    """The check of the listed downward 10 N force (predicted to slip first) at the start configuration."""
    sc = setup["sc"]
    return mujoco_holding_check(sc.braced, setup["q"], sc.holding, sc.holding.wrenches[0])


def test_mjcf_has_the_coulomb_cone_friction_gravity_and_the_statics_set_points(setup: dict) -> None:
    sc, q = setup["sc"], setup["q"]
    robot = sc.robot
    resp = contact_response(sc.braced, q, preload=20.0, gravity=True, friction=0.5)
    xml = build_mujoco_model(
        robot.model, q, robot.stiffness, robot.tip_id, plane_contacts(sc.braced),
        gravity=True, friction=0.5, impratio=10.0, set_points=resp.q_s,
    )  # fmt: skip
    m = mujoco.MjModel.from_xml_string(xml)
    assert m.opt.cone == mujoco.mjtCone.mjCONE_ELLIPTIC and m.opt.impratio == 10.0
    pair = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, g) for g in brace_geom_names(0)]
    assert np.all(m.geom_condim[pair] == 3) and np.allclose(m.geom_friction[pair, 0], 0.5)
    np.testing.assert_allclose(m.qpos_spring, resp.q_s, atol=1e-15)
    np.testing.assert_allclose(m.opt.gravity, [0.0, 0.0, -9.81])
    d = mujoco.MjData(m)
    d.qpos[:] = q
    mujoco.mj_forward(m, d)
    # with the robot at rest, MuJoCo's bias force is gravity: it matches Pinocchio's g(q) = τ0 + J_bᵀ f_c0
    st = sc.braced.state(q)
    np.testing.assert_allclose(d.qfrc_bias, resp.tau0 + st.J_b_i[0].T @ resp.f_c0, atol=1e-9)


def test_unloaded_contact_force_is_the_preload_with_no_tangential_force(down: HoldingCheck) -> None:
    assert down.unloaded_normal_rel_err < 0.02
    assert down.unloaded_tangential < 0.01 * 20.0
    assert down.preloads == (20.0,) and down.friction == 0.5 and down.gravity


def test_loaded_contact_force_and_torques_match_the_first_order_response_below_the_margin(down: HoldingCheck) -> None:
    held = [c for c in down.cases if c.fraction is not None and c.fraction <= 0.5]
    assert len(held) == 2
    for c in held:
        (b,) = c.braces
        assert c.outcome == "held" and b.outcome == "held" and c.failed_braces == ()
        assert c.rel_err < 0.01 and c.torque_rel_err < 0.01
        assert abs(b.mujoco_normal - b.predicted_normal) < 0.01 * b.predicted_normal
        assert abs(b.mujoco_tangential - b.predicted_tangential) < 0.02 * b.predicted_tangential + 0.05
    # the first-order error grows with the load (second order in s): the larger scale is further off
    assert held[1].rel_err > held[0].rel_err


def test_mujoco_and_first_order_forces_match_the_nonlinear_sticking_statics(setup: dict, down: HoldingCheck) -> None:
    sc, q = setup["sc"], setup["q"]
    robot, surface = sc.robot, sc.braced.brace.surface
    case = next(c for c in down.cases if c.fraction is not None and abs(c.fraction - 0.5) < 1e-9)
    exact = solve_static_equilibrium(
        robot.model, q, robot.stiffness, sc.braced.brace_id, robot.tip_id, surface.point, surface.normal,
        case.wrench, preload=20.0, gravity=True, constraint_wrenches=load_contact_wrenches(sc.braced.brace, 0.5),
    )  # fmt: skip
    f_exact = exact.contact_wrench[:3]
    (b,) = case.braces
    mj_err = np.linalg.norm(b.mujoco_force - f_exact) / np.linalg.norm(f_exact)
    first_err = np.linalg.norm(b.predicted_force - f_exact) / np.linalg.norm(f_exact)
    assert mj_err < 0.005 and first_err < 0.01


@pytest.mark.parametrize("index", [0, 1])
def test_mujoco_slips_only_beyond_the_predicted_slip_margin(setup: dict, down: HoldingCheck, index: int) -> None:
    sc = setup["sc"]
    chk = down if index == 0 else mujoco_holding_check(sc.braced, setup["q"], sc.holding, sc.holding.wrenches[1])
    assert chk.mode == "slipped" and np.isfinite(chk.margin) and chk.liftoff_margin > chk.margin
    below = [c for c in chk.cases if c.fraction <= HOLD_BELOW + 1e-9]
    above = [c for c in chk.cases if c.fraction >= FAIL_ABOVE - 1e-9]
    assert below and above
    assert all(c.outcome == "held" and c.agrees for c in below)
    assert all(c.outcome == "slipped" and c.agrees for c in above)
    # sticking creeps a little; slipping moves b by far more
    assert max(c.braces[0].slip_displacement for c in below) < 0.1 * min(c.braces[0].slip_displacement for c in above)
    assert max(c.braces[0].cone_ratio for c in below) < 1.0
    # at 0.8× the margin the first-order contact force is still within a few %
    assert max(c.rel_err for c in below) < 0.04


def _cut_short(real, motions: list[float]):
    """holding_check._settle with the loaded phase cut short (half a τ of ramp, no hold); its end motions."""

    def short(sim, w, phase):  # the unloaded state as always
        if not phase.startswith("loaded"):
            return real(sim, w, phase)
        steps = sim.settle_ramped(w, phase, ramp=0.5, min_hold=0.0, max_hold=0.0, tol=holding_check._SETTLE_TOL)
        motions.append(sim.motion())
        return steps, sim.motion() < holding_check._SETTLE_TOL

    return short


def test_a_case_still_creeping_below_the_band_is_not_counted_as_held(setup: dict, monkeypatch) -> None:
    """A settling budget too short for the loaded state (half a τ of ramp, no hold): the braces creep on.

    Reference: MuJoCo's own remaining motion max|q̇|·τ at the end of the loaded phase (above the tolerance), and
    the same check with the full budget, where every case below the band settles and agrees.
    """
    real = holding_check._settle
    motions: list[float] = []
    monkeypatch.setattr(holding_check, "_settle", _cut_short(real, motions))
    sc = setup["sc"]
    chk = mujoco_holding_check(sc.braced, setup["q"], sc.holding, sc.holding.wrenches[0], fractions=(0.25, 0.5))
    assert len(motions) == 2 and min(motions) > holding_check._SETTLE_TOL
    for c in chk.cases:
        assert c.outcome == "held" and c.braces[0].slip_displacement < HOLDING_SETTINGS["slip_tol_m"]
        assert not c.settled and c.expected == "held" and c.agrees is False
        assert c.rel_err is None and c.torque_rel_err is None  # a moving state is not an equilibrium
    monkeypatch.setattr(holding_check, "_settle", real)
    full = mujoco_holding_check(sc.braced, setup["q"], sc.holding, sc.holding.wrenches[0], fractions=(0.25, 0.5))
    assert all(c.settled and c.agrees and c.rel_err is not None for c in full.cases)


def test_the_report_counts_a_creeping_case_as_a_disagreement(setup: dict, monkeypatch) -> None:
    monkeypatch.setattr(holding_check, "_settle", _cut_short(holding_check._settle, []))
    report = run_holding_validation(setup["path"], [setup["q"]], fractions=(0.5,))
    s = report.summary()
    assert s["margin_cases"] == 2 and s["margin_agree"] == 0
    assert [(d["expected"], d["mujoco"], d["settled"]) for d in s["margin_disagreements"]] == [
        ("held", "held", False)
    ] * 2
    assert "2 case(s) below 0.8× still creeping" in report.table_text()


def test_frictionless_brace_lifts_off_only_beyond_the_predicted_liftoff_margin(setup: dict) -> None:
    sc = setup["sc"]
    chk = mujoco_holding_check(sc.braced, setup["q"], Holding(gravity=True, preload=20.0), [0.0, 0.0, 10.0, 0, 0, 0])
    assert chk.mode == "lifted_off" and chk.slip_margin is None
    for c in chk.cases:
        (b,) = c.braces
        if c.fraction <= HOLD_BELOW + 1e-9:
            assert c.outcome == "held" and b.mujoco_normal > 0.0
        else:
            assert c.outcome == "lifted_off" and b.mujoco_normal == 0.0 and b.predicted_normal < 0.0
            assert c.failed_braces == (0,)
    lightly = chk.cases[0].braces[0]
    assert abs(lightly.mujoco_normal - lightly.predicted_normal) < 0.01 * lightly.predicted_normal


def test_holding_validation_report_is_json_and_agrees(setup: dict) -> None:
    report = run_holding_validation(setup["path"], [setup["q"]], fractions=(0.5, 1.2))
    js = json.loads(json.dumps(report.to_json(), allow_nan=False))
    s = js["summary"]
    assert s["counts"] == {"ok": 2, "failed": 0}
    assert s["margin_cases"] == 4 and s["margin_agree"] == 4 and s["margin_disagreements"] == []
    assert s["unloaded_normal_max_rel_err"] < 0.02 and s["force_max_rel_err"] < 0.02
    assert js["holding"] == {
        "source": "the scenario's holding statics",
        "gravity": True,
        "preload_N": 20.0,
        "preloads_N": [20.0],
        "friction": 0.5,
        "frictions": [0.5],
        "wrenches": [[0.0, 0.0, -10.0, 0.0, 0.0, 0.0], [10.0, 0.0, 0.0, 0.0, 0.0, 0.0]],
    }
    assert "4 of 4 agree" in report.table_text()


def test_holding_validation_refuses_a_scenario_without_holding_and_bad_inputs(setup: dict) -> None:
    with pytest.raises(InputError, match="no holding statics"):
        run_holding_validation("paper", [setup["q"]])
    sc = setup["sc"]
    with pytest.raises(InputError, match="tool wrench"):
        mujoco_holding_check(sc.braced, setup["q"], sc.holding, [1.0, 2.0])
    with pytest.raises(InputError, match="impratio"):
        mujoco_holding_check(sc.braced, setup["q"], sc.holding, np.zeros(6), impratio=0.5)
    with pytest.raises(InputError, match="holding"):
        mujoco_holding_check(sc.braced, setup["q"], {"preload": 20.0}, np.zeros(6))  # type: ignore[arg-type]


def test_wrench_free_scenario_checks_the_unloaded_state_only(tmp_path: Path, setup: dict) -> None:
    path = tmp_path / "noload.toml"
    path.write_text(_holding_text().replace(LOADS, "\n"), encoding="utf-8")
    report = run_holding_validation(path, [setup["q"]])
    (check,) = report.checks
    assert check["status"] == "ok" and check["check"]["cases"] == []
    assert check["check"]["unloaded_normal_rel_err"] < 0.02


PULL_UP = [0.0, 0.0, 10.0, 0.0, 0.0, 0.0]


@pytest.fixture(scope="module")
def capacity(setup: dict) -> dict:
    """The ramp check of the listed wrenches, an upward pull (slips with μ, lifts off without) and a zero wrench."""
    wrenches = [*setup["sc"].holding.wrenches.tolist(), PULL_UP, [0.0] * 6]
    report = run_capacity_validation(setup["path"], [setup["q"]], wrenches=wrenches)
    return json.loads(json.dumps(report.to_json(), allow_nan=False))


def test_slow_ramp_slips_and_lifts_off_within_5_percent_of_the_predicted_scales(capacity: dict) -> None:
    cases = capacity["cases"]
    assert [(c["wrench_index"], c["variant"], c["status"]) for c in cases] == [
        (0, "scenario", "ok"),
        (1, "scenario", "ok"),
        (2, "scenario", "ok"),
        (2, "frictionless", "ok"),
        (3, "scenario", "no_limit"),
    ]
    modes = [c["ramp"]["mode"] for c in cases[:4]]
    assert modes == ["slipped", "slipped", "slipped", "lifted_off"]
    for c in cases[:4]:
        r = c["ramp"]
        assert r["mujoco_outcome"] == r["mode"] and r["agrees"]
        assert r["rel_err"] < 0.05  # bracekit's first-order scale
        assert r["rel_err_static"] < 0.005  # the nonlinear statics along the ramp: MuJoCo's rigid-body limit
        assert abs(r["predicted_scale"] - r["static_scale"]) / r["static_scale"] < 0.05
    for c in cases[:3]:  # a sticking contact creeps by far less than it slides once the force is on the cone
        assert c["ramp"]["creep_m"] < 1e-6
    assert cases[0]["ramp"]["slide_scale"] > cases[0]["ramp"]["mujoco_scale"]
    assert capacity["n_cases"] == 4 and capacity["max_rel_err"] < 0.05 and capacity["max_rel_err_static"] < 0.005
    assert capacity["by_mode"]["slipped"]["n_cases"] == 3 and capacity["by_mode"]["lifted_off"]["n_cases"] == 1
    assert capacity["counts"] == {"ok": 4, "disagrees": 0, "no_limit": 1, "failed": 0}


def test_ramp_scale_does_not_depend_on_the_ramp_rate(setup: dict, capacity: dict) -> None:
    sc = setup["sc"]
    fast = mujoco_capacity_ramp(sc.braced, setup["q"], sc.holding, sc.holding.wrenches[0], ramp_time=20.0, static=False)
    slow = capacity["cases"][0]["ramp"]
    assert fast.mujoco_outcome == "slipped" and fast.static_scale is None
    assert fast.rate > 1.9 * slow["rate_per_s"]
    assert abs(fast.mujoco_scale - slow["mujoco_scale"]) < 0.005 * slow["mujoco_scale"]


def test_capacity_checks_refuse_what_they_cannot_check(setup: dict) -> None:
    sc, q = setup["sc"], setup["q"]
    with pytest.raises(InputError, match="preload"):
        run_capacity_validation("paper", [q])
    # a wrench that can break nothing is no input error: it is ramped and holds (was refused before)
    zero = mujoco_capacity_ramp(sc.braced, q, sc.holding, np.zeros(6), static=False)
    assert zero.mode == "held" and zero.mujoco_outcome == "held"
    with pytest.raises(InputError, match="ramp_time"):
        mujoco_capacity_ramp(sc.braced, q, sc.holding, PULL_UP, ramp_time=0.0)
    with pytest.raises(InputError, match="friction"):
        static_capacity_scale(sc.braced, q, Holding(gravity=True, preload=20.0), PULL_UP, "slipped", 1.0)


def _pressing_wrench(sc: bk.Scenario, q: np.ndarray) -> np.ndarray:
    """A tool wrench whose first-order contact-force change is a pure push into the surface (10 N along n̂ on b)."""
    resp = contact_response(sc.braced, q, preload=20.0, gravity=True, friction=0.5)
    f0 = np.asarray(resp.contact_wrench(np.zeros(6))[:3])
    R = np.column_stack([np.asarray(resp.contact_wrench(e)[:3]) - f0 for e in np.eye(6)])
    w = np.linalg.lstsq(R, 10.0 * sc.braced.brace.surface.normal, rcond=None)[0]
    return np.asarray(w, dtype=float)


def test_a_wrench_that_cannot_break_the_brace_is_ramped_tenfold_and_holds(setup: dict) -> None:
    sc, q = setup["sc"], setup["q"]
    w = _pressing_wrench(sc, q)
    r = mujoco_capacity_ramp(sc.braced, q, sc.holding, w)
    assert not np.isfinite(r.predicted_scale) and r.mode == "held"
    assert r.stop_scale == 10.0 and r.mujoco_outcome == "held" and r.mujoco_scale is None
    assert r.static_message is not None and r.static_message.startswith("nonlinear statics hold at 10")
    assert r.creep < 1e-5  # the sticking contact does not slide under the tenfold push
    report = run_capacity_validation(setup["path"], [q], wrenches=[w])
    data = json.loads(json.dumps(report.to_json(), allow_nan=False))
    (case,) = data["cases"]
    assert case["status"] == "no_limit" and case["ramp"]["mujoco_outcome"] == "held"
    assert case["message"].startswith("holds at any scale; ramped to 10x in MuJoCo, held")
    assert "held to 10" in report.table_text()
