"""The shared Cholesky loops of the compiled kernels against NumPy's LAPACK (factor, triangular inverse, inverse).

Reference: ``np.linalg.cholesky`` and ``np.linalg.inv`` on random symmetric positive definite matrices of the
sizes the kernels see (1 to 12), and an indefinite matrix the factor must refuse.
"""

from __future__ import annotations

import numpy as np
import pytest

from bracekit._cholesky import cholesky, cholesky_inverse, lower_inverse


@pytest.mark.parametrize("c", [1, 2, 3, 6, 7, 12])
def test_the_loops_match_lapack(c: int) -> None:
    rng = np.random.default_rng(c)
    a = rng.standard_normal((c, c + 2))
    m = a @ a.T + 0.1 * np.eye(c)
    lo, ok = cholesky(m, 0.5)
    assert ok
    np.testing.assert_allclose(lo, np.linalg.cholesky(m + 0.5 * np.eye(c)), rtol=1e-12, atol=1e-13)
    np.testing.assert_allclose(lower_inverse(lo), np.linalg.inv(lo), rtol=1e-10, atol=1e-12)
    out = np.zeros((c, c))
    assert cholesky_inverse(m, 0.5, out)
    np.testing.assert_allclose(out, np.linalg.inv(m + 0.5 * np.eye(c)), rtol=1e-10, atol=1e-12)


def test_an_indefinite_matrix_is_refused() -> None:
    m = np.diag([2.0, -1.0, 3.0])
    assert not cholesky(m, 0.0)[1]
    assert cholesky(m, 1.5)[1]  # shifted positive definite
    out = np.full((3, 3), 7.0)
    assert not cholesky_inverse(m, 0.0, out)
    assert np.all(out == 7.0)  # untouched
