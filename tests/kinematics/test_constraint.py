"""Tests of bracekit.kinematics.constraint: the stacked null spaces against each matrix's own."""

from __future__ import annotations

import numpy as np

from bracekit.kinematics.constraint import contact_null_space, stacked_null_spaces


def test_stacked_null_spaces_are_each_matrix_s_own_and_refuse_mixed_ranks() -> None:
    """Reference: contact_null_space of each matrix, one at a time (bit for bit: the same LAPACK call per matrix)."""
    rng = np.random.default_rng(3)
    g = rng.standard_normal((5, 3, 7))
    g[:, 2] = g[:, 0] - 2.0 * g[:, 1]  # rank 2 in every matrix: a dependent row
    got = stacked_null_spaces(g)
    assert got is not None and got.shape == (5, 7, 5)
    for k in range(5):
        assert np.array_equal(got[k], contact_null_space(g[k]))
    mixed = g.copy()
    mixed[0, 2] = rng.standard_normal(7)  # rank 3 in one matrix: bases of another width
    assert stacked_null_spaces(mixed) is None
    assert stacked_null_spaces(np.zeros((2, 0, 7))) is None
