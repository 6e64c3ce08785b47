"""Tests of the correction's compiled kernel (:mod:`bracekit.simulation._correction_kernel`).

References: Pinocchio's own ``pin.log3`` / ``pin.Jlog3``; the NumPy formulas of the correction module
(``task_error``, ``contact_residual``, ``contact_jacobian``) on ``braced.state``; central finite differences of the
kernel's residual; ``np.linalg.lstsq``; and a whole correction by the NumPy Gauss–Newton loop written out here
(the residual, rows and step from those formulas, the stopping and acceptance rules of the class docstring).
Every contact type (with and without constraint moments), one and two braces, and each task space.
"""

from __future__ import annotations

import dataclasses
import json
import math
import subprocess
import sys

import numpy as np
import pinocchio as pin
import pytest

from bracekit.errors import ConvergenceError
from bracekit.kinematics import BracedRobot
from bracekit.resolution.task_space import POSE, TaskSpace
from bracekit.simulation import _correction_kernel as kernel
from bracekit.simulation.correction import (
    LINE_SEARCH,
    LM_DAMPING,
    Correction,
    contact_jacobian,
    contact_residual,
    norm,
    numpy_point,
    task_error,
)
from bracekit.simulation.scenario import load_scenario
from bracekit.tolerances import ACCEPT_TOL, CORRECTION_ROUNDOFF

SPACES = [POSE, TaskSpace("position"), TaskSpace("position+axis"), TaskSpace("position+axis", axis=[0.3, -0.2, 0.9])]
#: One brace of each contact type (soft finger: a constraint moment), two braces with and without moments.
CONTACTS = [
    ("frictionless_point",),
    ("point_with_friction",),
    ("soft_finger",),
    ("soft_finger", "point_with_friction"),
    ("frictionless_point", "frictionless_point"),
]


def _both(f):  # type: ignore[no-untyped-def]
    """The kernel function compiled and as Python (its ``py_func``; the same function without numba)."""
    return [f, getattr(f, "py_func", f)]


def _braced(contacts: tuple[str, ...]) -> tuple[BracedRobot, np.ndarray]:
    """The two-braces robot (paper robot + a wall pad) with its braces' contact types replaced, and its guess."""
    sc = load_scenario("two-braces")
    braces = [dataclasses.replace(b, contact=c) for b, c in zip(sc.braced.braces, contacts, strict=False)]
    return BracedRobot(sc.braced.robot, braces), np.asarray(sc.guess, dtype=float)


def _anchors(braced: BracedRobot, q: np.ndarray, rng: np.random.Generator) -> list[tuple[np.ndarray, np.ndarray]]:
    """Anchors off the state at q: b0 5 mm away, ⁰R_b0 turned by up to 0.8 rad (log3 far from 0)."""
    out = []
    for c in braced.state(q).contacts:
        turn = pin.exp3(rng.uniform(-0.8, 0.8) * _unit(rng))
        out.append((c.b + 0.005 * _unit(rng), turn @ c.R_b))
    return out


def _unit(rng: np.random.Generator) -> np.ndarray:
    v = rng.standard_normal(3)
    return v / np.linalg.norm(v)


def _rotations() -> list[np.ndarray]:
    """Rotations at every branch of log3 / Jlog3: 0, below and above the Taylor thresholds, generic, near π, π."""
    rng = np.random.default_rng(11)
    axes = [np.eye(3)[i] for i in range(3)] + [_unit(rng) for _ in range(4)]
    angles = [0.0, 1e-12, 1e-8, 1e-6, 6.05545e-6, 1e-5, 1.2e-4, 1e-3, 0.3, 1.0, 2.0, 3.0]
    angles += [math.pi - d for d in (1e-2, 1e-4, 1e-6, 1e-8, 1e-10, 1e-12, 0.0)]
    out = [pin.exp3(a * axis) for a in angles for axis in axes]
    out += [pin.exp3(rng.uniform(0.0, math.pi) * _unit(rng)) for _ in range(200)]
    out += [r + 1e-10 * rng.standard_normal((3, 3)) for r in out[:40]]  # not quite orthonormal: renormalised
    return out


@pytest.mark.parametrize("compiled", [True, False])
def test_log3_and_jlog3_are_pinocchios_to_rounding(compiled: bool) -> None:
    log3, jlog3 = _both(kernel.log3)[not compiled], _both(kernel.jlog3)[not compiled]
    for r in _rotations():
        theta, *w = log3(np.ascontiguousarray(r))
        pin_theta = np.zeros(1)  # Pinocchio's θ (its acos expansion near 0, not |ω| there)
        want = pin.log3(r, pin_theta)
        if abs(theta - math.pi) < 1e-7 and not np.allclose(w, want, atol=1e-12):
            want = -want  # at π, ω and −ω are both the log; the branch's sign comes from round-off of r
        # |ω| = θ / sin θ · |antisymmetric part|: a round-off of the trace moves it by ~1e-15 θ / sin²θ near π
        conditioning = 1e-15 * theta / max(math.sin(theta), 1e-300) ** 2
        np.testing.assert_allclose(w, want, rtol=0.0, atol=4e-15 * max(1.0, theta) + conditioning)
        # θ from the trace: a round-off δ of tr moves θ by δ / (2 sin θ) (≈ 1e-15 / θ near 0 and π)
        assert theta == pytest.approx(pin_theta[0], abs=4e-15 + 1e-15 / max(math.sin(theta), 1e-300))
        if abs(theta - math.pi) >= 1e-7:  # Jlog3 is taken where the log is unique
            np.testing.assert_allclose(jlog3(theta, *w), pin.Jlog3(r), rtol=0.0, atol=1e-13 + conditioning)


def _point(correction: Correction, q: np.ndarray, position: np.ndarray, tol: float = -1.0):  # type: ignore[no-untyped-def]
    """The kernel's point at q: (status, size, norm, residual, rows, step), a full evaluation unless `tol` accepts
    it (then only the residual is meaningful)."""
    point = correction._evaluate(correction._pass(q), position, math.inf, 0, tol=tol)
    return (*point, *(a.copy() for a in correction._buffers[0]))


def _reference_residual_rows(
    braced: BracedRobot, q: np.ndarray, position: np.ndarray, rotation: np.ndarray, anchors, space: TaskSpace
) -> tuple[np.ndarray, np.ndarray]:
    """The residual and rows from ``braced.state`` and the correction module's NumPy formulas."""
    st = braced.state(q)
    s = space.selection(st.R_e)
    res = np.concatenate([s @ task_error(st, position, rotation, space), -contact_residual(st, anchors)])
    return res, np.vstack([s @ st.J_e, contact_jacobian(st, anchors)])


@pytest.mark.parametrize("point", ["compiled", "numpy"])
@pytest.mark.parametrize("space", SPACES, ids=lambda s: s.describe())
@pytest.mark.parametrize("contacts", CONTACTS, ids="+".join)
def test_the_kernel_gives_the_numpy_residual_rows_and_lstsq_step(
    contacts: tuple[str, ...], space: TaskSpace, point: str
) -> None:
    """The compiled point and the NumPy one (a run's without numba) against the module's formulas on braced.state."""
    braced, guess = _braced(contacts)
    rng = np.random.default_rng(len(contacts) + 7 * len(space.describe()))
    for _ in range(3):
        q = guess + 0.2 * rng.standard_normal(braced.n)
        anchors = _anchors(braced, q, rng)
        st = braced.state(q)
        rotation = pin.exp3(0.7 * _unit(rng)) @ st.R_e
        position = st.e + 0.01 * _unit(rng)
        correction = Correction(braced, rotation, anchors, space=space)
        if point == "numpy":
            correction._kernel = numpy_point()
        status, size, scaled, res, rows, step = _point(correction, q, position)
        want_res, want_rows = _reference_residual_rows(braced, q, position, rotation, anchors, space)
        assert status == kernel.STEP and res.shape == (space.rows + sum(x.shape[1] for x in braced.X_i),)
        np.testing.assert_allclose(res, want_res, rtol=0.0, atol=1e-14)
        np.testing.assert_allclose(rows, want_rows, rtol=0.0, atol=1e-13)
        scale = correction.scale
        assert size == pytest.approx(float(np.max(np.abs(want_res) / scale)), rel=1e-13)
        assert scaled == pytest.approx(float(np.linalg.norm(want_res / scale)), rel=1e-13)
        want_step = want_rows.T @ np.linalg.lstsq(want_rows @ want_rows.T, want_res, rcond=None)[0]
        np.testing.assert_allclose(step, want_step, rtol=0.0, atol=1e-10 * np.abs(want_step).max())


@pytest.mark.parametrize("space", SPACES, ids=lambda s: s.describe())
@pytest.mark.parametrize("contacts", CONTACTS, ids="+".join)
def test_the_rows_are_minus_the_derivative_of_the_residual(contacts: tuple[str, ...], space: TaskSpace) -> None:
    """Central differences of the kernel's residual, at a tip on its target orientation (there the task rows S J_e
    are its exact derivative; the contact rows are exact everywhere, log3's derivative included)."""
    braced, guess = _braced(contacts)
    rng = np.random.default_rng(3 + len(contacts))
    q = guess + 0.2 * rng.standard_normal(braced.n)
    anchors = _anchors(braced, q, rng)
    st = braced.state(q)
    correction = Correction(braced, st.R_e.copy(), anchors, space=space)
    position = st.e + 0.01 * _unit(rng)
    rows = _point(correction, q, position)[4]
    h = 1e-6
    columns = []
    for k in range(braced.n):
        dq = np.zeros(braced.n)
        dq[k] = h
        plus = _point(correction, q + dq, position, tol=math.inf)[3]
        minus = _point(correction, q - dq, position, tol=math.inf)[3]
        columns.append((plus - minus) / (2 * h))
    np.testing.assert_allclose(-np.array(columns).T, rows, rtol=0.0, atol=2e-8)


@pytest.mark.parametrize("compiled", [True, False])
def test_the_step_is_lstsqs_minimum_norm_one_also_for_dependent_rows(compiled: bool) -> None:
    """Reference: rowsᵀ np.linalg.lstsq(rows rowsᵀ, res, rcond=None); dependent rows give its finite compromise."""
    min_norm_step = _both(kernel.min_norm_step)[not compiled]
    cholesky_solve = _both(kernel._cholesky_solve)[not compiled]

    def solve(rows: np.ndarray, res: np.ndarray) -> np.ndarray:
        step = np.full(rows.shape[1], np.nan)
        min_norm_step(rows, res, step)
        return step

    rng = np.random.default_rng(4)
    branches: set[bool] = set()
    for m, n in [(1, 4), (5, 11), (7, 11), (11, 11), (13, 11)]:
        # well conditioned (Cholesky), ill conditioned but of full rank (gelsd keeps every σ), dependent rows
        for spread, dependent in ((2, False), (7, False), (2, True)):
            rows = rng.standard_normal((m, n)) * np.logspace(0, -spread, n)
            if dependent and m > 1:  # a repeated row (two braces constraining the same motion) and a combination
                rows[-1] = rows[0]
                rows[m // 2] = 0.5 * rows[0] - 2.0 * rows[-2] if m > 2 else rows[0]
            res = rng.standard_normal(m)
            want = rows.T @ np.linalg.lstsq(rows @ rows.T, res, rcond=None)[0]
            got = solve(rows, res)
            assert np.all(np.isfinite(got))
            # which branch: Cholesky only where LAPACK's eigenvalues say rows rowsᵀ is that well conditioned, and
            # wherever they clear it by m² (tr G ≤ m λ_max, ‖L⁻¹‖_F² = tr G⁻¹ ≤ m / λ_min)
            gram = rows @ rows.T
            certified = cholesky_solve(gram, res).shape[0] == m
            eig = np.linalg.eigvalsh(gram)
            assert not certified or eig[0] >= kernel.WELL_CONDITIONED * eig[-1]
            assert certified or eig[0] < m * m * kernel.WELL_CONDITIONED * eig[-1]
            branches.add(certified)
            # rounding of rows rowsᵀ, grown by its condition where it is ill conditioned
            atol = (1e-10 if spread == 2 else 1e-4) * max(1.0, np.abs(want).max())
            np.testing.assert_allclose(got, want, rtol=0.0, atol=atol)
    assert branches == {True, False}  # both Cholesky and gelsd were taken
    zero = np.zeros((3, 5))
    assert np.array_equal(solve(zero, np.ones(3)), np.zeros(5))


def _reference_correct(correction: Correction, q: np.ndarray, position: np.ndarray) -> tuple[np.ndarray, int]:
    """The correction's Gauss–Newton loop in NumPy on ``braced.state``: the corrected q and its damped steps."""
    braced, scale, space = correction.braced, correction.scale, correction.space
    roundoff = CORRECTION_ROUNDOFF * np.finfo(float).eps * np.sqrt(braced.n)

    def residual(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return _reference_residual_rows(braced, q, position, correction.rotation, correction.anchors, space)

    previous, damped = np.inf, 0
    res, rows = residual(q)
    for _ in range(correction.max_iter):
        size = float(np.max(np.abs(res) / scale))
        if size < correction.tol or (size < ACCEPT_TOL and size > 0.5 * previous):
            return q, damped
        if size < roundoff * max(1.0, float(np.abs(q).max())) * norm(rows / scale[:, None]):
            return q, damped
        previous = size
        t_q = q + rows.T @ np.linalg.lstsq(rows @ rows.T, res, rcond=None)[0]
        t_res, t_rows = residual(t_q)
        if size >= ACCEPT_TOL and norm(t_res / scale) > norm(res / scale):
            damped += 1
            j, r = rows / scale[:, None], res / scale
            jjt = j @ j.T
            found = None
            for damping in LM_DAMPING:
                step = j.T @ np.linalg.solve(jjt + damping * max(np.trace(jjt), 1e-300) * np.eye(r.size), r)
                for fraction in LINE_SEARCH:
                    t_q = q + fraction * step
                    t_res, t_rows = residual(t_q)
                    if norm(t_res / scale) < norm(r):
                        found = t_q
                        break
                if found is not None:
                    break
            assert found is not None, "the reference's damped step found nothing"
        q, res, rows = t_q, t_res, t_rows
    raise AssertionError("the reference did not converge")


@pytest.mark.parametrize("space", SPACES[:3], ids=lambda s: s.describe())
@pytest.mark.parametrize("contacts", CONTACTS, ids="+".join)
def test_a_whole_correction_is_the_numpy_gauss_newton_one(contacts: tuple[str, ...], space: TaskSpace) -> None:
    braced, guess = _braced(contacts)
    rng = np.random.default_rng(17 + len(contacts))
    base = braced.state(guess)
    anchors = [(c.b.copy(), c.R_b.copy()) for c in base.contacts]
    correction = Correction(braced, base.R_e.copy(), anchors, space=space)
    for spread in (0.002, 0.02, 0.05):
        start = guess + spread * rng.standard_normal(braced.n)
        target = base.e + spread * _unit(rng)
        try:
            want, _ = _reference_correct(correction, start, target)
        except AssertionError:  # the reference cannot close it from here: neither can the kernel's loop
            with pytest.raises(ConvergenceError):
                correction(start, target)
            continue
        got = correction(start, target).q
        np.testing.assert_allclose(got, want, rtol=0.0, atol=1e-11)


@pytest.mark.parametrize(
    ("contacts", "space"), [(("soft_finger",), POSE), (("frictionless_point", "frictionless_point"), SPACES[1])]
)
def test_far_starts_take_the_reference_levenberg_marquardt_path_or_fail_as_it_does(
    contacts: tuple[str, ...], space: TaskSpace
) -> None:
    """Starts far enough off that a Gauss–Newton step raises the residual (as the reference loop finds)."""
    braced, guess = _braced(contacts)
    rng = np.random.default_rng(23)
    base = braced.state(guess)
    anchors = [(c.b.copy(), c.R_b.copy()) for c in base.contacts]
    correction = Correction(braced, base.R_e.copy(), anchors, space=space)
    found = failed = 0
    for _ in range(12):
        start = guess + 0.6 * rng.standard_normal(braced.n)
        target = base.e + 0.2 * _unit(rng)
        try:
            want, damped = _reference_correct(correction, start, target)
        except AssertionError:  # the reference cannot close it: neither can the kernel's loop
            failed += 1
            with pytest.raises(ConvergenceError):
                correction(start, target)
            continue
        found += damped > 0
        # the same path: rounding grows along far-off iterations and the stalled stop (below ACCEPT_TOL)
        np.testing.assert_allclose(correction(start, target).q, want, rtol=0.0, atol=1e-7)
    assert found >= 3, "too few starts needed the damped step"


def test_dependent_braces_are_harmless() -> None:
    """Two braces on one frame and surface: their rows repeat; the correction closes both, at the reference's q."""
    sc = load_scenario("paper")
    braced = BracedRobot(sc.braced.robot, [sc.braced.braces[0], sc.braced.braces[0]])
    guess = np.asarray(sc.guess, dtype=float)
    base = braced.state(guess)
    anchors = [(c.b.copy(), c.R_b.copy()) for c in base.contacts]
    correction = Correction(braced, base.R_e.copy(), anchors)
    rng = np.random.default_rng(2)
    for _ in range(3):
        start, target = guess + 0.02 * rng.standard_normal(braced.n), base.e + 0.01 * _unit(rng)
        out = correction(start, target)
        np.testing.assert_allclose(out.q, _reference_correct(correction, start, target)[0], rtol=0.0, atol=1e-11)
        assert np.max(np.abs(contact_residual(out, anchors))) < 1e-10


def test_the_kernels_codes_are_the_correctors() -> None:
    from bracekit.simulation import correction as module

    assert (module._STEP, module._DONE) == (kernel.STEP, kernel.DONE) and kernel.FLOOR not in (kernel.STEP, kernel.DONE)
    assert module._KINDS == {"pose": kernel.POSE, "position": kernel.POSITION, "position+axis": kernel.POSITION_AXIS}


def test_without_numba_the_numpy_point_runs_the_run_says_so_and_follows_the_same_path() -> None:
    """A short braced run in a process where numba cannot be imported, against the same run here (compiled)."""
    pytest.importorskip("numba")
    from bracekit.simulation.notes import CORRECTION_BACKEND_NOTE

    code = (
        "import json, sys; sys.modules['numba'] = None\n"
        "from bracekit.simulation import _correction_kernel as k; assert not k.COMPILED\n"
        f"{_RUN}\n"
        "print(json.dumps(run()))"
    )
    here = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=False)
    assert here.returncode == 0, here.stderr
    plain = json.loads(here.stdout.strip().splitlines()[-1])
    namespace: dict[str, object] = {}
    exec(_RUN, namespace)  # the same run, compiled, in this process
    compiled = namespace["run"]()  # type: ignore[operator]
    note = f"braced_min_norm: {CORRECTION_BACKEND_NOTE}"
    assert note in plain["warnings"] and note not in compiled["warnings"]
    assert [w for w in plain["warnings"] if w != note] == compiled["warnings"]
    assert np.max(np.abs(np.array(plain["q"]) - np.array(compiled["q"]))) < 1e-9


_RUN = """
def run():
    import warnings
    from bracekit import Circle, load_scenario, simulate, solve_start
    sc = load_scenario("paper")
    start = solve_start(sc.braced, sc.task.position(0.0), sc.guess)
    c = sc.task
    task = Circle(c.centre, c.radius, c.normal, c.period, c.start_direction, turns=0.05)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        tr = simulate(sc.braced, sc.strategy("braced_min_norm"), task, start.q, sc.dt, sc.beta_x)
    return {"q": tr.q.tolist(), "warnings": list(tr.warnings)}
"""


def test_a_chain_beyond_pinocchios_data_corrects_through_the_chain_kinematics() -> None:
    """n > DATA_JOINT_LIMIT: the passes read ChainFK's frames (no Pinocchio Data); the reference reads braced.state."""
    from bracekit.contact import Brace, Surface
    from bracekit.model.chain import DATA_JOINT_LIMIT
    from bracekit.model.robot import Robot
    from helpers import random_chain_urdf

    n = DATA_JOINT_LIMIT + 4
    robot = Robot.from_urdf(random_chain_urdf(n, seed=5, brace_link=n // 2), tip="tip")
    braced = BracedRobot(robot, Brace("brace", Surface(np.zeros(3), np.array([0.0, 0.0, 1.0])), "soft_finger"))
    rng = np.random.default_rng(8)
    q0 = 0.3 * rng.standard_normal(n)
    base = braced.state(q0)
    anchors = [(c.b.copy(), c.R_b.copy()) for c in base.contacts]
    correction = Correction(braced, base.R_e.copy(), anchors)
    assert correction._pin is None
    start, target = q0 + 0.01 * rng.standard_normal(n), base.e + 0.005 * _unit(rng)
    out = correction(start, target)
    np.testing.assert_allclose(out.q, _reference_correct(correction, start, target)[0], rtol=0.0, atol=1e-11)
    assert np.max(np.abs(contact_residual(out, anchors))) < 1e-10


def test_a_target_position_of_another_shape_is_refused_by_name() -> None:
    from bracekit.errors import InputError

    braced, guess = _braced(("frictionless_point",))
    st = braced.state(guess)
    correction = Correction(braced, st.R_e.copy(), [(c.b.copy(), c.R_b.copy()) for c in st.contacts])
    for bad in (st.e[:2], np.append(st.e, 0.0), st.e[:, None]):
        with pytest.raises(InputError, match="3 numbers"):
            correction(guess, bad)
    assert np.allclose(correction(guess, list(st.e)).e, st.e, atol=1e-12)  # a list of 3 numbers is fine
