"""The placed brace's Jacobian against Pinocchio's at a new point frame, its derivatives against central differences."""

from __future__ import annotations

from typing import Any

import numpy as np

from bracekit.studies.place.kinematics import link_axes_in_brace, placed_brace
from bracekit.studies.place.scenario import Place, place_scenario
from bracekit.studies.sweep.spec import POINT_FRAME

H = 1e-6


def _placed(setup: dict[str, Any], q: np.ndarray, theta: np.ndarray) -> Any:
    sc, surface, t = setup["scenario"], setup["surface"], setup["template"]
    state = sc.braced.state(q, hessians=True)
    rot = link_axes_in_brace(sc.robot, surface.link, POINT_FRAME)
    return placed_brace(state, surface, surface.point(t.fraction, t.angle), theta, rot)


def test_jacobian_matches_a_frame_at_the_new_point(setup: dict[str, Any]) -> None:
    q, surface = setup["q"], setup["surface"]
    rng = np.random.default_rng(3)
    for _ in range(3):
        theta = np.array([rng.uniform(0.05, 0.95), rng.uniform(-np.pi, np.pi)])
        qq = q + 0.05 * rng.standard_normal(q.size)
        got = _placed(setup, qq, theta)
        ref = place_scenario(setup["spec"], surface, Place("link4", *theta), qq).braced.state(qq)
        assert np.allclose(got.J_b, ref.contacts[0].J_b, atol=1e-12)
        assert np.allclose(got.b, ref.contacts[0].b, atol=1e-12)
        assert np.allclose(got.n, ref.contacts[0].z_b, atol=1e-12)  # the pad axis is the inward normal


def test_derivatives_against_central_differences(setup: dict[str, Any]) -> None:
    q = setup["q"]
    theta = np.array([0.41, 2.3])
    base = _placed(setup, q, theta)
    for k in range(q.size):
        dq = np.zeros(q.size)
        dq[k] = H
        hi, lo = _placed(setup, q + dq, theta), _placed(setup, q - dq, theta)
        assert np.allclose((hi.J_b - lo.J_b) / (2 * H), base.dJ_dq[:, :, k], atol=1e-7)
        assert np.allclose((hi.n - lo.n) / (2 * H), base.dn_dq[:, k], atol=1e-7)
    for j in range(2):
        dt = np.zeros(2)
        dt[j] = H
        hi, lo = _placed(setup, q, theta + dt), _placed(setup, q, theta - dt)
        assert np.allclose((hi.J_b - lo.J_b) / (2 * H), base.dJ_dtheta[:, :, j], atol=1e-7)
        assert np.allclose((hi.b - lo.b) / (2 * H), base.db_dtheta[:, j], atol=1e-7)
        assert np.allclose((hi.n - lo.n) / (2 * H), base.dn_dtheta[:, j], atol=1e-7)
