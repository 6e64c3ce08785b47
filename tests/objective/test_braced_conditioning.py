"""The braced-conditioning barrier (eq:cond_barrier) against independent references.

r against σ_min/σ_max of S J_e N with SciPy's null space N of the stacked constraint (equal joint stiffnesses);
its gradient against central differences of the value, with one brace and with two, in every task space.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import scipy.linalg

from bracekit.compliance.first_order import constrained_compliance
from bracekit.errors import BarrierError, InputError
from bracekit.objective import BracedConditioning, central_difference
from bracekit.objective.braced_conditioning import conditioning_ratio
from bracekit.resolution.task_space import TaskSpace
from bracekit.simulation.scenario import load_scenario
from bracekit.simulation.start import solve_start

SPACES = [TaskSpace("pose"), TaskSpace("position"), TaskSpace("position+axis", [1.0, 0.5, 0.2])]


def _near_start(name: str) -> tuple[object, list[np.ndarray]]:
    sc = load_scenario(name)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        start = solve_start(sc.braced, sc.task.position(0.0), sc.guess, rotation=sc.task.rotation)
    rng = np.random.default_rng(5)
    return sc.braced, [start.q + 0.05 * rng.standard_normal(sc.robot.n) for _ in range(2)]


CASES = {"one brace": _near_start("paper"), "two braces": _near_start("two-braces")}


@pytest.mark.parametrize("case", list(CASES))
@pytest.mark.parametrize("space", SPACES, ids=lambda s: s.kind)
def test_the_ratio_is_sigma_min_over_sigma_max_of_the_braced_task_jacobian(case: str, space: TaskSpace) -> None:
    braced, qs = CASES[case]
    for q in qs:
        st = braced.state(q)
        assert np.ptp(st.K) == 0.0  # equal stiffnesses: the metric is the plain one
        g = np.vstack([x.T @ c.J_b for x, c in zip(st.X_i, st.contacts, strict=True)])
        b = space.selection(st.R_e) @ st.J_e @ scipy.linalg.null_space(g)
        s = np.linalg.svd(b, compute_uv=False)
        r = conditioning_ratio(constrained_compliance(st), space.selection(st.R_e))
        assert r == pytest.approx(s[-1] / s[0], rel=1e-8)


@pytest.mark.parametrize("case", list(CASES))
@pytest.mark.parametrize("space", [None, *SPACES], ids=lambda s: "none" if s is None else s.kind)
def test_the_gradient_is_that_of_the_value(case: str, space: TaskSpace | None) -> None:
    braced, qs = CASES[case]
    term = BracedConditioning(threshold=0.95, space=space)  # active everywhere here
    for q in qs:
        st = braced.state(q, hessians=True)
        assert term.value(st) > 0.0
        grad = term.gradient(st)
        fd = central_difference(lambda x: term.value(braced.state(x)), q, 1e-6)
        np.testing.assert_allclose(grad, fd, atol=2e-6 * float(np.linalg.norm(fd)), err_msg=case)


def test_the_barrier_is_zero_above_its_threshold_and_refuses_a_bad_one() -> None:
    braced, qs = CASES["one brace"]
    st = braced.state(qs[0], hessians=True)
    r = conditioning_ratio(constrained_compliance(st), np.eye(6))
    above = BracedConditioning(threshold=0.9 * r)
    below = BracedConditioning(threshold=min(0.99, 2.0 * r))
    assert above.value(st) == 0.0 and not np.any(above.gradient(st))
    assert below.value(st) == pytest.approx((below.threshold - r) ** 2 / (below.threshold * r))
    for bad in (0.0, 1.0, -0.1):
        with pytest.raises(InputError, match="conditioning threshold"):
            BracedConditioning(threshold=bad)
    with pytest.raises(BarrierError, match="singular"):
        below._barrier(0.0)
