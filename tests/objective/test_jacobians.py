"""Every registered objective term's gradient against central differences, with one brace and with two.

The terms are collected from the registry (``bracekit.objective.TERMS``) as a scenario builds them
(``terms_from_scenario``): a term added in a new file is checked here without editing this test.
"""

from __future__ import annotations

import warnings
from dataclasses import replace

import numpy as np
import pytest

from bracekit.errors import BarrierError, UnloadedContactWarning
from bracekit.objective import TERMS, Term, TermContext, central_difference, register_term
from bracekit.simulation.holding import Holding
from bracekit.simulation.scenario import load_scenario
from bracekit.simulation.start import solve_start

#: Loads every term can take: a preload and friction to hold, and one tool wrench (N, N·m).
HOLDING = Holding(preload=8.0, friction=0.6, wrenches=np.array([[0.0, 0.0, -2.0, 0.0, 0.3, 0.0]]))


def _configurations(name: str, count: int = 2) -> tuple[TermContext, list[np.ndarray]]:
    """The scenario's robot and β_x with HOLDING, and configurations near its start (inside every region)."""
    sc = load_scenario(name)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        start = solve_start(sc.braced, sc.task.position(0.0), sc.guess, rotation=sc.task.rotation)
    context = TermContext(sc.braced, sc.beta_x(0.0), "constrained", HOLDING)
    terms = _terms(context)
    rng = np.random.default_rng(3)
    qs: list[np.ndarray] = []
    while len(qs) < count:  # near the start, where every term is finite (no link in an obstacle, inside regions)
        q = start.q + 0.1 * rng.standard_normal(sc.robot.n)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                [t.value(sc.braced.state(q)) for t in terms]
        except BarrierError:
            continue
        qs.append(q)
    return context, qs


def _terms(context: TermContext) -> list[Term]:
    out: list[Term] = []
    for cls in TERMS.values():
        out.extend(cls.terms_from_scenario(context))
    return out


CASES = {"one brace": _configurations("paper"), "two braces": _configurations("two-braces")}


def test_the_registry_holds_every_shipped_term() -> None:
    # the test below sees every registered key; this names the shipped ones so that none is dropped unseen
    shipped = {"k", "Ci", "theta_z", "d", "joint_limits", "joint_limit_barrier", "brace_margin", "clearance"}
    shipped |= {"conditioning"}
    assert shipped <= set(TERMS)


@pytest.mark.parametrize("case", list(CASES))
@pytest.mark.parametrize("key", list(TERMS))
def test_every_registered_term_has_the_gradient_of_its_value(case: str, key: str) -> None:
    context, qs = CASES[case]
    braced = context.braced
    terms = TERMS[key].terms_from_scenario(context)
    assert terms  # each term applies to one brace and to two (per-brace terms give one per brace)
    for term in terms:
        for q in qs:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", UnloadedContactWarning)
                grad = term.gradient(braced.state(q, hessians=True))
                fd = central_difference(lambda x, t=term: t.value(braced.state(x)), q, 1e-6)
            scale = max(float(np.linalg.norm(fd)), 1e-9)
            np.testing.assert_allclose(grad, fd, atol=2e-6 * scale, err_msg=f"{case}: {term.name}")


def test_a_new_term_is_one_file_and_is_then_checked_like_the_shipped_ones() -> None:
    # what a user writes in a new file: value and gradient (the tip height, m, and J_e's z row) and its scenario hook
    class TipHeight(Term):
        name = "tip_height"
        key = "tip_height"

        def value(self, state):  # type: ignore[no-untyped-def]
            return float(state.e[2])

        def gradient(self, state):  # type: ignore[no-untyped-def]
            return state.J_e[2].copy()

        @classmethod
        def from_scenario(cls, context):  # type: ignore[no-untyped-def]
            return cls()

    register_term(TipHeight)
    try:
        assert TERMS["tip_height"] is TipHeight
        sc = load_scenario("two-braces")
        objective = replace(sc, weights=dict(sc.weights, tip_height=1.0)).objective()
        assert "tip_height" in objective.names  # the scenario's weight key exists as soon as it is registered
        for case in CASES:  # and the registry-driven check above takes it, with one brace and with two
            test_every_registered_term_has_the_gradient_of_its_value(case, "tip_height")
    finally:
        TERMS.pop("tip_height", None)
