"""Tasks: positions, velocities (checked by finite differences) and validation."""

from __future__ import annotations

import numpy as np
import pytest

from bracekit import Circle, InputError, Line, Waypoints


def _fd_velocity(task, t: float, h: float = 1e-6) -> np.ndarray:
    return (task.position(t + h) - task.position(t - h)) / (2 * h)


def test_circle_velocity_is_the_time_derivative_of_its_position() -> None:
    c = Circle([1.0, 0.0, 0.5], 0.1, [0, 1, 0], 4.0, [1, 0, 0])
    for t in np.linspace(0.1, 3.9, 7):
        assert np.allclose(c.velocity(t), _fd_velocity(c, t), atol=1e-8)


def test_circle_stays_at_radius_in_its_plane_and_starts_along_start_direction() -> None:
    c = Circle([1.0, 0.0, 0.5], 0.2, [0, 0, 2], 3.0, [0, 1, 0.5])
    assert np.allclose(c.position(0.0), [1.0, 0.2, 0.5])
    for t in np.linspace(0, 3, 11):
        rel = c.position(t) - c.centre
        assert np.isclose(np.linalg.norm(rel), 0.2)
        assert np.isclose(rel[2], 0.0)
        assert np.allclose(c.radial(t), rel / 0.2)
    assert np.allclose(c.position(3.0), c.position(0.0))


def test_waypoints_interpolate_linearly_and_velocity_matches_finite_differences() -> None:
    w = Waypoints([[0, 0, 0], [1, 0, 0], [1, 2, 0]], [0.0, 1.0, 3.0])
    assert np.allclose(w.position(0.5), [0.5, 0, 0])
    assert np.allclose(w.position(2.0), [1, 1, 0])
    assert np.allclose(w.velocity(2.0), _fd_velocity(w, 2.0))
    assert w.duration == 3.0


def test_line_runs_from_start_to_end_at_constant_speed() -> None:
    line = Line([0, 0, 0], [0.3, 0, 0.4], 2.0)
    assert np.allclose(line.position(2.0), [0.3, 0, 0.4])
    assert np.isclose(np.linalg.norm(line.velocity(1.0)), 0.25)


@pytest.mark.parametrize(
    "kwargs",
    [
        {"radius": 0.0},
        {"period": -1.0},
        {"normal": [0, 0, 0]},
        {"start_direction": [0, 1, 0]},
        {"centre": [0, 0]},
    ],
)
def test_circle_rejects_bad_parameters(kwargs: dict) -> None:
    base = {"centre": [0, 0, 0], "radius": 0.1, "normal": [0, 1, 0], "period": 1.0, "start_direction": [1, 0, 0]}
    base.update(kwargs)
    with pytest.raises(InputError):
        Circle(**base)


def test_waypoints_reject_non_increasing_times_and_single_points() -> None:
    with pytest.raises(InputError):
        Waypoints([[0, 0, 0], [1, 0, 0]], [0.0, 0.0])
    with pytest.raises(InputError):
        Waypoints([[0, 0, 0]], [0.0])
    with pytest.raises(InputError):
        Line([0, 0, 0], [1, 0, 0], 0.0)


@pytest.mark.parametrize(
    "kwargs",
    [
        {"radius": "big"},
        {"radius": None},
        {"period": float("nan")},
        {"turns": True},
        {"centre": "origin"},
        {"normal": [[0, 1], [0]]},
        {"rotation": np.eye(2)},
        {"rotation": 2 * np.eye(3)},
        {"radius": 1e308, "period": 1e-10},  # a speed beyond float64
    ],
)
def test_circle_rejects_wrong_types_and_shapes_with_input_errors(kwargs: dict) -> None:
    base = {"centre": [0, 0, 0], "radius": 0.1, "normal": [0, 1, 0], "period": 1.0, "start_direction": [1, 0, 0]}
    base.update(kwargs)
    with pytest.raises(InputError) as info:
        Circle(**base)
    assert "\n" not in str(info.value)


@pytest.mark.parametrize(
    ("points", "times"),
    [
        ([[0, 0, 0], [1, 0]], [0.0, 1.0]),  # ragged
        ([[0, 0, 0], [1, 0, 0]], "0 1"),
        ([[0, 0, 0], [1, 0, 0]], [0.0, float("nan")]),
        ([[0, 0, 0], [1e308, 0, 0], [-1e308, 0, 0]], [0.0, 1.0, 2.0]),  # steps beyond float64
        (None, [0.0, 1.0]),
    ],
)
def test_waypoints_reject_ragged_or_non_numeric_input_with_input_errors(points: object, times: object) -> None:
    with pytest.raises(InputError):
        Waypoints(points, times)  # type: ignore[arg-type]


@pytest.mark.parametrize("duration", ["1", None, float("inf"), [1.0]])
def test_line_rejects_a_duration_that_is_not_a_positive_number(duration: object) -> None:
    with pytest.raises(InputError):
        Line([0, 0, 0], [1, 0, 0], duration)  # type: ignore[arg-type]


@pytest.mark.parametrize("t", [float("nan"), "0", None])
def test_positions_refuse_a_time_that_is_not_a_finite_number(t: object) -> None:
    circle = Circle([0, 0, 0], 0.1, [0, 1, 0], 1.0, [1, 0, 0])
    line = Line([0, 0, 0], [1, 0, 0], 1.0)
    for task in (circle, line):
        for fn in (task.position, task.velocity):
            with pytest.raises(InputError):
                fn(t)  # type: ignore[arg-type]


def test_a_circle_keeps_what_it_computed_at_a_time_and_gives_the_same_numbers_as_the_formula() -> None:
    """Reference: p_d, ṗ_d and r̂ from the circle's formula at each t, written out here (a fresh circle each time)."""
    from bracekit.simulation.tasks import circle as module

    kwargs = {
        "centre": [0.7, -0.15, 0.05],
        "radius": 0.1,
        "normal": [0.0, 0.0, 1.0],
        "period": 4.0,
        "start_direction": [1.0, 0.0, 0.0],
    }
    c = Circle(**kwargs)
    u, w = np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])
    for t in np.linspace(0.0, 4.0, 41).tolist() * 2:  # every time twice: the second from what the circle kept
        a = 2.0 * np.pi * t / 4.0
        np.testing.assert_allclose(c.position(t), [0.7 + 0.1 * np.cos(a), -0.15 + 0.1 * np.sin(a), 0.05], atol=1e-15)
        np.testing.assert_allclose(c.velocity(t), 0.1 * np.pi / 2.0 * (-np.sin(a) * u + np.cos(a) * w), atol=1e-15)
        np.testing.assert_allclose(c.radial(t), np.cos(a) * u + np.sin(a) * w, atol=1e-15)
        fresh = Circle(**kwargs)  # nothing kept: the same bits
        for kept, computed in ((c.position, fresh.position), (c.velocity, fresh.velocity), (c.radial, fresh.radial)):
            assert np.array_equal(kept(t), computed(t))
    assert c.position(1.0) is c.position(1.0) and not c.position(1.0).flags.writeable  # one read-only array
    with pytest.raises(ValueError):
        c.position(1.0)[0] = 0.0
    assert np.array_equal(c.position(np.float64(1.0)), c.position(1.0))  # a time not a float: computed, not kept
    old = module.MEMO_SIZE
    try:
        module.MEMO_SIZE = 3
        small = Circle(**kwargs)
        for t in (0.1, 0.2, 0.3, 0.4):
            small.position(t)
        assert len(small._memo[0]) == 1  # forgotten past MEMO_SIZE, then kept again
        assert np.array_equal(small.position(0.1), c.position(0.1))
    finally:
        module.MEMO_SIZE = old


def test_a_pickled_circle_leaves_what_it_kept_behind_and_gives_the_same_numbers() -> None:
    """Reference: the circle before pickling (its kept p_d, ṗ_d and r̂)."""
    import copy
    import pickle

    c = Circle(centre=[0.7, -0.15, 0.05], radius=0.1, normal=[0.0, 0.0, 1.0], period=4.0, start_direction=[1.0, 0, 0])
    times = np.linspace(0.0, 4.0, 9).tolist()
    kept = [(c.position(t), c.velocity(t), c.radial(t)) for t in times]
    for other in (pickle.loads(pickle.dumps(c)), copy.deepcopy(c)):
        assert all(not memo for memo in other._memo) and all(memo for memo in c._memo)
        for t, (p, v, r) in zip(times, kept, strict=True):
            assert np.array_equal(other.position(t), p) and np.array_equal(other.velocity(t), v)
            assert np.array_equal(other.radial(t), r)
        assert np.array_equal(other.normal, c.normal) and other.period == c.period


def test_a_circles_fields_cannot_change_under_its_kept_values() -> None:
    """The kept p_d would go stale if a field changed in place: the fields are read-only copies of the inputs."""
    centre = np.array([0.1, 0.2, 0.3])
    c = Circle(centre, 0.05, np.array([0.0, 0.0, 1.0]), 4.0, np.array([1.0, 0.0, 0.0]), rotation=np.eye(3))
    before = c.position(0.3).copy()
    for name in ("centre", "normal", "start_direction", "rotation"):
        with pytest.raises(ValueError):
            getattr(c, name)[0] = 1.0
    centre[0] = 1.0  # the caller's array stays the caller's (writeable, not the circle's)
    assert np.array_equal(c.position(0.3), before) and np.array_equal(c.centre, [0.1, 0.2, 0.3])
