"""The leader's motion ẋ_1 = f(t): waypoints along straight legs, or the paper's sinusoid.

Only the leader agent moves along its path, but the world evaluates it too (Assumption 4 and the
|f| < β check at load, f_max for the convergence bound), so it lives in geometry/, which both share.

The leader moves open loop: the command of tick k is the displacement of the path over the tick
divided by dt, so an Euler step lands on the path and |f| never exceeds the path's speed (corners
are cut within one tick, never overshot).
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from shoal.bus.types import PathSpec, Sinusoid, Waypoints
from shoal.geometry.vectors import FloatArray, norm


def path_position(path: PathSpec, t: float) -> FloatArray:
    """p(t), m: where the leader's path is at time t ≥ 0 s."""
    if isinstance(path, Sinusoid):
        start = np.asarray(path.start, dtype=np.float64)
        direction = np.asarray(path.direction, dtype=np.float64)
        normal = np.asarray(path.normal, dtype=np.float64)
        wave = path.amplitude * math.sin(2.0 * math.pi * t / path.period)
        return start + direction * (path.speed * t) + normal * wave
    return _along_waypoints(path, path.speed * t)


def path_positions(path: PathSpec, times: FloatArray) -> FloatArray:
    """p(t) for many times at once: (k,) s in, (k, dim) m out."""
    if isinstance(path, Sinusoid):
        start = np.asarray(path.start, dtype=np.float64)
        direction = np.asarray(path.direction, dtype=np.float64)
        normal = np.asarray(path.normal, dtype=np.float64)
        # math.sin, not np.sin: numpy's vectorised sine is its own (SIMD) code, libm's is not
        phases = (2.0 * math.pi * times / path.period).tolist()
        wave = path.amplitude * np.asarray([math.sin(x) for x in phases], dtype=np.float64)
        return np.asarray(
            start + np.outer(path.speed * times, direction) + np.outer(wave, normal),
            dtype=np.float64,
        )
    return np.asarray([path_position(path, float(t)) for t in times], dtype=np.float64)


def _along_waypoints(path: Waypoints, distance: float) -> FloatArray:
    points = np.asarray(path.points, dtype=np.float64)
    for a, b in itertools.pairwise(points):
        leg = norm(b - a)
        if distance <= leg:
            out = a + (b - a) * (distance / leg) if leg > 0 else a.copy()
            return np.asarray(out, dtype=np.float64)
        distance -= leg
    return np.asarray(points[-1].copy(), dtype=np.float64)


def leader_velocity(path: PathSpec, tick: int, dt: float) -> FloatArray:
    """f over tick k, m/s: (p((k+1)·dt) - p(k·dt)) / dt."""
    return (path_position(path, (tick + 1) * dt) - path_position(path, tick * dt)) / dt


def leader_velocities(path: PathSpec, samples: int = 720) -> FloatArray:
    """(k, dim) the leader's velocities f along its path, m/s: each leg's (waypoints), or a
    sinusoid's at ``samples`` phases of its period (both extremes of its wave among them)."""
    if isinstance(path, Sinusoid):
        phase = np.linspace(0.0, 2.0 * math.pi, samples, endpoint=False)
        wave = 2.0 * math.pi * path.amplitude / path.period
        along = np.asarray(path.direction, dtype=np.float64) * path.speed
        across = np.asarray(path.normal, dtype=np.float64) * wave
        return along[None, :] + np.cos(phase)[:, None] * across[None, :]
    points = np.asarray(path.points, dtype=np.float64)
    legs = [(b - a) / norm(b - a) * path.speed for a, b in itertools.pairwise(points)
            if norm(b - a) > 0]  # fmt: skip
    return np.asarray(legs, dtype=np.float64).reshape(len(legs), points.shape[1])


def peak_speed(path: PathSpec) -> FloatArray:
    """f_max per coordinate, m/s: the largest |f_c(t)| over all t (for |f| < β and the bounds)."""
    if isinstance(path, Sinusoid):
        direction = np.abs(np.asarray(path.direction, dtype=np.float64))
        normal = np.abs(np.asarray(path.normal, dtype=np.float64))
        wave = 2.0 * math.pi * path.amplitude / path.period
        return np.asarray(direction * path.speed + normal * wave, dtype=np.float64)
    points = np.asarray(path.points, dtype=np.float64)
    peak = np.zeros(points.shape[1])
    for a, b in itertools.pairwise(points):
        leg = norm(b - a)
        if leg > 0:
            peak = np.maximum(peak, np.abs(b - a) / leg * path.speed)
    return peak
