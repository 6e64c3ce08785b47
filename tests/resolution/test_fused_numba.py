"""The numba backend of the fused gradient-projection step (bracekit.resolution.fused) equals its reference paths.

Reference: ``BracedGradientProjection.velocity(braced.state(q, hessians=True), ẋ)`` and the NumPy backend of the
same step, on the paper's robot, on random robots, at every split of the chain and with every contact type, and at
the configurations where the reference raises or warns; the backend choice when numba is missing. The tests skip
without numba (the first of them compiles the kernel, ~10 s, unless numba's disk cache already holds it). No timing
is asserted.
"""

from __future__ import annotations

import dataclasses
import sys
import warnings

import numpy as np
import pytest
from test_fused import _assert_same, _objective, _outcome, _unloaded_braced

from bracekit import (
    Brace,
    BracedGradientProjection,
    BracedRobot,
    InputError,
    Objective,
    Robot,
    Surface,
    load_model,
)
from bracekit.contact import contact_type
from bracekit.errors import UnloadedContactWarning
from bracekit.resolution.fused import GradientProjectionStep, numba_available
from helpers import random_chain_urdf


def _paper_configs(sc, count: int, seed: int) -> np.ndarray:
    """Random configurations of the paper robot: near the start guess and anywhere within the joint limits."""
    rng = np.random.default_rng(seed)
    near = sc.guess + rng.normal(scale=0.5, size=(count // 2, sc.robot.n))
    anywhere = rng.uniform(sc.robot.lower, sc.robot.upper, size=(count - count // 2, sc.robot.n))
    return np.concatenate([near, anywhere])


def _kernel_or_none(step: GradientProjectionStep, q: np.ndarray, xdot: np.ndarray, beta=None):
    """The numba kernel's q̇, or None where it declines (the step then runs the NumPy code)."""
    return step._numba_step(q, xdot, beta)


@pytest.mark.parametrize("model", ["constrained", "projection"])
def test_numba_backend_equals_the_reference_and_the_numpy_backend(paper, model: str) -> None:
    pytest.importorskip("numba")
    sc, _ = paper
    braced = sc.braced
    rng = np.random.default_rng(7)
    strategy = BracedGradientProjection(_objective(braced, model, rng.normal(size=6)), alpha=-0.7)
    nb = GradientProjectionStep(braced, strategy, backend="numba")
    npb = GradientProjectionStep(braced, strategy)
    assert (nb.backend, nb.uses_kernel, npb.backend, npb.uses_kernel) == ("numba", True, "numpy", False)
    served = 0
    qs = _paper_configs(sc, 40, seed=5)
    for q in qs:
        xdot = rng.normal(scale=0.05, size=6)
        ref = _outcome(lambda q=q, x=xdot: strategy.velocity(braced.state(q, hessians=True), x))
        got = _outcome(lambda q=q, x=xdot: nb(q, x))
        if isinstance(ref, tuple):  # the reference raises: so does the step, with the same message
            assert got == ref
            continue
        kernel = _kernel_or_none(nb, q, xdot)
        if kernel is not None:
            served += 1
            assert np.array_equal(kernel, got)
        _assert_same(ref, got, rtol=1e-12)
        _assert_same(npb(q, xdot), got, rtol=1e-12)
    assert served >= 0.75 * len(qs)  # the kernel, not the NumPy code, computed most steps


@pytest.mark.parametrize("contact", ["frictionless_point", "point_with_friction", "soft_finger"])
@pytest.mark.parametrize("seed", [3, 4])
def test_numba_kernel_equals_the_reference_on_random_robots(contact: str, seed: int) -> None:
    """The kernel's compiled copies of the four terms against the reference path, on random 11–12 joint chains."""
    pytest.importorskip("numba")
    n = 11 + seed % 2
    rng = np.random.default_rng(seed)
    robot = Robot.from_urdf(
        random_chain_urdf(n, seed=seed, brace_link=6), tip="tip", stiffness=rng.uniform(50.0, 400.0, n)
    )
    braced = BracedRobot(robot, Brace("brace", Surface(np.zeros(3), rng.normal(size=3)), contact_type(contact)))
    used = 0
    for model in ("constrained", "projection"):
        strategy = BracedGradientProjection(_objective(braced, model, rng.normal(size=6), r_max=50.0), alpha=-0.7)
        step = GradientProjectionStep(braced, strategy, backend="numba")
        assert step.uses_kernel
        for _ in range(15):
            q = rng.uniform(-2.5, 2.5, n)
            xdot = rng.normal(scale=0.1, size=6)
            got = _kernel_or_none(step, q, xdot)
            if got is None:  # declined (not certified or unloaded): the NumPy code runs instead
                continue
            used += 1
            ref = strategy.velocity(braced.state(q, hessians=True), xdot)
            _assert_same(ref, got, rtol=1e-9)
    assert used >= 6


def test_numba_backend_replaces_beta_x_and_keeps_one_compiled_signature(paper) -> None:
    pytest.importorskip("numba")
    from bracekit.resolution import _numba_step

    sc, qs = paper
    braced = sc.braced
    strategy = BracedGradientProjection(_objective(braced, "constrained", np.r_[1.0, 0, 0, 0, 0, 0]))
    nb = GradientProjectionStep(braced, strategy, backend="auto")
    npb = GradientProjectionStep(braced, strategy, backend="numpy")
    assert nb.backend == "numba"
    beta = np.array([0.0, 2.0, 1.0, 0.0, 0.0, 0.0])
    xdot = np.array([0.01, 0.0, -0.02, 0.0, 0.01, 0.0])
    frozen = xdot.copy()
    frozen.flags.writeable = False
    strided = np.repeat(xdot, 2)[::2]  # not contiguous
    for q in qs[:4]:
        assert _kernel_or_none(nb, q, xdot, beta) is not None
        want = npb(q, xdot, beta)
        for x in (xdot, frozen, strided, xdot.tolist()):
            _assert_same(want, nb(q, x, beta), rtol=1e-12)
    with pytest.raises(InputError):
        nb(qs[0], xdot, np.zeros(6))
    assert len(_numba_step.gp_step.signatures) == 1  # no recompilation for other layouts of the inputs


@pytest.mark.parametrize("contact", ["point_with_friction", "soft_finger"])
def test_numba_backend_with_other_contacts_on_the_paper_robot(paper, contact: str) -> None:
    # three and four constraint directions: G = (Xᵀ C1 X)⁻¹ of the constrained model by Cholesky
    pytest.importorskip("numba")
    sc, qs = paper
    braced = BracedRobot(sc.robot, dataclasses.replace(sc.braced.brace, contact=contact_type(contact)))
    rng = np.random.default_rng(2)
    for model in ("constrained", "projection"):
        strategy = BracedGradientProjection(_objective(braced, model, rng.normal(size=6)), alpha=-0.5)
        nb = GradientProjectionStep(braced, strategy, backend="numba")
        assert nb.uses_kernel
        for q in qs[:6]:
            xdot = rng.normal(scale=0.05, size=6)
            assert _kernel_or_none(nb, q, xdot) is not None
            _assert_same(strategy.velocity(braced.state(q, hessians=True), xdot), nb(q, xdot), rtol=1e-12)


def test_numba_backend_runs_the_numpy_code_where_the_kernel_does_not_apply(paper) -> None:
    pytest.importorskip("numba")
    from bracekit.resolution.task_space import TaskSpace

    sc, qs = paper
    beta = np.r_[1.0, 0, 0, 0, 0, 0]
    xdot = np.array([0.02, 0.0, 0.01, 0.0, 0.0, 0.0])
    compliant = BracedRobot(sc.robot, dataclasses.replace(sc.braced.brace, environment_stiffness=2e4))
    fd = BracedGradientProjection(_objective(sc.braced, "constrained", beta), gradient="finite-difference")
    user = BracedGradientProjection(
        Objective([*_objective(sc.braced, "constrained", beta).terms, _Height()], [0.5, 100.0, 0.6, 0.01, 2.0])
    )
    position = BracedGradientProjection(_objective(sc.braced, "constrained", beta), space=TaskSpace("position"))
    cases = [
        (
            compliant,
            BracedGradientProjection(_objective(compliant, "constrained", beta)),
            "term without a compiled copy",
        ),
        (sc.braced, fd, "finite-difference gradient"),
        (sc.braced, user, "term without a compiled copy: height"),
        (sc.braced, position, "task space other than the full pose"),
    ]
    for braced, strategy, reason in cases:
        nb = GradientProjectionStep(braced, strategy, backend="numba")
        assert nb.backend == "numba" and not nb.uses_kernel
        assert nb.fallback_reason is not None and nb.fallback_reason.startswith(reason)
        assert np.array_equal(nb(qs[0], xdot), GradientProjectionStep(braced, strategy)(qs[0], xdot))
    # a compliant environment with the projection model: the kernel applies (C̃1 does not involve k_env)
    proj = BracedGradientProjection(_objective(compliant, "projection", beta))
    nb = GradientProjectionStep(compliant, proj, backend="numba")
    assert nb.uses_kernel and nb.fallback_reason is None
    for q in qs[:3]:
        _assert_same(proj.velocity(compliant.state(q, hessians=True), xdot), nb(q, xdot), rtol=1e-12)
    assert GradientProjectionStep(compliant, proj).fallback_reason == "numpy backend"


def _split_case(robot_name: str, link: str, contact: str) -> BracedRobot:
    """A link-point brace on `link` with a pad direction (so θ_z is defined), its region about the origin."""
    robot = load_model(robot_name).with_point_frame("pad", link, (0.04, 0.03, 0.02))
    surface = Surface(np.zeros(3), (0.2, -0.1, 1.0))
    return BracedRobot(robot, Brace("pad", surface, contact_type(contact), region_radius=50.0, pad_axis=True))


#: (robot, link, contact, n1): splits n1 ∈ {3, …, 7} on the Panda (up to 6: its link 7 is the last) and the
#: paper's robot, with one to four constraint directions, and l' = 0
SPLITS = [
    ("panda", "panda_link3", "frictionless_point", 3),
    ("panda", "panda_link4", "frictionless_point", 4),
    ("panda", "panda_link5", "frictionless_point", 5),
    ("panda", "panda_link6", "frictionless_point", 6),
    ("paper-robot", "link7", "frictionless_point", 7),
    ("paper-robot", "link3", "point_with_friction", 3),  # Xᵀ J1 square: no chain-1 motion keeps the contact
    ("paper-robot", "link4", "frictionless_point", 4),
    ("paper-robot", "link5", "soft_finger", 5),
    ("paper-robot", "link7", "point_with_friction", 7),
]


@pytest.mark.parametrize(("robot_name", "link", "contact", "n1"), SPLITS)
def test_numba_kernel_equals_the_numpy_step_at_every_split(robot_name: str, link: str, contact: str, n1: int) -> None:
    """The compiled step against the NumPy step and the reference, all four terms, both compliance models."""
    pytest.importorskip("numba")
    braced = _split_case(robot_name, link, contact)
    assert braced.split.n1 == n1
    rng = np.random.default_rng(n1 + len(contact))
    lo = np.where(np.isfinite(braced.robot.lower), braced.robot.lower, -3.0)
    hi = np.where(np.isfinite(braced.robot.upper), braced.robot.upper, 3.0)
    served = tried = 0
    for model in ("constrained", "projection"):
        strategy = BracedGradientProjection(_objective(braced, model, rng.normal(size=6), r_max=50.0), alpha=-0.6)
        nb = GradientProjectionStep(braced, strategy, backend="numba")
        npb = GradientProjectionStep(braced, strategy, backend="numpy")
        assert nb.uses_kernel and nb.fallback_reason is None
        for _ in range(8):
            q = rng.uniform(lo, hi)
            xdot = rng.normal(scale=0.05, size=6)
            tried += 1
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", UnloadedContactWarning)
                ref = _outcome(lambda q=q, x=xdot, s=strategy: s.velocity(braced.state(q, hessians=True), x))
                want = _outcome(lambda q=q, x=xdot, f=npb: f(q, x))
                got = _kernel_or_none(nb, q, xdot)
                step = _outcome(lambda q=q, x=xdot, f=nb: f(q, x))
            _assert_same(want, step, rtol=1e-9)  # the numba backend, kernel or not, equals the NumPy backend
            if got is None:
                continue
            served += 1
            assert not isinstance(want, tuple)  # the kernel serves only where the NumPy step succeeds
            _assert_same(want, got, rtol=1e-9)
            _assert_same(ref, got, rtol=1e-9)
    assert served >= 0.6 * tried


def test_null_space_kernel_matches_contact_null_space() -> None:
    numba_step = pytest.importorskip("bracekit.resolution._numba_step")
    from bracekit.kinematics import contact_null_space

    rng = np.random.default_rng(4)
    for c, k in [(1, 3), (3, 7), (4, 5), (3, 3), (4, 2)]:
        m = rng.normal(size=(c, k))
        basis, ok = numba_step._null_space(m, 1e6, 1e-10)
        ref = contact_null_space(m)
        assert ok and basis.shape == ref.shape
        np.testing.assert_allclose(basis.T @ basis, np.eye(basis.shape[1]), atol=1e-13)
        np.testing.assert_allclose(basis @ basis.T, ref @ ref.T, atol=1e-12)  # the same subspace
    m = rng.normal(size=(3, 6))
    m[2] = m[0] + m[1]  # rank 2: declined (the NumPy code finds the rank by SVD)
    assert not numba_step._null_space(m, 1e6, 1e-10)[1]
    assert not numba_step._null_space(1e-12 * rng.normal(size=(2, 5)), 1e6, 1e-10)[1]  # σ below the absolute limit


@dataclasses.dataclass(frozen=True)
class _Height:
    """A user-defined term: the tip's height, exact gradient from J_e."""

    name: str = "height"

    def value(self, state) -> float:
        return float(state.e[2])

    def gradient(self, state) -> np.ndarray:
        return state.J_e[2].copy()


def test_numba_backend_raises_and_warns_what_the_reference_does(paper) -> None:
    pytest.importorskip("numba")
    sc, qs = paper
    braced = sc.braced
    xdot = np.zeros(6)
    outside = BracedGradientProjection(_objective(braced, "constrained", np.r_[1.0, 0, 0, 0, 0, 0], r_max=1e-3))
    nb = GradientProjectionStep(braced, outside, backend="numba")
    assert _kernel_or_none(nb, qs[0], xdot) is None  # the kernel declines, the NumPy code raises
    ref = _outcome(lambda: outside.velocity(braced.state(qs[0], hessians=True), xdot))
    assert ref[0] == "BarrierError" and _outcome(lambda: nb(qs[0], xdot)) == ref
    q = np.zeros(braced.n)  # J1 singular
    q[1], q[2] = 0.3, -0.4
    ok = BracedGradientProjection(_objective(braced, "constrained", np.r_[1.0, 0, 0, 0, 0, 0], r_max=50.0))
    ref = _outcome(lambda: ok.velocity(braced.state(q, hessians=True), xdot))
    assert ref[0] == "SingularityError"
    assert _outcome(lambda: GradientProjectionStep(braced, ok, backend="numba")(q, xdot)) == ref
    # an unloaded contact (n1 = 1: the NumPy code) warns as the reference does
    unloaded = _unloaded_braced()
    strategy = BracedGradientProjection(_objective(unloaded, "constrained", np.r_[0, 0, 1.0, 0, 0, 0], r_max=50.0))
    q = np.array([0.3, 0.5, -0.4, 0.8, 0.2, -0.6])
    with pytest.warns(UnloadedContactWarning):
        got = GradientProjectionStep(unloaded, strategy, backend="numba")(q, np.r_[0.0, 0, 0.01, 0, 0, 0])
    with pytest.warns(UnloadedContactWarning):
        _assert_same(strategy.velocity(unloaded.state(q, hessians=True), np.r_[0.0, 0, 0.01, 0, 0, 0]), got)


def test_numba_kernel_declines_an_unloaded_contact() -> None:
    # with n1 = 6 and a well-conditioned J1 only extreme stiffnesses unload the contact: feed the kernel
    # J1 = I and a joint 3 (the one that moves {b} along the normal) 1e12 times stiffer than the others
    numba_step = pytest.importorskip("bracekit.resolution._numba_step")
    rng = np.random.default_rng(0)
    n = 8
    je, jb = rng.normal(size=(6, n)), np.zeros((6, n))
    jb[:, :6] = np.eye(6)
    he, hb = rng.normal(size=(n, 6 * n)), rng.normal(size=(n, 6 * n))
    mb, me = np.eye(4), np.eye(4)
    me[:3, 3] = [0.3, 0.1, 0.2]
    h = np.zeros((6, 5))
    h[[0, 1, 3, 4, 5], range(5)] = 1.0
    x = np.zeros((6, 1))
    x[2, 0] = 1.0
    ci = np.array([[1.0, 0, 0, 0, 0, 0, 100.0, 0.0]])  # constrained model
    kinv = np.ones(n)
    args = (je, jb, he, hb, mb, me, np.ones(6), h, x, np.eye(6) - x @ x.T, kinv, ci)
    par = np.array([-1.0, 1e300, 1e-10, 0.0, 0.0, 1e-10])  # [α, CERTIFIED_COND², UNLOADED_TOL, w_k, w_θ, rtol]
    status, _ = numba_step.gp_step(*args, np.zeros((0, 5)), np.array([0.0, 0, 1]), par, 6)
    assert status == numba_step.OK
    kinv[2] = 1e-12
    status, _ = numba_step.gp_step(*args, np.zeros((0, 5)), np.array([0.0, 0, 1]), par, 6)
    assert status == numba_step.UNLOADED


def test_backend_choice_and_numba_missing(paper, monkeypatch) -> None:
    sc, _ = paper
    strategy = sc.strategy("braced_gradient_projection")
    with pytest.raises(InputError, match="unknown backend"):
        GradientProjectionStep(sc.braced, strategy, backend="fortran")  # type: ignore[arg-type]
    default = GradientProjectionStep(sc.braced, strategy)  # what bracekit.simulation.simulate uses
    assert (default.backend, default.uses_kernel) == ("numpy", False)
    # numba not installed: "numba" is a clear InputError, "auto" is NumPy
    monkeypatch.setitem(sys.modules, "numba", None)
    monkeypatch.delitem(sys.modules, "bracekit.resolution._numba_step", raising=False)
    with pytest.raises(InputError, match=r"pip install bracekit\[fast\]"):
        GradientProjectionStep(sc.braced, strategy, backend="numba")
    auto = GradientProjectionStep(sc.braced, strategy, backend="auto")
    assert (auto.backend, auto.uses_kernel) == ("numpy", False)
    xdot = np.array([0.01, 0.0, 0.0, 0.0, 0.0, 0.0])
    assert np.array_equal(auto(sc.guess, xdot), default(sc.guess, xdot))
    assert not numba_available()
