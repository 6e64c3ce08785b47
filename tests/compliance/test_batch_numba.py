"""The numba backend of batch evaluation (bracekit.compliance.batch) equals the NumPy batch and the single path.

References: the NumPy backend of ``evaluate_batch`` and ``end_effector_compliance`` / ``compliance_index`` /
``frobenius_condition`` on ``braced.state(q)``, one configuration at a time, on the paper's robot, the Panda braced
on several links and random chains with every contact type; where the NumPy batch raises or warns, with a compliant
environment, in threads and in a forked process; the backend choice when numba is missing. The tests skip without
numba. No timing is asserted here.
"""

from __future__ import annotations

import dataclasses
import sys
import warnings

import numpy as np
import pinocchio as pin
import pytest
from test_batch import _rel

from bracekit import (
    Brace,
    BracedRobot,
    InputError,
    Robot,
    Surface,
    compliance_index,
    end_effector_compliance,
    frobenius_condition,
    load_model,
    load_scenario,
)
from bracekit.compliance.batch import BatchEvaluator, evaluate_batch
from bracekit.compliance.chain_kinematics import ChainKinematics
from bracekit.contact import contact_type
from bracekit.errors import SingularityError, UnloadedContactWarning
from helpers import random_chain_urdf


def _panda(link: int, contact: str = "frictionless_point") -> BracedRobot:
    robot = load_model("panda").with_point_frame("pad", f"panda_link{link}", (0.05, 0.02, 0.0))
    return BracedRobot(robot, Brace("pad", Surface(np.zeros(3), (0.1, 0.2, 1.0)), contact_type(contact)))


def _random_braced(seed: int, contact: str) -> BracedRobot:
    robot = Robot.from_urdf(random_chain_urdf(9, seed=seed, brace_link=4), tip="tip", stiffness=np.linspace(90, 250, 9))
    rng = np.random.default_rng(seed)
    return BracedRobot(robot, Brace("brace", Surface(np.zeros(3), rng.normal(size=3)), contact_type(contact)))


def _same_evaluation(a, b, tol: float) -> None:
    assert a.models == b.models
    for m in a.models:
        assert _rel(a.C_e[m], b.C_e[m]) <= tol
        np.testing.assert_allclose(a.Ci[m], b.Ci[m], rtol=tol, atol=0.0)
    np.testing.assert_allclose(a.k, b.k, rtol=tol, atol=0.0)  # NaN where the other has NaN
    if a.k_braced is None or b.k_braced is None:
        assert a.k_braced is None and b.k_braced is None
    else:
        np.testing.assert_allclose(a.k_braced, b.k_braced, rtol=tol, atol=0.0)


def _robot_cases():
    sc = load_scenario("paper")
    return {
        "paper": sc.braced,
        "paper-friction": BracedRobot(
            sc.robot, dataclasses.replace(sc.braced.brace, contact=contact_type("soft_finger"))
        ),
        "panda-3": _panda(3),
        "panda-4": _panda(4, "point_with_friction"),
        "panda-5": _panda(5),
        "random-point": _random_braced(21, "frictionless_point"),
        "random-soft": _random_braced(22, "soft_finger"),
    }


@pytest.mark.parametrize(
    "case", ["paper", "paper-friction", "panda-3", "panda-4", "panda-5", "random-point", "random-soft"]
)
def test_numba_batch_equals_the_numpy_batch_and_the_single_configuration_path(case: str) -> None:
    pytest.importorskip("numba")
    braced = _robot_cases()[case]
    rng = np.random.default_rng(len(case))
    lo = np.where(np.isfinite(braced.robot.lower), braced.robot.lower, -3.0)
    hi = np.where(np.isfinite(braced.robot.upper), braced.robot.upper, 3.0)
    Q = rng.uniform(lo, hi, size=(40, braced.n))
    beta = rng.normal(size=6)
    nb, npb = BatchEvaluator(braced, backend="numba"), BatchEvaluator(braced, backend="numpy")
    assert (nb.backend, npb.backend) == ("numba", "numpy") and nb.fallback_reason is None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UnloadedContactWarning)
        got = nb(Q, beta, k_braced=True, errors="nan")
        _same_evaluation(got, npb(Q, beta, k_braced=True, errors="nan"), 1e-10)
        betas = rng.normal(size=(len(Q), 6))  # one β_x per row, one model
        _same_evaluation(nb(Q, betas, models=("projection",)), npb(Q, betas, models=("projection",)), 1e-10)
    for i in range(0, len(Q), 4):  # the single-configuration path
        st = braced.state(Q[i])
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UnloadedContactWarning)
            for m in ("constrained", "projection"):
                c_e = end_effector_compliance(st, m)  # type: ignore[arg-type]
                assert _rel(got.C_e[m][i], c_e) < 1e-10
                assert got.Ci[m][i] == pytest.approx(compliance_index(c_e, beta), rel=1e-10)
        assert got.k[i] == pytest.approx(frobenius_condition(st.J_e), rel=1e-10)
        try:
            kb = frobenius_condition(st.split.J_braced)
        except SingularityError:
            assert np.isnan(got.k_braced[i])
        else:
            assert got.k_braced[i] == pytest.approx(kb, rel=1e-10)


def _outcome(fn):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            value = fn()
        except Exception as exc:  # compare errors by type and message
            value = (type(exc).__name__, str(exc))
    return value, [(w.category.__name__, str(w.message)) for w in caught]


def test_numba_batch_reports_singular_configurations_like_the_numpy_batch() -> None:
    pytest.importorskip("numba")
    # a soft finger at link 5 leaves J̃ of rank ≤ 4 (k of J̃ unbounded everywhere); the Panda's zero pose is
    # singular itself (joints 1, 3 and 5 aligned)
    braced = _panda(5, "soft_finger")
    Q = np.random.default_rng(3).uniform(-1.5, 1.5, size=(6, 7))
    Q[3] = 0.0
    with pytest.raises(SingularityError):
        frobenius_condition(braced.state(Q[3]).J_e)
    beta = np.r_[0.0, 0.0, 1.0, 0.0, 0.0, 0.0]
    for kw in ({}, {"k_braced": True, "chunk": 2}, {"k_braced": True, "chunk": 4}, {"errors": "nan", "k_braced": True}):
        outcomes = [
            _outcome(lambda b=b, kw=kw: BatchEvaluator(braced, backend=b)(Q, beta, **kw)) for b in ("numba", "numpy")
        ]
        (nb, nb_warn), (npb, np_warn) = outcomes
        assert nb_warn == np_warn
        if isinstance(npb, tuple):
            assert nb == npb and npb[0] == "SingularityError"
        else:
            _same_evaluation(nb, npb, 1e-10)
            assert np.isnan(nb.k[3]) and np.all(np.isnan(nb.k_braced)) and np.all(np.isfinite(np.delete(nb.k, 3)))
    # the first singular configuration in the NumPy path's order: chunk by chunk, k before k of J̃
    assert _outcome(lambda: BatchEvaluator(braced)(Q, beta, k_braced=True, chunk=4))[0][1].startswith("configuration 3")
    assert _outcome(lambda: BatchEvaluator(braced)(Q, beta, k_braced=True, chunk=2))[0][1].startswith("configuration 0")


@pytest.mark.parametrize("model", ["constrained", "projection"])
def test_numba_batch_raises_numerical_error_like_the_numpy_batch(model: str) -> None:
    pytest.importorskip("numba")
    robot = Robot.from_urdf(random_chain_urdf(8, seed=6, brace_link=4), tip="tip")
    object.__setattr__(robot, "stiffness", np.full(robot.n, 1e-320))  # 1/K overflows (range check bypassed)
    braced = BracedRobot(robot, Brace("brace", Surface(np.zeros(3), (0.0, 0.0, 1.0))))
    Q = np.random.default_rng(1).uniform(-2, 2, size=(4, robot.n))
    with np.errstate(all="ignore"):
        nb, npb = (
            _outcome(lambda b=b: evaluate_batch(braced, Q, np.r_[1.0, 0, 0, 0, 0, 0], models=(model,), backend=b))
            for b in ("numba", "numpy")
        )
    assert nb == npb and nb[0][0] == "NumericalError"


def test_numba_batch_warns_like_the_numpy_batch_when_the_contact_is_unloaded() -> None:
    pytest.importorskip("numba")
    robot = Robot.from_urdf(random_chain_urdf(6, seed=4), tip="tip").with_point_frame("pad", "l1", (0.2, 0.1, 0.0))
    data = robot.model.createData()
    pin.computeJointJacobians(robot.model, data, np.zeros(robot.n))
    z = pin.getJointJacobian(robot.model, data, 1, pin.ReferenceFrame.WORLD)[3:, 0]
    Q = np.random.default_rng(0).uniform(-2, 2, size=(5, robot.n))
    for contact in ("frictionless_point", "point_with_friction"):  # one constraint direction, and three (Jacobi)
        braced = BracedRobot(robot, Brace("pad", Surface(np.zeros(3), z), contact_type(contact)))
        (nb, nb_warn), (npb, np_warn) = (
            _outcome(lambda b=b, br=braced: evaluate_batch(br, Q, np.r_[1.0, 0, 0, 0, 0, 0], backend=b))
            for b in ("numba", "numpy")
        )
        assert nb_warn == np_warn and len(nb_warn) == 1 and "at 5 of 5 configurations" in nb_warn[0][1]
        _same_evaluation(nb, npb, 1e-10)


def test_numba_batch_with_a_compliant_environment() -> None:
    pytest.importorskip("numba")
    sc = load_scenario("paper")
    Q = np.random.default_rng(8).uniform(sc.robot.lower, sc.robot.upper, size=(30, sc.robot.n))
    for contact in ("frictionless_point", "soft_finger"):
        brace = dataclasses.replace(sc.braced.brace, environment_stiffness=5e3, contact=contact_type(contact))
        braced = BracedRobot(sc.robot, brace)
        beta = np.r_[0.0, 0.3, 1.0, 0.0, 0.0, 0.0]
        _same_evaluation(
            evaluate_batch(braced, Q, beta, backend="numba"), evaluate_batch(braced, Q, beta, backend="numpy"), 1e-10
        )
        st = braced.state(Q[0])
        ref = end_effector_compliance(st, "constrained")
        assert _rel(evaluate_batch(braced, Q[:1], beta, backend="numba").C_e["constrained"][0], ref) < 1e-10


def test_numba_batch_threads(paper) -> None:
    numba = pytest.importorskip("numba")
    sc, Q = paper
    ev = BatchEvaluator(sc.braced, backend="numba")
    beta = sc.beta_x(0.0)
    before = numba.get_num_threads()
    one, many = ev(Q, beta, threads=1), ev(Q, beta)
    _same_evaluation(one, many, 0.0)  # configurations are independent: the same numbers on any thread
    _same_evaluation(ev(Q, beta, threads=numba.config.NUMBA_NUM_THREADS), many, 0.0)
    assert numba.get_num_threads() == before  # restored after the call
    for bad in (0, numba.config.NUMBA_NUM_THREADS + 1, 1.5, "2"):
        with pytest.raises(InputError):
            ev(Q, beta, threads=bad)


def test_backend_choice_and_numba_missing(paper, monkeypatch) -> None:
    sc, Q = paper
    with pytest.raises(InputError, match="unknown backend"):
        BatchEvaluator(sc.braced, backend="fortran")  # type: ignore[arg-type]
    ev = BatchEvaluator(sc.braced, backend="numpy")
    assert (ev.backend, ev.fallback_reason) == ("numpy", None)
    # numba not installed: "numba" is a clear InputError, "auto" is NumPy and says why
    monkeypatch.setitem(sys.modules, "numba", None)
    monkeypatch.delitem(sys.modules, "bracekit.compliance._numba_batch", raising=False)
    with pytest.raises(InputError, match=r"pip install bracekit\[fast\]"):
        BatchEvaluator(sc.braced, backend="numba")
    auto = BatchEvaluator(sc.braced)
    assert auto.backend == "numpy" and "numba cannot be imported" in (auto.fallback_reason or "")
    beta = sc.beta_x(0.0)
    _same_evaluation(auto(Q, beta, threads=1), ev(Q, beta), 0.0)


def test_numba_batch_runs_the_numpy_code_for_joints_the_product_of_exponentials_does_not_model(
    paper, monkeypatch
) -> None:
    pytest.importorskip("numba")
    sc, Q = paper
    monkeypatch.setattr(ChainKinematics, "_check", lambda self: False)  # as for a screw joint off its origin
    ev = BatchEvaluator(sc.braced, backend="numba")
    assert ev.backend == "numpy" and "joint" in (ev.fallback_reason or "")
    _same_evaluation(
        ev(Q[:5], sc.beta_x(0.0)), BatchEvaluator(sc.braced, backend="numpy")(Q[:5], sc.beta_x(0.0)), 1e-12
    )


def _forked_k(Q: np.ndarray, beta: np.ndarray) -> np.ndarray:
    braced = load_scenario("paper").braced
    return BatchEvaluator(braced, backend="numba")(Q, beta).k


def test_numba_batch_in_a_process_forked_after_the_parallel_kernel_ran(paper) -> None:
    pytest.importorskip("numba")
    import multiprocessing

    from bracekit.compliance import _numba_batch

    sc, Q = paper
    beta = sc.beta_x(0.0)
    ev = BatchEvaluator(sc.braced, backend="numba")
    one = ev(Q, beta, threads=1)  # the serial copy of the kernel
    assert len(_numba_batch.evaluate_serial.signatures) >= 1
    here = ev(Q, beta)  # starts numba's thread pool in this process
    _same_evaluation(one, here, 0.0)
    with multiprocessing.get_context("fork").Pool(1) as pool:  # the child runs the serial copy: no hang
        k = pool.apply_async(_forked_k, (Q, beta)).get(timeout=120)
    np.testing.assert_array_equal(k, here.k)
