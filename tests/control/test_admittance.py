"""The admittance law against the closed form of a mass–damper under a step force."""

import numpy as np
import pytest

from bracekit.control import Admittance
from bracekit.errors import InputError


def test_step_force_matches_the_closed_form() -> None:
    m = np.array([2.0, 4.0, 8.0, 0.1, 0.2, 0.3])
    d = np.array([20.0, 30.0, 40.0, 1.0, 2.0, 3.0])
    w = np.array([5.0, -3.0, 1.0, 0.2, -0.1, 0.05])
    h = 1e-3
    law = Admittance(m, d, h)
    for k in range(1, 2001):
        xd = law(w).xdot
        t = k * h
        closed = w / d * (1.0 - np.exp(-d * t / m))
        assert np.allclose(xd, closed, rtol=1e-10, atol=1e-14)
    # after at least ten time constants M/D: the terminal velocity w / D within e^-10
    assert np.allclose(law.xdot, w / d, rtol=5e-5)


def test_semi_implicit_limit_and_time_constant() -> None:
    """After one time constant M/D the velocity is (1 − 1/e) of its terminal value."""
    law = Admittance(5.0, 25.0, 1e-3)
    tau = 5.0 / 25.0
    for _ in range(round(tau / 1e-3)):
        v = law(np.array([10.0, 0, 0, 0, 0, 0])).xdot
    assert v[0] == pytest.approx(10.0 / 25.0 * (1 - np.exp(-1.0)), rel=1e-9)


def test_deadband_and_selection() -> None:
    law = Admittance(1.0, 10.0, 1e-3, deadband=2.0, axes=[True, True, False, False, False, False])
    out = law(np.array([1.5, -5.0, 9.0, 1.0, 1.0, 1.0]))
    assert np.array_equal(out.wrench, [0.0, -3.0, 0.0, 0.0, 0.0, 0.0])
    assert out.xdot[0] == 0.0 and out.xdot[2] == 0.0 and out.xdot[1] < 0.0


def test_bad_parameters_are_refused() -> None:
    with pytest.raises(InputError, match="mass"):
        Admittance([1.0, 2.0], 1.0)
    with pytest.raises(InputError, match="damping"):
        Admittance(1.0, -1.0)
