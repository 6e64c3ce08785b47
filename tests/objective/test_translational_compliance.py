"""The translational-compliance term c_t = βᵀ C_e,tt β: its value against an independent compliance and its
analytic gradient against central differences (docs/model.md, section 11).

References: the constrained compliance from the bordered KKT system on a separately built Pinocchio model
(`validate.statics.lagrange_compliance`; with k_env the joint springs plus a contact spring), and central
differences of those values (our own loop) and of the term's value (bracekit's `finite_difference_gradient`).
"""

from __future__ import annotations

import warnings

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from bracekit.compliance.first_order import end_effector_compliance
from bracekit.contact import Brace, Surface
from bracekit.errors import InputError, UnloadedContactWarning
from bracekit.kinematics import BracedRobot
from bracekit.model.robot import Robot
from bracekit.model.shipped import load_model, model_path
from bracekit.objective import TERMS, ComplianceIndex, TermContext, TranslationalCompliance, finite_difference_gradient
from bracekit.validate.statics import lagrange_compliance
from helpers import pin_frame_jacobian, random_chain_urdf, random_unit

WRIST_DOWN_Q = np.array([0.0, 0.1924, -2.594, 0.0, -0.74, -3.1416, 0.2, -3.0734, 1.9224, 0.2834, 0.3])
RTOL = 1e-6


class Reference:
    """A braced robot and, from an independent Pinocchio model, its constrained compliance at q."""

    def __init__(self, urdf: str | None, seed: int, env: float | None):
        rng = np.random.default_rng(seed)
        if urdf is None:
            self.ref, self.tip = pin.buildModelFromUrdf(str(model_path("paper-robot"))), "tool"
            self.K = rng.uniform(120.0, 220.0, 11)
            robot = load_model("paper-robot", stiffness=self.K)
        else:
            self.ref, self.tip = pin.buildModelFromXML(urdf), "tip"
            self.K = rng.uniform(50.0, 500.0, self.ref.nv)
            robot = Robot.from_urdf(urdf, tip="tip", stiffness=self.K)
        self.normal, self.env = random_unit(rng), env
        surface = Surface(rng.normal(scale=0.1, size=3), self.normal)
        self.braced = BracedRobot(robot, Brace("brace", surface, environment_stiffness=env))
        self.beta = random_unit(rng)

    def compliance(self, q: np.ndarray) -> np.ndarray:
        J, Jb = pin_frame_jacobian(self.ref, self.tip, q), pin_frame_jacobian(self.ref, "brace", q)
        a = Jb[:3].T @ self.normal
        if self.env is None:
            return lagrange_compliance(J, self.K, a)
        return J @ np.linalg.solve(np.diag(self.K) + self.env * np.outer(a, a), J.T)

    def c_t(self, q: np.ndarray) -> float:
        return float(self.beta @ self.compliance(q)[:3, :3] @ self.beta)


def central(fn, q: np.ndarray, h: float = 2e-5) -> np.ndarray:
    """Richardson-extrapolated central differences (steps h and h/2), our own loop."""

    def step(s: float) -> np.ndarray:
        return np.array([(fn(q + s * e) - fn(q - s * e)) / (2 * s) for e in np.eye(q.size)])

    return (4.0 * step(h / 2) - step(h)) / 3.0


def check(r: Reference, q: np.ndarray) -> None:
    state = r.braced.state(q, hessians=True)
    for model in ("constrained", "projection") if r.env is None else ("constrained",):
        term = TranslationalCompliance(r.beta, model)
        analytic = term.gradient(state)
        fd = finite_difference_gradient(r.braced, term.value, q)
        assert np.linalg.norm(analytic - fd) <= RTOL * np.linalg.norm(fd) + 1e-12
        assert np.linalg.norm(analytic) > 0.0
    term = TranslationalCompliance(r.beta)
    assert term.value(state) == pytest.approx(r.c_t(q), rel=1e-9)
    ours = central(r.c_t, q)
    assert np.linalg.norm(term.gradient(state) - ours) <= RTOL * np.linalg.norm(ours)


@pytest.mark.parametrize("env", [None, 2e4], ids=["rigid", "k_env"])
def test_gradient_matches_finite_differences_on_the_paper_robot(env: float | None) -> None:
    r = Reference(None, seed=3, env=env)
    with warnings.catch_warnings():
        warnings.simplefilter("error", UnloadedContactWarning)
        check(r, WRIST_DOWN_Q)


@settings(max_examples=8, deadline=None)
@given(n=st.integers(7, 10), seed=st.integers(0, 10_000), qseed=st.integers(0, 2**31), elastic=st.booleans())
def test_gradient_matches_finite_differences_on_random_chains(n: int, seed: int, qseed: int, elastic: bool) -> None:
    link = 2 + seed % (n - 2)
    r = Reference(random_chain_urdf(n, seed=seed, brace_link=link), seed=seed, env=5e3 if elastic else None)
    q = np.random.default_rng(qseed).uniform(-3.0, 3.0, n)
    with warnings.catch_warnings():
        warnings.simplefilter("error", UnloadedContactWarning)
        check(r, q)


def test_value_is_the_force_block_and_not_the_index() -> None:
    r = Reference(None, seed=4, env=None)
    state = r.braced.state(WRIST_DOWN_Q)
    c = end_effector_compliance(state)
    beta6 = np.concatenate([r.beta, np.zeros(3)])
    ct = TranslationalCompliance(beta6).value(state)
    ci = ComplianceIndex(beta6).value(state)
    assert ct == pytest.approx(r.beta @ c[:3, :3] @ r.beta, rel=1e-12)
    assert ct < ci  # ‖β_xᵀC‖ ≥ |β_xᵀCβ_x| (Cauchy–Schwarz), and the moment columns add to it


def test_refuses_a_rotational_direction_and_follows_the_task() -> None:
    with pytest.raises(InputError, match="translational"):
        TranslationalCompliance(np.array([1.0, 0, 0, 0, 0.5, 0]))
    r = Reference(None, seed=5, env=None)
    term = TERMS["ct"].from_scenario(TermContext(r.braced, np.array([0, 0, 2.0, 0, 0, 0]), "constrained"))
    assert isinstance(term, TranslationalCompliance)
    np.testing.assert_array_equal(term.beta_x, [0, 0, 1, 0, 0, 0])
    np.testing.assert_array_equal(term.with_beta_x([0, 3.0, 0]).beta_x, [0, 1, 0, 0, 0, 0])
