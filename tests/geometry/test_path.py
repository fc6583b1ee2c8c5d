"""The leader's path ẋ_1 = f(t): waypoints and sinusoid; geometry/path.py."""

from __future__ import annotations

import math

import numpy as np
import pytest

from shoal.bus.types import Sinusoid, Waypoints
from shoal.geometry.path import leader_velocity, path_position, peak_speed

ELL = Waypoints(points=((0.0, 0.0), (3.0, 0.0), (3.0, 4.0)), speed=1.0)  # length 7 m
WAVE = Sinusoid(
    start=(1.0, 2.0), direction=(1.0, 0.0), normal=(0.0, 1.0), speed=2.0, amplitude=0.5, period=4.0
)


@pytest.mark.parametrize(
    ("t", "expected"),
    [(0.0, (0.0, 0.0)), (1.5, (1.5, 0.0)), (3.0, (3.0, 0.0)), (5.0, (3.0, 2.0)), (7.0, (3.0, 4.0))],
)
def test_waypoint_positions_at_given_times(t: float, expected: tuple[float, float]) -> None:
    np.testing.assert_allclose(path_position(ELL, t), expected, atol=1e-12)


def test_waypoints_stop_at_last_point() -> None:
    for t in (7.0, 7.5, 100.0):
        np.testing.assert_allclose(path_position(ELL, t), [3.0, 4.0])
    np.testing.assert_array_equal(leader_velocity(ELL, 80, 0.1), [0.0, 0.0])  # t = 8.0 .. 8.1


def test_waypoints_speed_scales_time() -> None:
    fast = Waypoints(points=ELL.points, speed=2.0)
    np.testing.assert_allclose(path_position(fast, 2.5), [3.0, 2.0])


def test_zero_length_leg_is_skipped() -> None:
    path = Waypoints(points=((0.0, 0.0), (0.0, 0.0), (2.0, 0.0)), speed=1.0)
    np.testing.assert_allclose(path_position(path, 0.0), [0.0, 0.0])
    np.testing.assert_allclose(path_position(path, 1.0), [1.0, 0.0])
    np.testing.assert_allclose(peak_speed(path), [1.0, 0.0])


def test_velocity_is_displacement_over_tick() -> None:
    dt = 0.4
    for tick in (0, 3, 7, 12, 20):
        expected = (path_position(ELL, (tick + 1) * dt) - path_position(ELL, tick * dt)) / dt
        np.testing.assert_allclose(leader_velocity(ELL, tick, dt), expected, atol=1e-12)


def test_velocity_over_corner_cuts_it() -> None:
    # Tick 7 at dt = 0.4 spans t = 2.8 .. 3.2: from (2.8, 0) to (3, 0.2).
    v = leader_velocity(ELL, 7, 0.4)
    np.testing.assert_allclose(v, [0.5, 0.5], atol=1e-12)
    assert np.linalg.norm(v) < ELL.speed


def test_waypoint_speed_never_exceeds_path_speed() -> None:
    rng = np.random.default_rng(30)
    for _ in range(20):
        points = tuple(tuple(p) for p in rng.uniform(-5, 5, size=(5, 2)))
        path = Waypoints(points=points, speed=float(rng.uniform(0.2, 3.0)))
        dt = float(rng.uniform(0.01, 0.2))
        speeds = [np.linalg.norm(leader_velocity(path, k, dt)) for k in range(400)]
        assert max(speeds) <= path.speed * (1 + 1e-9)
        assert max(speeds) == pytest.approx(path.speed, rel=1e-9)  # straight stretches: full speed


def test_euler_steps_of_leader_velocity_land_on_path() -> None:
    dt = 0.3
    x = path_position(ELL, 0.0)
    for k in range(30):
        x = x + dt * leader_velocity(ELL, k, dt)
        np.testing.assert_allclose(x, path_position(ELL, (k + 1) * dt), atol=1e-9)


def test_sinusoid_position_formula() -> None:
    np.testing.assert_allclose(path_position(WAVE, 0.0), [1.0, 2.0])
    np.testing.assert_allclose(path_position(WAVE, 1.0), [3.0, 2.5])  # sin(π/2) = 1
    np.testing.assert_allclose(path_position(WAVE, 2.0), [5.0, 2.0], atol=1e-12)
    np.testing.assert_allclose(path_position(WAVE, 3.0), [7.0, 1.5])


def test_sinusoid_peak_speed_formula() -> None:
    # (speed, 2π A / T) = (2, π/4).
    np.testing.assert_allclose(peak_speed(WAVE), [2.0, math.pi / 4])


def test_sinusoid_peak_speed_diagonal_axes() -> None:
    h = 1.0 / math.sqrt(2.0)
    wave = Sinusoid(
        start=(0.0, 0.0), direction=(h, h), normal=(-h, h), speed=1.0, amplitude=1.0, period=2.0
    )
    peak = (1.0 + math.pi) * h
    np.testing.assert_allclose(peak_speed(wave), [peak, peak])


def test_sinusoid_tick_velocity_within_and_reaching_peak() -> None:
    dt = 1e-3
    v = np.array([leader_velocity(WAVE, k, dt) for k in range(8000)])
    peak = peak_speed(WAVE)
    assert (np.abs(v) <= peak * (1 + 1e-9)).all()
    np.testing.assert_allclose(np.abs(v).max(axis=0), peak, rtol=1e-5)


@pytest.mark.parametrize(
    ("points", "speed", "expected"),
    [
        (((0.0, 0.0), (3.0, 4.0)), 5.0, (3.0, 4.0)),
        (((0.0, 0.0), (3.0, 0.0), (3.0, 4.0)), 2.0, (2.0, 2.0)),
        (((0.0, 0.0), (-3.0, 4.0), (-3.0, 4.0)), 1.0, (0.6, 0.8)),
        (((0.0, 0.0, 0.0), (0.0, 0.0, 2.0), (1.0, 2.0, 4.0)), 3.0, (1.0, 2.0, 3.0)),
    ],
)
def test_waypoint_peak_speed_per_coordinate(
    points: tuple[tuple[float, ...], ...], speed: float, expected: tuple[float, ...]
) -> None:
    np.testing.assert_allclose(peak_speed(Waypoints(points=points, speed=speed)), expected)


def test_waypoint_tick_velocity_within_peak_per_coordinate() -> None:
    path = Waypoints(points=((0.0, 0.0), (4.0, 1.0), (2.0, 6.0), (-1.0, 6.0)), speed=1.5)
    v = np.array([leader_velocity(path, k, 0.25) for k in range(100)])
    assert (np.abs(v) <= peak_speed(path) * (1 + 1e-9)).all()
