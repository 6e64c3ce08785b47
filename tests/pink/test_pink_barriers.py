"""bracekit.pink's barriers against central differences and a brute-force lateral distance."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

pink = pytest.importorskip("pink")

from bracekit.errors import InputError  # noqa: E402
from bracekit.kinematics import BracedRobot  # noqa: E402
from bracekit.pink import BraceRegionBarrier, LinkClearanceBarrier  # noqa: E402


def test_the_region_barrier_is_r_max_squared_minus_r_squared(panda: Any, config: Any, fd: Any) -> None:
    sc, q = panda
    barrier = BraceRegionBarrier(sc.braced)
    brace = sc.braced.brace
    b = sc.braced.state(q).b_i[0]
    r = np.linalg.norm((b - brace.surface.point)[:2])  # the post's top is horizontal: lateral = x, y
    assert barrier.compute_barrier(config(sc, q)) == pytest.approx([brace.region_radius**2 - r**2], abs=1e-12)
    fd = fd(lambda x: barrier.compute_barrier(config(sc, x)), q)
    assert np.max(np.abs(barrier.compute_jacobian(config(sc, q)) - fd)) < 1e-8


def test_the_clearance_barrier_gradient_is_the_derivative_of_the_clearance(panda: Any, config: Any, fd: Any) -> None:
    sc, q = panda
    barrier = LinkClearanceBarrier(sc.braced, config(sc, q), clearance_min=0.01)
    h = barrier.compute_barrier(config(sc, q))
    assert h.shape == (len(barrier.names),) and np.all(h > -0.01)
    fd = fd(lambda x: barrier.compute_barrier(config(sc, x)), q)
    assert np.max(np.abs(barrier.compute_jacobian(config(sc, q)) - fd)) < 1e-6


def test_a_region_barrier_needs_a_region(panda: Any) -> None:
    sc, _ = panda
    import dataclasses

    braced = BracedRobot(sc.braced.robot, dataclasses.replace(sc.braced.brace, region_radius=None, surface_radius=None))
    with pytest.raises(InputError, match="region_radius"):
        BraceRegionBarrier(braced)


def test_the_brace_margin_barrier_rows_add_up_to_the_terms_analytic_gradient(panda: Any, config: Any) -> None:
    """Σ φ'(r_j) ∂h_j/∂q (the barrier's rows by differences) equals BraceMargin's exact (Hessian) gradient."""
    from bracekit.objective import BraceMargin
    from bracekit.pink import BraceMarginBarrier

    sc, q = panda
    wrenches = np.array([[0.0, 0.0, 2.0, 0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0, 0.0, 0.0]])
    delta = 40.0
    term = BraceMargin(sc.braced, wrenches, preload=20.0, friction=0.8, margin=delta)
    barrier = BraceMarginBarrier(term, config(sc, q))
    state = sc.braced.state(q, hessians=True)
    r = term.residuals(state)
    assert barrier.compute_barrier(config(sc, q)) == pytest.approx(r, abs=1e-12)
    # every residual on the barrier's exact branch δ/4 ≤ r < δ, where φ(r) = δ/r − 2 + r/δ
    assert r.size == 4 and np.all((r >= delta / 4) & (r < delta))
    dphi = 1.0 / delta - delta / r**2
    rows = barrier.compute_jacobian(config(sc, q))
    exact = term.gradient(state)
    assert np.max(np.abs(dphi @ rows - exact)) < 1e-6 * max(1.0, np.max(np.abs(exact)))
