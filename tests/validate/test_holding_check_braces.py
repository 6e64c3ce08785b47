"""Tests of bracekit.validate.holding_check and capacity_check with two braces (the shipped ``two-braces``).

Each brace has its own friction cone and normal-force limit. References independent of bracekit's first-order
statics: MuJoCo (a sphere per brace on its plane, the Coulomb cone, bracekit's set points) and the nonlinear
static solve over both contacts (:func:`~bracekit.validate.statics.solve_statics`).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import bracekit as bk
from bracekit.errors import InputError
from bracekit.simulation.holding import Holding
from bracekit.statics import load_contact_wrenches
from bracekit.validate.capacity_check import mujoco_capacity_ramp, static_capacity_scale
from bracekit.validate.contacts import plane_contacts
from bracekit.validate.holding_check import FAIL_ABOVE, HOLD_BELOW, HoldingCheck, mujoco_holding_check
from bracekit.validate.holding_report import DEFAULT_WRENCHES, default_holding
from bracekit.validate.runner import validation_configurations
from bracekit.validate.statics import solve_statics

pytestmark = pytest.mark.slow  # MuJoCo simulations

PULL_UP, DRAG_X = (np.array(w) for w in DEFAULT_WRENCHES)


@pytest.fixture(scope="module")
def setup() -> dict:
    sc = bk.load_scenario("two-braces")
    return {"sc": sc, "q": validation_configurations(sc, 1)[0], "holding": default_holding(sc)}


@pytest.fixture(scope="module")
def checks(setup: dict) -> dict[str, HoldingCheck]:
    sc, q, h = setup["sc"], setup["q"], setup["holding"]
    return {name: mujoco_holding_check(sc.braced, q, h, w) for name, w in (("up", PULL_UP), ("drag", DRAG_X))}


def _exact_forces(setup: dict, w: np.ndarray) -> list[np.ndarray]:
    """Each brace's force in the nonlinear statics with both sticking contacts (μ = 0.8, P_i = 5 N)."""
    sc, q, h = setup["sc"], setup["q"], setup["holding"]
    contacts = [
        replace(c, X=load_contact_wrenches(b, 0.8))
        for c, b in zip(plane_contacts(sc.braced, list(h.brace_preloads(2))), sc.braced.braces, strict=True)
    ]
    res = solve_statics(sc.robot.model, q, sc.robot.stiffness, sc.robot.tip_id, contacts, w, gravity=h.gravity)
    return [np.asarray(f[:3]) for f in res.contact_wrenches]


def test_each_brace_carries_its_preload_without_load(checks: dict[str, HoldingCheck]) -> None:
    for chk in checks.values():
        assert chk.preloads == (5.0, 5.0) and chk.friction == 0.8 and chk.unloaded_forces.shape == (2, 3)
        assert chk.unloaded_normal_rel_err < 0.01 and chk.unloaded_tangential < 0.01 * 5.0


def test_each_brace_fails_at_its_own_limit_and_the_first_one_is_named(checks: dict[str, HoldingCheck]) -> None:
    up, drag = checks["up"], checks["drag"]
    # the pull slips the wall pad first, the drag the table pad: the margin is each brace's own cone
    assert up.brace == 1 and up.mode == "slipped" and up.prediction.slip[1] < up.prediction.slip[0]
    assert drag.brace == 0 and drag.mode == "slipped" and drag.prediction.slip[0] < drag.prediction.slip[1]
    for chk in (up, drag):
        below = [c for c in chk.cases if c.fraction <= HOLD_BELOW + 1e-9]
        above = [c for c in chk.cases if c.fraction >= FAIL_ABOVE - 1e-9]
        assert below and above
        assert all(c.outcome == "held" and c.agrees and c.failed_braces == () for c in below)
        assert all(c.outcome == "slipped" and c.agrees and chk.brace in c.failed_braces for c in above)
        assert all(c.focus == chk.brace for c in chk.cases)


def test_every_brace_s_force_matches_the_first_order_response_below_the_margin(checks: dict[str, HoldingCheck]) -> None:
    for chk in checks.values():
        held = [c for c in chk.cases if c.fraction <= 0.5 + 1e-9]
        assert len(held) == 2
        for c in held:
            assert c.rel_err < 0.01 and c.torque_rel_err < 0.01
            for b in c.braces:
                assert abs(b.mujoco_normal - b.predicted_normal) < 0.01 * b.predicted_normal
                assert b.cone_ratio < 1.0


def test_mujoco_and_first_order_forces_match_the_nonlinear_statics_of_both_contacts(
    setup: dict, checks: dict[str, HoldingCheck]
) -> None:
    for chk in checks.values():
        case = next(c for c in chk.cases if abs(c.fraction - 0.5) < 1e-9)
        exact = np.concatenate(_exact_forces(setup, case.wrench))
        mj = np.concatenate([b.mujoco_force for b in case.braces])
        first = np.concatenate([b.predicted_force for b in case.braces])
        assert np.linalg.norm(mj - exact) < 0.005 * np.linalg.norm(exact)
        assert np.linalg.norm(first - exact) < 0.01 * np.linalg.norm(exact)


@pytest.mark.parametrize(("wrench", "brace"), [(PULL_UP, 1), (DRAG_X, 0)])
def test_slow_ramp_fails_the_predicted_brace_at_the_predicted_scale(
    setup: dict, wrench: np.ndarray, brace: int
) -> None:
    sc, q, h = setup["sc"], setup["q"], setup["holding"]
    r = mujoco_capacity_ramp(sc.braced, q, h, wrench)
    assert r.mode == "slipped" and r.brace == brace and r.preloads == (5.0, 5.0)
    assert r.mujoco_outcome == "slipped" and r.mujoco_brace == brace
    assert r.rel_err < 0.05 and r.rel_err_static < 0.005


def test_frictionless_braces_lift_off_at_the_predicted_scale(setup: dict) -> None:
    sc, q = setup["sc"], setup["q"]
    bare = Holding(preloads=(5.0, 5.0))
    r = mujoco_capacity_ramp(sc.braced, q, bare, DRAG_X)
    assert r.mode == "lifted_off" and r.friction is None and r.slip_margin is None
    assert r.mujoco_outcome == "lifted_off" and r.mujoco_brace == r.brace
    assert r.rel_err < 0.05 and r.rel_err_static < 0.005
    # the nonlinear statics' lift-off scale of that brace, directly
    s = static_capacity_scale(sc.braced, q, bare, DRAG_X, "lifted_off", r.predicted_scale, r.brace)
    assert s == pytest.approx(r.static_scale, rel=1e-9)


def test_the_mujoco_checks_refuse_what_their_model_cannot_hold(setup: dict) -> None:
    sc, q = setup["sc"], setup["q"]
    mixed = Holding(preloads=(5.0, 5.0), frictions=(0.8, 0.5))
    with pytest.raises(InputError, match="same friction"):
        mujoco_holding_check(sc.braced, q, mixed, PULL_UP)
    with pytest.raises(InputError, match="same friction"):
        mujoco_capacity_ramp(sc.braced, q, mixed, PULL_UP)
    soft = bk.BracedRobot(sc.robot, [sc.braced.braces[0], replace(sc.braced.braces[1], environment_stiffness=1e4)])
    with pytest.raises(InputError, match="brace 1 has an environment stiffness"):
        mujoco_holding_check(soft, q, setup["holding"], PULL_UP)
    with pytest.raises(InputError, match="brace must be an index"):
        static_capacity_scale(sc.braced, q, setup["holding"], PULL_UP, "slipped", 0.5, 2)
