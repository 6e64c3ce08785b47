"""Gradient projection moves in the null space whenever there is one and ∇g is not orthogonal to it.

Reference: the null space Z of the stacked rows [X_iᵀ J_b_i; S J_e] (the contacts and the task's selected rows)
from an SVD written here, and ∇g as the sum of the weighted terms' own gradients. With xdot = 0 minimum norm
is still; gradient projection's q̇ must then satisfy every contact and task row, descend g (∇gᵀq̇ < 0) when
Zᵀ∇g ≠ 0, and be still when Zᵀ∇g = 0.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from bracekit.resolution.strategies import with_beta_x
from bracekit.simulation.scenario import load_scenario
from bracekit.simulation.start import solve_start
from helpers import iiwa_like_urdf, iiwa_scenario_text

CIRCLE = """type = "circle"
centre = [0.66, 0.0, 0.50]
radius = 0.04
normal = [0.0, 0.0, 1.0]
start_direction = [1.0, 0.0, 0.0]
period = 4.0
"""


def _scenario(tmp_path: Path, space: str):
    (tmp_path / "iiwa.urdf").write_text(iiwa_like_urdf(), encoding="utf-8")
    text = iiwa_scenario_text(True)
    start = text.index('type = "line"')
    end = text.index("[start]")
    text = text[:start] + CIRCLE + space + "\n" + text[end:]
    text = text.replace("d = 0.01 }", "d = 0.01, clearance = 0.0 }")
    path = tmp_path / "iiwa.toml"
    path.write_text(text, encoding="utf-8")
    return load_scenario(path)


def _null_space(st, space) -> np.ndarray:
    rows = [x.T @ c.J_b for x, c in zip(st.X_i, st.contacts, strict=True)]
    rows.append(space.selection(st.R_e) @ st.J_e)
    m = np.vstack(rows)
    _, s, vt = np.linalg.svd(m)
    rank = int(np.sum(s > 1e-10 * s[0]))
    return vt[rank:].T


@pytest.mark.parametrize(
    ("space", "orthogonal"),
    [
        ('space = "position"', False),
        ('space = "position+axis"\naxis = [1.0, 0.0, 0.0]', False),
        # the one redundant motion is joint 7 about the tool axis, which no term sees: ∇g ⟂ Z
        ('space = "position+axis"', True),
    ],
)
def test_gradient_projection_moves_in_the_null_space_unless_the_gradient_is_orthogonal_to_it(
    tmp_path: Path, space: str, orthogonal: bool
) -> None:
    sc = _scenario(tmp_path, space)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        start = solve_start(
            sc.braced, sc.task.position(0.0), sc.guess, theta_weight=sc.start_theta_weight, space=sc.task_space
        )
    st = sc.braced.state(start.q, hessians=True)
    gp = with_beta_x(sc.strategy("braced_gradient_projection"), sc.beta_x(0.0))
    grad = sum(w * t.gradient(st) for t, w in zip(gp.objective.terms, gp.objective.weights, strict=True))
    z = _null_space(st, sc.task_space)
    assert z.shape[1] >= 1  # redundancy > 0
    qdot = gp.velocity(st, np.zeros(6))
    np.testing.assert_allclose(sc.strategy("braced_min_norm").velocity(st, np.zeros(6)), 0.0, atol=1e-12)
    rows = np.vstack(
        [*(x.T @ c.J_b for x, c in zip(st.X_i, st.contacts, strict=True)), sc.task_space.selection(st.R_e) @ st.J_e]
    )
    np.testing.assert_allclose(rows @ qdot, 0.0, atol=1e-10 * max(1.0, float(np.linalg.norm(qdot))))
    projected = float(np.linalg.norm(z.T @ grad))
    if orthogonal:
        assert projected < 1e-6 * float(np.linalg.norm(grad))
        assert float(np.linalg.norm(qdot)) < 1e-6
    else:
        assert projected > 1e-3 * float(np.linalg.norm(grad))
        assert float(grad @ qdot) < -1e-6 * projected**2
