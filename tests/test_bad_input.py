"""Bad input to the public API gives bracekit's own one-line errors: never a bare NumPy, SciPy or Boost error.

Each entry of ``bracekit.__all__`` that takes arrays, numbers or paths is called with one argument replaced
by a bad value (NaN, inf, wrong shapes, wrong types, strings, None, negative numbers) drawn by hypothesis.
The call must either raise a BracekitError subclass with a one-line message or, when the value happens to
be valid, return a result without NaN. Any warning other than bracekit's own fails the test (a NumPy
RuntimeWarning such as "overflow encountered in matmul" included).
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import array_shapes, arrays

import bracekit as bk
from bracekit.errors import BracekitError, BracekitWarning
from bracekit.model.shipped import model_path
from bracekit.objective import BraceAngle
from bracekit.resolution import GradientProjectionStep
from bracekit.simulation.scenario import shipped_scenarios
from helpers import scenario_text

SETTINGS = settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])

Q = np.array([0.0, 0.194, -2.598, 0.0, -0.737, -2.498, -1.898, 3.142, 2.106, 2.438, 0.867])
E_X = np.array([1.0, 0.0, 0.0, 0.0, 0.0, 0.0])
ROBOT = bk.load_model("paper-robot")
SURFACE = bk.Surface(np.array([0.70, -0.15, -0.30]), np.array([0.0, 0.0, 1.0]))
BRACE = bk.Brace("brace", SURFACE, region_radius=0.15)
BRACED = bk.BracedRobot(ROBOT, BRACE)
STATE = BRACED.state(Q)
C_E = bk.end_effector_compliance(STATE)
PUMA = model_path("puma560")
SHIPPED = set(shipped_scenarios())


class _Opaque:
    """An object of no type bracekit knows."""


#: Values that are wrong for most arguments: non-finite, wrongly typed, ragged, empty, negative, huge.
SPECIAL = st.sampled_from(
    [
        math.nan,
        math.inf,
        -math.inf,
        None,
        "abc",
        "",
        "<robot",
        b"bytes",
        [],
        [[1.0, 2.0], [3.0]],
        ["1", "2", "3"],
        {},
        {"a": 1},
        _Opaque(),
        True,
        0,
        -1,
        -1.0,
        1e308,
        -1e308,
        1e-320,
        2**70,
        1j,
        np.full(3, np.nan),
        np.full((6, 6), np.inf),
        np.eye(2),
        np.zeros((0, 3)),
        np.array(["a", "b", "c"]),
    ]
)
FLOATS = st.floats(allow_nan=True, allow_infinity=True, width=64)
ARRAYS = arrays(np.float64, array_shapes(min_dims=0, max_dims=3, max_side=7), elements=FLOATS)
BAD = st.one_of(
    SPECIAL,
    ARRAYS,
    FLOATS,
    st.integers(-3, 3),
    st.text(max_size=6).filter(lambda s: s not in SHIPPED),
    st.lists(st.one_of(FLOATS, st.none(), st.text(max_size=2)), max_size=7),
)


def _has_nan(value: Any) -> bool:
    """Whether a result holds a NaN anywhere (numbers, arrays, lists, dicts, dataclasses)."""
    if isinstance(value, float | np.floating):
        return math.isnan(value)
    if isinstance(value, np.ndarray):
        return value.dtype.kind == "f" and bool(np.isnan(value).any())
    if isinstance(value, dict):
        return any(_has_nan(v) for v in value.values())
    if isinstance(value, list | tuple):
        return any(_has_nan(v) for v in value)
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return any(_has_nan(getattr(value, f.name)) for f in dataclasses.fields(value) if f.name != "braced")
    return False


def check(call: Callable[[], Any]) -> None:
    """The call raises a BracekitError with a one-line message, or returns a result without NaN."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a NumPy or SciPy warning is a failure
        warnings.simplefilter("ignore", BracekitWarning)  # bracekit's own warnings are legitimate
        try:
            result = call()
        except BracekitError as exc:
            msg = str(exc)
            assert msg.strip() and "\n" not in msg, repr(msg)
            return
    assert not _has_nan(result), f"returned NaN: {result!r}"


def replaced(valid: dict[str, Any], key: str, bad: Any) -> dict[str, Any]:
    return {**valid, key: bad}


# ---------------------------------------------------------------------------------------------- the entries
# (function, valid keyword arguments, arguments to spoil, values that are valid for an argument and slow)
ENTRIES: list[tuple[str, Callable[..., Any], dict[str, Any], tuple[str, ...]]] = [
    (
        "Robot.from_urdf",
        bk.Robot.from_urdf,
        {"source": PUMA, "tip": "flange", "stiffness": 170.0},
        ("source", "tip", "stiffness"),
    ),
    ("load_model", bk.load_model, {"name": "puma560", "stiffness": 170.0, "tip": None}, ("name", "stiffness", "tip")),
    (
        "Surface",
        bk.Surface,
        {"point": np.zeros(3), "normal": np.array([0.0, 0.0, 1.0]), "tangent": None},
        ("point", "normal", "tangent"),
    ),
    (
        "Brace",
        bk.Brace,
        {
            "frame": "brace",
            "surface": SURFACE,
            "contact": "frictionless_point",
            "region_radius": 0.15,
            "environment_stiffness": None,
        },
        ("frame", "surface", "contact", "region_radius", "environment_stiffness"),
    ),
    ("contact_type", bk.contact_type, {"name": "soft_finger"}, ("name",)),
    ("BracedRobot", bk.BracedRobot, {"robot": ROBOT, "brace": BRACE}, ("robot", "brace")),
    ("BracedRobot.state", BRACED.state, {"q": Q, "hessians": False}, ("q", "hessians")),
    (
        "end_effector_compliance",
        bk.end_effector_compliance,
        {"state": STATE, "model": "constrained"},
        ("state", "model"),
    ),
    ("free_space_compliance", bk.free_space_compliance, {"state": STATE}, ("state",)),
    (
        "preloaded_compliance",
        bk.preloaded_compliance,
        {"braced": BRACED, "q": Q, "preload": 1.0},
        ("braced", "q", "preload"),
    ),
    ("compliance_index", bk.compliance_index, {"c_e": C_E, "beta_x": E_X}, ("c_e", "beta_x")),
    (
        "directional_compliance",
        bk.directional_compliance,
        {"c_e": C_E, "beta_x": E_X, "beta_w": E_X},
        ("c_e", "beta_x", "beta_w"),
    ),
    ("compliance_ellipsoids", bk.compliance_ellipsoids, {"c_e": C_E}, ("c_e",)),
    ("frobenius_condition", bk.frobenius_condition, {"J": STATE.J_e}, ("J",)),
    ("singular_value_measures", bk.singular_value_measures, {"J": STATE.split.J_braced}, ("J",)),
    ("theta_z", bk.theta_z, {"z_t": np.array([0.0, 0.0, 1.0]), "z_b": STATE.split.z_b}, ("z_t", "z_b")),
    ("region_barrier", bk.compliance.region_barrier, {"r": 0.05, "r_max": 0.15}, ("r", "r_max")),
    ("Objective", bk.Objective, {"terms": [bk.ConditionNumber()], "weights": [1.0]}, ("terms", "weights")),
    ("ComplianceIndex", bk.ComplianceIndex, {"beta_x": E_X, "model": "constrained"}, ("beta_x", "model")),
    ("RegionBarrier", bk.RegionBarrier, {"r_max": 0.15, "centre": np.zeros(3)}, ("r_max", "centre")),
    ("BraceAngle", BraceAngle, {"name": "theta_z"}, ("name",)),
    ("ConditionNumber", bk.ConditionNumber, {"name": "k"}, ("name",)),
    (
        "Circle",
        bk.Circle,
        {
            "centre": np.zeros(3),
            "radius": 0.1,
            "normal": np.array([0.0, 1.0, 0.0]),
            "period": 2.0,
            "start_direction": np.array([1.0, 0.0, 0.0]),
            "rotation": None,
            "turns": 1.0,
        },
        ("centre", "radius", "normal", "period", "start_direction", "rotation", "turns"),
    ),
    (
        "Line",
        bk.Line,
        {"start": np.zeros(3), "end": np.ones(3), "duration": 1.0, "rotation": None},
        ("start", "end", "duration", "rotation"),
    ),
    (
        "Waypoints",
        bk.Waypoints,
        {"points": np.eye(3), "times": np.array([0.0, 1.0, 2.0]), "rotation": None},
        ("points", "times", "rotation"),
    ),
    ("load_scenario", bk.load_scenario, {"source": "paper"}, ("source",)),
    (
        "evaluate",
        bk.evaluate,
        {
            "robot": ROBOT,
            "brace_frame": "brace",
            "q": Q,
            "normal": (0.0, 0.0, 1.0),
            "contact": "frictionless_point",
            "beta_x": None,
        },
        ("robot", "brace_frame", "q", "normal", "contact", "beta_x"),
    ),
    (
        "evaluate_batch",
        bk.evaluate_batch,
        {
            "braced": BRACED,
            "Q": np.vstack([Q, Q + 0.01]),
            "beta_x": E_X,
            "models": ("constrained",),
            "errors": "raise",
            "k_braced": False,
        },
        ("braced", "Q", "beta_x", "models", "errors", "k_braced"),
    ),
    (
        "brace_location_study",
        bk.brace_location_study,
        {
            "robot": ROBOT,
            "q": Q,
            "normal": (0.0, 0.0, 1.0),
            "beta_x": None,
            "points_per_link": 1,
            "contact": "frictionless_point",
        },
        ("robot", "q", "normal", "beta_x", "points_per_link", "contact"),
    ),
]
# the resolution and the simulation: a short line task (2 steps) so that a bad value that passes is cheap
_OBJECTIVE = bk.Objective([bk.ConditionNumber(), bk.ComplianceIndex(E_X)], [0.5, 100.0])
_GP = bk.BracedGradientProjection(_OBJECTIVE)
_LINE = bk.Line(STATE.e, STATE.e + np.array([0.002, 0.0, 0.0]), 0.1)
_XDOT = np.array([0.01, 0.0, 0.0, 0.0, 0.0, 0.0])
ENTRIES += [
    ("FreeSpaceMinNorm.velocity", bk.FreeSpaceMinNorm().velocity, {"state": STATE, "xdot": _XDOT}, ("xdot",)),
    ("BracedMinNorm.velocity", bk.BracedMinNorm().velocity, {"state": STATE, "xdot": _XDOT}, ("xdot",)),
    (
        "BracedGradientProjection.velocity",
        _GP.velocity,
        {"state": BRACED.state(Q, hessians=True), "xdot": _XDOT},
        ("xdot",),
    ),
    (
        "BracedGradientProjection",
        bk.BracedGradientProjection,
        {"objective": _OBJECTIVE, "alpha": -1.0, "gradient": "analytic", "fd_step": 1e-5},
        ("objective", "alpha", "gradient", "fd_step"),
    ),
    (
        "GradientProjectionStep",
        lambda **kw: GradientProjectionStep(BRACED, _GP)(**kw),
        {"q": Q, "xdot": _XDOT, "beta_x": None},
        ("q", "xdot", "beta_x"),
    ),
    (
        "simulate",
        bk.simulate,
        {
            "braced": BRACED,
            "strategy": bk.BracedMinNorm(),
            "task": _LINE,
            "q0": Q,
            "dt": 0.05,
            "beta_x": lambda t: E_X,
            "feedback_gain": 1.0,
        },
        ("strategy", "task", "q0", "dt", "beta_x", "feedback_gain"),
    ),
]
_W = np.array([[0.0, 0.0, -10.0, 0.0, 0.0, 0.0]])
ENTRIES += [
    (
        "Holding",
        bk.Holding,
        {"gravity": True, "preload": 5.0, "friction": 0.5, "wrenches": _W},
        ("gravity", "preload", "friction", "wrenches"),
    ),
    (
        "contact_response",
        bk.contact_response,
        {"braced": BRACED, "q": Q, "preload": 5.0, "gravity": True, "friction": 0.5},
        ("braced", "q", "preload", "gravity", "friction"),
    ),
    (
        "load_capacity",
        bk.load_capacity,
        {"braced": BRACED, "q": Q, "wrenches": _W, "preload": 5.0, "gravity": False, "friction": 0.5},
        ("braced", "q", "wrenches", "preload", "friction"),
    ),
    (
        "capacity_along",
        bk.capacity_along,
        {"braced": BRACED, "qs": np.vstack([Q, Q]), "wrenches": _W, "preload": 5.0, "gravity": False, "friction": None},
        ("braced", "qs", "wrenches", "preload", "friction"),
    ),
    (
        "actuator_relief",
        bk.actuator_relief,
        {"braced": BRACED, "qs": np.vstack([Q, Q]), "wrenches": _W},
        ("braced", "qs", "wrenches"),
    ),
]
ENTRIES.append(
    ("TaskSpace", bk.TaskSpace, {"kind": "position+axis", "axis": np.array([0.0, 0.0, 1.0])}, ("kind", "axis"))
)
CASES = [(name, fn, valid, key) for name, fn, valid, keys in ENTRIES for key in keys]
#: Public names that take no values of a user (types, results, exceptions) and so need no entry above.
TAKES_NO_VALUES = {
    "BracedState",
    "BracekitError",
    "BracekitWarning",
    "InputError",
    "NumericalError",
    "RunResult",
    "Scenario",
    "Term",
    "Trajectory",
    "__version__",
}


@pytest.mark.parametrize(("name", "fn", "valid", "key"), CASES, ids=[f"{c[0]}-{c[3]}" for c in CASES])
@SETTINGS
@given(bad=BAD)
def test_bad_values_give_bracekit_errors(name: str, fn: Callable[..., Any], valid: dict, key: str, bad: Any) -> None:
    if name == "evaluate_batch" and key == "errors" and isinstance(bad, str) and bad == "nan":
        return  # errors="nan" asks for NaN where k is singular
    if name == "brace_location_study" and key == "points_per_link" and isinstance(bad, int) and bad > 3:
        return  # a valid count: only slower
    check(lambda: fn(**replaced(valid, key, bad)))


def test_every_public_entry_that_takes_values_is_covered() -> None:
    """Every name of bracekit.__all__ has an entry above, or is listed as taking no values (a type or a result)."""
    covered = {name.split(".")[0] for name, *_ in ENTRIES} | {"run_scenario", "solve_start"}
    missing = set(bk.__all__) - covered - TAKES_NO_VALUES
    assert not missing, f"public entries without a bad-input test: {sorted(missing)}"


# ---------------------------------------------------------------------------------------------- paths and runs
#: Path-like values that do not name a scenario file.
BAD_SOURCES = st.one_of(
    BAD,
    st.sampled_from([Path("/no/such/file.toml"), Path("/"), Path(__file__), Path("paper"), Path(".")]),
)


@SETTINGS
@given(source=BAD_SOURCES)
def test_run_scenario_with_a_bad_path_gives_bracekit_errors(source: Any) -> None:
    check(lambda: bk.run_scenario(source))


@pytest.fixture(scope="module")
def short_scenario(tmp_path_factory: pytest.TempPathFactory) -> bk.Scenario:
    path = tmp_path_factory.mktemp("scenario") / "short.toml"
    path.write_text(scenario_text(turns=0.05, dt=0.5), encoding="utf-8")
    return bk.load_scenario(path)


@pytest.mark.parametrize("key", ["gradient", "compliance_model", "both_models", "progress"])
@SETTINGS
@given(bad=BAD.filter(lambda v: v is not None and not isinstance(v, bool)))
def test_run_scenario_with_bad_options_gives_bracekit_errors(short_scenario: bk.Scenario, key: str, bad: Any) -> None:
    check(lambda: bk.run_scenario(short_scenario, **{key: bad}))


#: Values that are not a valid start position, guess or rotation (a finite value of the right shape could be
#: one, and would start a long solve).
def _not_a_valid(shape: tuple[int, ...]) -> Callable[[Any], bool]:
    def keep(value: Any) -> bool:
        try:
            a = np.asarray(value, dtype=float)
        except (TypeError, ValueError, OverflowError):
            return True
        return a.size != int(np.prod(shape)) or not np.all(np.isfinite(a))

    return keep


@pytest.mark.parametrize(("key", "shape"), [("position", (3,)), ("guess", (11,)), ("rotation", (3, 3))])
@SETTINGS
@given(data=st.data())
def test_solve_start_with_bad_values_gives_bracekit_errors(
    key: str, shape: tuple[int, ...], data: st.DataObject
) -> None:
    bad = data.draw(BAD.filter(_not_a_valid(shape)).filter(lambda v: not (key == "rotation" and v is None)))
    valid = {"position": np.array([1.34, -0.32, -0.17]), "guess": Q, "rotation": None}
    check(lambda: bk.solve_start(BRACED, **replaced(valid, key, bad)))


@pytest.mark.parametrize("huge", [3e307, -3e307])
def test_finite_inputs_whose_sum_overflows_are_checked_without_numpys_warning(huge: float) -> None:
    """A twist or q of finite values too large to add: a bracekit error or a result, no NumPy warning."""
    q = BRACED.robot.neutral()
    check(lambda: GradientProjectionStep(BRACED, _GP)(q, np.full(6, huge)))
    check(lambda: BRACED.state(np.full_like(q, huge)))
