"""The matrices a braced run keeps from singularity: with one brace, the task rows S A of A (eq:braced_kin).

A step inverts S A (eq:general_inv in the task's rows), not the whole A: a position task may pass where A's
orientation rows lose rank. Reference: NumPy's SVD of rows @ A built here from the split, and Cauchy's
interlacing (S with orthonormal rows: σ_min(S A) ≥ σ_min(A), σ_max(S A) ≤ σ_max(A) for a wide A).
"""

from __future__ import annotations

import numpy as np

from bracekit import load_scenario
from bracekit.simulation.guards import sigma_ratios


def _ratio(m: np.ndarray) -> float:
    s = np.linalg.svd(m, compute_uv=False)
    return float(s[-1] / s[0])


def test_one_brace_watches_the_task_rows_of_a_in_a_position_task() -> None:
    sc = load_scenario("panda")
    space = sc.task_space
    assert not space.is_pose
    rng = np.random.default_rng(7)
    base = np.asarray(sc.guess, dtype=float)
    for _ in range(5):
        st = sc.braced.state(base + 0.05 * rng.standard_normal(base.shape))
        rows = space.selection(st.R_e)
        assert np.allclose(rows @ rows.T, np.eye(rows.shape[0]), atol=1e-12)
        keys = st.motions.inverted(True)
        assert "SA" in keys and "A" not in keys
        ratios = sigma_ratios(st, space)
        a = st.split.A
        assert np.isclose(ratios["SA"], _ratio(rows @ a), rtol=1e-12)
        assert np.isclose(ratios["A"], _ratio(a), rtol=1e-12)
        assert ratios["SA"] >= ratios["A"] * (1 - 1e-12)


def test_a_pose_task_watches_the_whole_a() -> None:
    sc = load_scenario("paper")
    st = sc.braced.state(np.asarray(sc.guess, dtype=float))
    ratios = sigma_ratios(st, sc.task_space)
    assert sc.task_space.is_pose and ratios["SA"] == ratios["A"]
