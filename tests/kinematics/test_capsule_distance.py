"""Tests of the capsule rule (bracekit.kinematics.capsule_distance), the one kernel both clearance searches use.

References: 20001 points sampled along each segment in plane coordinates (their distance from the solid from
the nearest point of the top, rim circle or side; the disk's edge found by bisection for penetration), and the
same functions run as Python in a process without numba (the shim's fallback), to rounding.
"""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest
from test_clearance import _solid_distance

from bracekit.kinematics.capsule_distance import capsule_distance

_UP = np.array([0.0, 0.0, 1.0])


def _segments(seed: int, count: int) -> list[list[list[float]]]:
    """Random segments [[x_a, x_b], [y_a, y_b], [h_a, h_b]] (m) over, beside, above and below a 0.3 m disk."""
    rng = np.random.default_rng(seed)
    ends = rng.uniform([-0.6, -0.6, -0.3], [0.6, 0.6, 0.4], (count, 2, 3))
    return [e.T.tolist() for e in ends]


def _sampled(ends: list[list[float]], radius: float, r_max: float | None, count: int = 20001) -> float:
    """Brute force: the least sampled clearance (m) of a capsule (test_clearance's rule, in plane coordinates)."""
    pa, pb = np.array(ends)[:, 0], np.array(ends)[:, 1]
    ts = np.linspace(0.0, 1.0, count)
    points = pa + np.outer(ts, pb - pa)
    if r_max is None:
        return float(points[:, 2].min()) - radius
    inside = np.hypot(points[:, 0], points[:, 1]) <= r_max
    heights = list(points[inside, 2])
    for i in np.flatnonzero(inside[:-1] != inside[1:]):  # the disk's edge between two samples, by bisection
        t_in, t_out = (ts[i], ts[i + 1]) if inside[i] else (ts[i + 1], ts[i])
        for _ in range(60):
            mid = 0.5 * (t_in + t_out)
            p = pa + mid * (pb - pa)
            t_in, t_out = (mid, t_out) if np.hypot(p[0], p[1]) <= r_max else (t_in, mid)
        heights.append(float((pa + t_in * (pb - pa))[2]))
    if heights and min(heights) < 0.0:
        return min(heights) - radius
    k = int(np.argmin(_solid_distance(points, np.zeros(3), _UP, r_max)))
    fine = np.linspace(ts[max(k - 1, 0)], ts[min(k + 1, count - 1)], count)
    return float(_solid_distance(pa + np.outer(fine, pb - pa), np.zeros(3), _UP, r_max).min()) - radius


@pytest.mark.parametrize("r_max", [None, 0.3, 0.05])
def test_the_capsule_rule_matches_segments_sampled_brute_force(r_max) -> None:
    values = []
    for ends in _segments(1, 150):
        value, t, u, _ = capsule_distance(ends, 0.05, r_max)
        brute = _sampled(ends, 0.05, r_max)
        assert value == pytest.approx(brute, abs=1e-9)
        assert value <= brute + 1e-12  # the samples can only miss the least point
        assert 0.0 <= t <= 1.0 and np.linalg.norm(u) == pytest.approx(1.0, abs=1e-12)
        values.append(value)
    assert min(values) < -0.05 and max(values) > 0.0  # penetration and clearance both met


def test_without_numba_the_same_functions_run_as_python_and_give_the_compiled_values() -> None:
    pytest.importorskip("numba")
    cases = [(ends, r_max) for r_max in (None, 0.3) for ends in _segments(2, 100)]
    code = (
        "import json, sys; sys.modules['numba'] = None\n"
        "import bracekit._compiled as c; assert not c.COMPILED\n"
        "from bracekit.kinematics.capsule_distance import capsule_distance\n"
        "print(json.dumps([capsule_distance(e, 0.05, r) for e, r in json.load(sys.stdin)]))"
    )
    run = subprocess.run([sys.executable, "-c", code], input=json.dumps(cases), capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    python = json.loads(run.stdout)
    for (ends, r_max), (value, t, u, clip) in zip(cases, python, strict=True):
        compiled = capsule_distance(ends, 0.05, r_max)
        assert value == pytest.approx(compiled[0], abs=1e-14) and t == pytest.approx(compiled[1], abs=1e-12)
        np.testing.assert_allclose(u, compiled[2], rtol=0.0, atol=1e-12)
        assert clip == compiled[3]
