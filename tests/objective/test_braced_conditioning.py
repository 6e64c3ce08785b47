"""The braced-conditioning barrier (eq:cond_barrier) against independent references.

r against σ_min/σ_max of S J_e N with SciPy's null space N of the stacked constraint (equal joint stiffnesses);
its gradient against central differences of the value, with one brace and with two, in every task space.
"""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import scipy.linalg

from bracekit.compliance.first_order import constrained_compliance
from bracekit.errors import BarrierError, InputError
from bracekit.objective import BracedConditioning, central_difference
from bracekit.objective.braced_conditioning import conditioning_ratio
from bracekit.resolution.task_space import TaskSpace
from bracekit.simulation.run import run_scenario
from bracekit.simulation.scenario import load_scenario
from bracekit.simulation.start import solve_start
from helpers import iiwa_like_urdf, iiwa_scenario_text

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


#: A task only for loading a scenario at a configuration (a 1 mm circle near the line's end).
PROBE = (
    'type = "circle"\ncentre = [0.8, -0.06, 0.62]\nradius = 0.001\nnormal = [0.0, 1.0, 0.0]\n'
    "start_direction = [1.0, 0.0, 0.0]\nperiod = 4.0\n"
)


def _iiwa(tmp_path: Path, task: str, guess: list[float], weights: str, strategies: str) -> Path:
    """The iiwa-like arm braced at its forearm (tests/helpers.py) with a position task, given weights."""
    (tmp_path / "iiwa.urdf").write_text(iiwa_like_urdf(), encoding="utf-8")
    text = iiwa_scenario_text(True)
    text = text[: text.index('type = "line"')] + task + 'space = "position"\n' + text[text.index("[start]") :]
    text = text.replace("guess = [0.0, 0.6, 0.0, -0.97, 0.0, 1.2, 0.0]", f"guess = {guess}")
    text = text[: text.index("weights = ")] + f"weights = {{ {weights} }}\n" + text[text.index("[simulation]") :]
    text = text.replace("dt = 0.05\n", f"dt = 0.05\nstrategies = [{strategies}]\n")
    path = tmp_path / "iiwa.toml"
    path.write_text(text, encoding="utf-8")
    return path


def _ratios(sc: Any, qs: np.ndarray) -> np.ndarray:
    """σ_min/σ_max of S J_e N along a path, N from SciPy's null space (the joints are equally stiff)."""
    out = []
    for q in qs:
        st = sc.braced.state(q)
        g = np.vstack([x.T @ c.J_b for x, c in zip(st.X_i, st.contacts, strict=True)])
        s = np.linalg.svd(sc.task_space.selection(st.R_e) @ st.J_e @ scipy.linalg.null_space(g), compute_uv=False)
        out.append(s[-1] / s[0])
    return np.array(out)


@pytest.fixture(scope="module")
def near_singular(tmp_path_factory: pytest.TempPathFactory) -> np.ndarray:
    """Where braced minimum norm stops on a line up and out (t = 2.8 s): σ_min/σ_max of S J_e N ≈ 0.003."""
    end = np.round(np.array([0.70, -0.06, 0.50]) + 0.25 * np.array([1.0, 0.0, 1.0]) / np.sqrt(2.0), 4).tolist()
    task = f'type = "line"\nstart = [0.70, -0.06, 0.50]\nend = {end}\nduration = 4.0\n'
    path = _iiwa(
        tmp_path_factory.mktemp("line"), task, [0.0, 0.6, 0.0, -0.97, 0.0, 1.2, 0.0], "k = 0.0", '"braced_min_norm"'
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        run = run_scenario(path, both_models=False).trajectories["constrained"]["braced_min_norm"]
    assert not run.completed and "braced singularity" in (run.failure or "")
    return np.asarray(run.q[-1])


def test_the_term_alone_moves_away_from_a_braced_singularity_in_the_null_space(
    tmp_path: Path, near_singular: np.ndarray
) -> None:
    """With ẋ = 0, gradient projection on the barrier alone keeps the task and the contact (rows written here)
    and raises σ_min/σ_max of S J_e N along q̇ (a central difference of the SciPy ratio)."""
    sc = load_scenario(
        _iiwa(
            tmp_path,
            PROBE,
            near_singular.tolist(),
            "conditioning = 0.01, joint_limit_barrier = 0.0, clearance = 0.0",
            '"braced_min_norm"',
        )
    )
    assert sc.objective().names == ("conditioning",)
    st = sc.braced.state(near_singular, hessians=True)
    qdot = sc.strategy("braced_gradient_projection").velocity(st, np.zeros(6))
    g = np.vstack([x.T @ c.J_b for x, c in zip(st.X_i, st.contacts, strict=True)])
    assert np.max(np.abs(g @ qdot)) < 1e-9 and np.max(np.abs(st.J_e[:3] @ qdot)) < 1e-9
    h = 1e-6
    rate = (_ratios(sc, [near_singular + h * qdot])[0] - _ratios(sc, [near_singular - h * qdot])[0]) / (2 * h)
    assert _ratios(sc, [near_singular])[0] < 0.005 and rate > 0.0


@pytest.mark.slow
def test_a_run_held_near_a_braced_singularity_moves_away_with_the_term(
    tmp_path: Path, near_singular: np.ndarray
) -> None:
    """A 1 mm circle at the stopping point: with the barrier (its default weight) σ_min/σ_max of S J_e N rises
    above the path without it at every later sample, and ends 1.2× higher (the joint-limit barrier in both)."""
    braced = load_scenario(_iiwa(tmp_path, PROBE, near_singular.tolist(), "k = 0.0", '"braced_min_norm"')).braced
    tip = braced.state(near_singular).e
    task = (
        f'type = "circle"\ncentre = {(tip - [1e-4, 0.0, 0.0]).tolist()}\nradius = 0.0001\n'
        "normal = [0.0, 1.0, 0.0]\nstart_direction = [1.0, 0.0, 0.0]\nperiod = 4.0\n"
    )
    paths = {}
    for weight in ("0.0", "0.01"):
        weights = f"joint_limit_barrier = 0.01, clearance = 0.0, conditioning = {weight}"
        path = _iiwa(tmp_path, task, near_singular.tolist(), weights, '"braced_gradient_projection"')
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            run = run_scenario(path, both_models=False).trajectories["constrained"]["braced_gradient_projection"]
        assert run.completed, run.failure
        paths[weight] = _ratios(load_scenario(path), run.q)
    off, on = paths["0.0"], paths["0.01"]
    assert off[0] == pytest.approx(on[0], rel=1e-9) and off[0] < 0.006
    assert np.all(on[1:] > off[1:]) and on[-1] > 1.2 * off[-1]


@pytest.mark.parametrize("threshold", [0.01, 0.95], ids=["inactive", "active"])
@pytest.mark.parametrize("space", SPACES, ids=lambda s: s.kind)
def test_the_fused_step_with_the_term_equals_the_reference(threshold: float, space: TaskSpace) -> None:
    """One brace: the fused step skips the term where r > 1.1 r₀ and else takes its reference gradient."""
    from bracekit.objective import ComplianceIndex, Objective
    from bracekit.resolution.fused import GradientProjectionStep, numba_available
    from bracekit.resolution.strategies import BracedGradientProjection

    braced, qs = CASES["one brace"]
    terms = [ComplianceIndex(np.r_[1.0, 0, 0, 0, 0, 0], "constrained"), BracedConditioning(threshold, space)]
    strategy = BracedGradientProjection(Objective(terms, [100.0, 0.01]), alpha=-0.7, space=space)
    step = GradientProjectionStep(braced, strategy, backend="numpy")
    rng = np.random.default_rng(4)
    for q in qs:
        st = braced.state(q, hessians=True)
        active = terms[1].value(st) > 0.0
        assert active == (threshold > 0.5)
        xdot = rng.normal(scale=0.05, size=6)
        ref = strategy.velocity(st, xdot)
        np.testing.assert_allclose(step(q, xdot), ref, rtol=1e-10, atol=1e-12 * np.max(np.abs(ref)))
        assert step.value(q) == pytest.approx(strategy.objective.value(st), rel=1e-13)
    if numba_available():  # the kernel has no compiled copy of the term: it says so and the NumPy step runs
        fast = GradientProjectionStep(braced, strategy, backend="numba")
        why = "term without a compiled copy: conditioning" if space.is_pose else "task space other than the full pose"
        assert not fast.uses_kernel and fast.fallback_reason == why
