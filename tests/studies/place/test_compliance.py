"""C_i and c_t of the placed brace against constrained_compliance at a new frame; gradients by central differences."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from bracekit.compliance.first_order import constrained_compliance
from bracekit.studies.place.compliance import placed_compliance
from bracekit.studies.place.kinematics import link_axes_in_brace, placed_brace
from bracekit.studies.place.scenario import Place, place_scenario
from bracekit.studies.sweep.spec import POINT_FRAME

H = 1e-6


def _value(setup: dict[str, Any], x: np.ndarray, measure: str) -> tuple[float, np.ndarray]:
    sc, surface, t = setup["scenario"], setup["surface"], setup["template"]
    n = sc.robot.n
    q, theta = x[:n], x[n:]
    state = sc.braced.state(q, hessians=True)
    rot = link_axes_in_brace(sc.robot, surface.link, POINT_FRAME)
    pb = placed_brace(state, surface, surface.point(t.fraction, t.angle), theta, rot)
    assert state.dJ_e is not None
    dje = np.concatenate([state.dJ_e, np.zeros((6, n, 2))], axis=2)
    djb = np.concatenate([pb.dJ_dq, pb.dJ_dtheta], axis=2)
    x_mat = sc.braced.X_i[0]
    out = placed_compliance(
        state.J_e,
        dje,
        pb.J_b,
        djb,
        x_mat,
        state.K,
        np.zeros(x_mat.shape[1]),
        sc.beta_x(0.0),
        measure,  # type: ignore[arg-type]
    )
    return out.value, out.gradient


@pytest.mark.parametrize("measure", ["Ci", "ct"])
def test_value_matches_constrained_compliance(setup: dict[str, Any], measure: str) -> None:
    q = setup["q"]
    theta = np.array([0.62, -1.1])
    value, _ = _value(setup, np.concatenate([q, theta]), measure)
    ref = place_scenario(setup["spec"], setup["surface"], Place("link4", *theta), q)
    c_e = constrained_compliance(ref.braced.state(q))
    beta = ref.beta_x(0.0)
    want = np.linalg.norm(c_e @ beta) if measure == "Ci" else beta @ c_e @ beta
    assert value == pytest.approx(want, rel=1e-10)


@pytest.mark.parametrize("measure", ["Ci", "ct"])
def test_gradient_against_central_differences(setup: dict[str, Any], measure: str) -> None:
    x = np.concatenate([setup["q"], [0.37, 2.9]])
    _, grad = _value(setup, x, measure)
    fd = np.zeros(x.size)
    for k in range(x.size):
        dx = np.zeros(x.size)
        dx[k] = H
        fd[k] = (_value(setup, x + dx, measure)[0] - _value(setup, x - dx, measure)[0]) / (2 * H)
    assert np.allclose(grad, fd, rtol=1e-5, atol=1e-9 * np.abs(fd).max())


def test_value_without_variables(setup: dict[str, Any]) -> None:
    """No variables (the figure's values): the same value, an empty gradient."""
    x = np.concatenate([setup["q"], [0.37, 2.9]])
    value, _ = _value(setup, x, "Ci")
    sc, surface, t = setup["scenario"], setup["surface"], setup["template"]
    state = sc.braced.state(setup["q"], hessians=True)
    rot = link_axes_in_brace(sc.robot, surface.link, POINT_FRAME)
    pb = placed_brace(state, surface, surface.point(t.fraction, t.angle), x[-2:], rot)
    zero = np.zeros((6, sc.robot.n, 0))
    out = placed_compliance(state.J_e, zero, pb.J_b, zero, sc.braced.X_i[0], state.K, np.zeros(1), sc.beta_x(0.0))
    assert out.value == value and out.gradient.shape == (0,)
