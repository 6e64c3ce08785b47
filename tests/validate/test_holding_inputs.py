"""What the MuJoCo holding and capacity checks take and refuse, before any simulation (no MuJoCo run)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import bracekit as bk
from bracekit.errors import InputError
from bracekit.simulation.holding import Holding
from bracekit.validate.holding_check import check_mujoco_contacts, common_friction, predicted_limits
from bracekit.validate.holding_report import DEFAULT_WRENCHES, default_holding, scenario_holding
from bracekit.validate.runner import validation_configurations


@pytest.fixture(scope="module")
def two() -> bk.Scenario:
    return bk.load_scenario("two-braces")


def test_a_scenario_without_holding_statics_gets_the_checks_own_for_every_brace(two: bk.Scenario) -> None:
    assert not two.holding.active
    h = default_holding(two)
    assert h.brace_preloads(2) == (5.0, 5.0) and h.brace_frictions(2) == (0.8, 0.8) and not h.gravity
    np.testing.assert_array_equal(h.wrenches, np.array(DEFAULT_WRENCHES))
    with pytest.raises(InputError, match="no holding statics"):
        scenario_holding(two, None)
    assert scenario_holding(two, h) is h


def test_the_checks_refuse_by_name_what_their_mujoco_model_cannot_hold(two: bk.Scenario) -> None:
    braced = two.braced
    check_mujoco_contacts(braced, default_holding(two), "holding check")
    assert common_friction(braced, Holding(preloads=(5.0, 5.0))) is None
    with pytest.raises(InputError, match=r"same friction; the braces have μ = 0\.8, 0\.5"):
        check_mujoco_contacts(braced, Holding(preloads=(5.0, 5.0), frictions=(0.8, 0.5)), "holding check")
    soft = bk.BracedRobot(braced.robot, [braced.braces[0], replace(braced.braces[1], environment_stiffness=1e4)])
    with pytest.raises(InputError, match="rigid surfaces; brace 1 has an environment stiffness"):
        check_mujoco_contacts(soft, default_holding(two), "capacity ramp")


def test_the_first_brace_to_fail_is_the_least_of_every_brace_s_own_limits(two: bk.Scenario) -> None:
    """Each brace's lift-off and slip scale against its own force f_c0,i + s δf_c,i from the responses."""
    q = validation_configurations(two, 1)[0]
    w = np.array(DEFAULT_WRENCHES[0])
    pred = predicted_limits(two.braced, q, default_holding(two), w)
    assert pred.liftoff.shape == (2,) and pred.slip is not None and pred.slip.shape == (2,)
    for i in range(2):
        r = pred.response(i)
        n = r.normal
        for s, kind in ((pred.liftoff[i], "lift"), (pred.slip[i], "slip")):
            if not np.isfinite(s):
                continue
            f = r.contact_wrench(s * w)[:3]
            fn = float(f @ n)
            ft = float(np.linalg.norm(f - fn * n))
            # at its own scale brace i sits on its own limit: f_n = 0, or ‖f_t‖ = μ f_n
            assert (abs(fn) if kind == "lift" else abs(ft - 0.8 * fn)) < 1e-9 * max(1.0, abs(fn))
    assert pred.margin == min(np.min(pred.liftoff), np.min(pred.slip))
    assert pred.brace == int(np.argmin(np.minimum(pred.liftoff, pred.slip))) and pred.mode == "slipped"


def test_above_the_band_the_expected_outcome_is_the_first_order_state_at_that_load() -> None:
    """A brace past its slip scale can be near its lift-off scale too (they lie 20 % apart on the tutorial's arm,
    where MuJoCo's pad is at the edge of lifting off at 1.2× the slip margin): lift-off's own band decides."""
    from bracekit.validate.holding_check import _expected
    from bracekit.validate.holding_records import Prediction

    close = Prediction(responses=None, liftoff=np.array([0.3789]), slip=np.array([0.3163]))  # type: ignore[arg-type]
    far = Prediction(responses=None, liftoff=np.array([0.5]), slip=np.array([0.3163]))  # type: ignore[arg-type]
    past = Prediction(responses=None, liftoff=np.array([0.3]), slip=np.array([0.25]))  # type: ignore[arg-type]
    s = 1.2 * close.margin
    assert close.mode == "slipped" and 0.8 * 0.3789 < s < 1.2 * 0.3789
    assert _expected(1.2, close, s) == ("lifted_off", ("slipped", "lifted_off"))  # near lift-off: either way
    assert _expected(1.2, far, s) == ("slipped", ("slipped",))  # s = 0.76 × its lift-off
    assert _expected(1.2, past, 1.2 * past.margin) == ("lifted_off", ("slipped", "lifted_off"))  # s = its lift-off
    assert _expected(1.6, past, 1.6 * past.margin) == ("lifted_off", ("lifted_off",))  # 0.40 ≥ 1.2 × 0.3
    assert _expected(0.8, close, 0.8 * close.margin) == ("held", ("held",))
    assert _expected(1.0, close, close.margin) == (None, ())  # inside the band nothing is expected


def test_indeterminate_contact_forces_refuse_the_holding_checks_by_name(two: bk.Scenario) -> None:
    """A sticking pad with three load rows on a body only two joints move: J_bᵀ X has rank ≤ 2 < 3 (a frictionless
    pad on the same body keeps its one row): the split into normal and tangential force is free, so no check."""
    from bracekit.validate.holding_check import check_determinate

    q = validation_configurations(two, 1)[0]
    h = default_holding(two)
    check_determinate(two.braced, [q], h, "holding check")  # the shipped pads are determinate
    robot = two.braced.robot
    j = next(i for i in range(robot.model.nframes) if robot.model.frames[i].parentJoint == 2)
    name = robot.model.frames[j].name
    import pinocchio as pin

    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, q)
    where = data.oMf[j].translation.copy()
    pad = bk.Brace(name, bk.Surface(where, np.array([0.0, 0.0, 1.0])))
    braced = bk.BracedRobot(robot, [pad])
    rank = np.linalg.matrix_rank(braced.state(q).J_b_i[0][:3], tol=1e-9)
    assert rank <= 2
    with pytest.raises(InputError, match="determinate contact forces"):
        check_determinate(braced, [q], Holding(preloads=(5.0,), frictions=(0.8,)), "holding check")
