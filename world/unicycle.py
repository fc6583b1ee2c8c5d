"""Unicycle kinematics for the control point ahead of the axle, as pure functions.

A unicycle at body centre c with heading θ drives at speed v along e(θ) = (cos θ, sin θ) and turns
at ω. shoal controls the point p = c + l·e(θ) a projection distance l ahead of the axle: the
paper's law and the safety filter give the point's step u·dt over the tick, and the world (the
robot's driver) holds the one (v, ω) that puts the point exactly there at the tick's end
(:func:`wheel_command`). In between, the point moves at constant speed along a circular arc
over that chord, never farther than l·x²/2 ≈ |u|²dt²/(8l) from where the straight step would
have it at the same instant (:func:`arc_departure`); the body, a disc of ``agent_radius``
about c, lies within l of p.

Why the end of the tick and not its start. The Robotarium's near-identity map
v = e(θ)·u, ω = e⊥(θ)·u/l makes ṗ = u only at the tick's start: the point ends up to
|u|²dt²/(2l) off the step the filter certified, and the next tick certifies from there. Pressed
against a guard, that departure ratchets inwards tick after tick (the filter's row for an agent
inside its guard only forbids going deeper): measured, 14 of 10,000 campaign fields drove a
body into an obstacle, its point 0.13 m inside its guard. Matching the end keeps every tick's
start on a step the filter certified (up to rounding), so the single-integrator theorem holds
at the ticks and only that small departure is added between them (docs/safety.md, Unicycles).

The map: in the body frame the point's step is w·dt with w = R(−θ)·u, and over a tick of (v, ω)
held the point moves by dt·(sin x/x)·R(θ + x)·(v, l·ω), x = ω·dt/2. Solved for (v, ω):
tan x = w_y / (2l/dt + w_x), ω = 2x/dt, v = (x/sin x)·(cos x·w_x + sin x·w_y). With
|u|·dt ≤ l (the cap, :meth:`~shoal.world.scenario.Unicycle.point_speed_cap`) the denominator is
positive and |x| ≤ arcsin(|u|·dt/(2l)) ≤ π/6.
"""

from __future__ import annotations

import math

import numpy as np

from shoal.geometry.vectors import FloatArray


def _sinc(x: float) -> float:
    return math.sin(x) / x if x != 0.0 else 1.0


Lookahead = float | FloatArray  # l for every agent, or (n,) per agent: 0 for a single integrator


def _each(lookahead: Lookahead, n: int) -> list[float]:
    if isinstance(lookahead, (float, int)):
        return [float(lookahead)] * n
    out: list[float] = np.asarray(lookahead, dtype=np.float64).tolist()
    return out


def _command(theta: float, ux: float, uy: float, ell: float, dt: float) -> tuple[float, float]:
    """(v, ω) of one unicycle at heading ``theta`` whose point moves by (ux, uy)·dt exactly."""
    cos, sin = math.cos(theta), math.sin(theta)
    wx, wy = cos * ux + sin * uy, -sin * ux + cos * uy
    x = math.atan2(wy, 2.0 * ell / dt + wx)
    return (math.cos(x) * wx + math.sin(x) * wy) / _sinc(x), 2.0 * x / dt


def _drive(
    px: float, py: float, theta: float, speed: float, w: float, ell: float, elapsed: float
) -> tuple[float, float, float]:
    """One unicycle's point and heading after ``elapsed`` s of (``speed``, ``w``) held."""
    cx = px - ell * math.cos(theta)
    cy = py - ell * math.sin(theta)
    # The chord of the body's arc: v·t·sin(x)/x along θ + x, x = ω·t/2 (the same as
    # (v/ω)(sin θ' − sin θ, cos θ − cos θ'), without its cancellation when ω is tiny).
    half = 0.5 * w * elapsed
    chord = speed * elapsed * _sinc(half)
    cx += chord * math.cos(theta + half)
    cy += chord * math.sin(theta + half)
    turned = theta + w * elapsed
    return cx + ell * math.cos(turned), cy + ell * math.sin(turned), turned


def wheel_command(
    u: FloatArray, headings: FloatArray, lookahead: Lookahead, dt: float
) -> tuple[FloatArray, FloatArray]:
    """(v, ω) per agent, m/s and rad/s, which held for ``dt`` s move each point by ``u``·dt
    exactly ((n, 2) point velocities, (n,) headings); a single integrator's (l = 0) is NaN."""
    n = len(headings)
    pairs = [
        (math.nan, math.nan) if ell == 0.0 else _command(theta, ux, uy, ell, dt)
        for theta, (ux, uy), ell in zip(headings.tolist(), u.tolist(), _each(lookahead, n))
    ]
    return np.array([v for v, _ in pairs]), np.array([w for _, w in pairs])


def drive(
    points: FloatArray,
    headings: FloatArray,
    v: FloatArray,
    omega: FloatArray,
    lookahead: Lookahead,
    elapsed: float,
) -> tuple[FloatArray, FloatArray]:
    """The points (n, 2) and headings (n,) after ``elapsed`` s with (v, ω) held: the body's exact
    arc (a straight line where ω = 0), the point l ahead of it. Only for unicycles (l > 0)."""
    moved = [
        _drive(px, py, theta, speed, w, ell, elapsed)
        for (px, py), theta, speed, w, ell in zip(
            points.tolist(), headings.tolist(), v.tolist(), omega.tolist(),
            _each(lookahead, len(points)),
        )
    ]  # fmt: skip
    return np.array([(x, y) for x, y, _ in moved]), np.array([t for _, _, t in moved])


def step(
    points: FloatArray, headings: FloatArray, u: FloatArray, lookahead: Lookahead, dt: float
) -> tuple[FloatArray, FloatArray]:
    """One tick: the points and headings after ``dt`` s of the :func:`wheel_command` that moves
    each point by ``u``·dt; the points land there up to rounding. A single integrator of a
    mixed formation (l = 0) moves by exactly ``u``·dt (the same bits as
    world/kinematics.py's ``integrate``) and keeps its heading."""
    out: list[tuple[float, float]] = []
    after: list[float] = []
    for (px, py), theta, (ux, uy), ell in zip(
        points.tolist(), headings.tolist(), u.tolist(), _each(lookahead, len(points))
    ):
        if ell == 0.0:  # integrate()'s p + dt·u, elementwise: the same bits
            out.append((px + dt * ux, py + dt * uy))
            after.append(theta)
            continue
        v, w = _command(theta, ux, uy, ell, dt)
        x, y, turned = _drive(px, py, theta, v, w, ell, dt)
        out.append((x, y))
        after.append(turned)
    return np.array(out, dtype=np.float64).reshape(points.shape), np.array(after, dtype=np.float64)


def body_centres(points: FloatArray, headings: FloatArray, lookahead: Lookahead) -> FloatArray:
    """Where each body's centre (the axle's midpoint) is, l behind its point (a single
    integrator's, l = 0, is its point)."""
    ell = np.asarray(lookahead, dtype=np.float64)
    if ell.ndim == 1:
        ell = ell[..., None]
    back: FloatArray = points - ell * np.stack([np.cos(headings), np.sin(headings)], axis=-1)
    return back


def speed_cap(limit: float, lookahead: float, dt: float) -> float:
    """m/s: the fastest point velocity u whose (v, l·ω) stays within ``limit`` for any heading,
    (2l/dt)·sin(limit·dt/(2l)), and no faster than l/dt (so |x| ≤ π/6).

    |(v, l·ω)| = |u|·x/sin x with |x| ≤ arcsin(|u|·dt/(2l)), which is at most
    (2l/dt)·arcsin(|u|·dt/(2l)); that is ≤ ``limit`` exactly up to this cap."""
    scale = 2.0 * lookahead / dt
    return scale * math.sin(min(limit / scale, math.pi / 6.0))


def arc_departure(speed: float, lookahead: float, dt: float) -> float:
    """m: the most a point moving at ``speed`` (≤ l/dt) is ever away from where the straight
    step would have it at the same instant, p0 + u·t: l·x²/2 with sin x = speed·dt/(2l).

    d(t) = p(t) − (p0 + u·t) is 0 at both ends of the tick and |d̈| = |p̈| = S·|ω| (the point
    runs at constant speed S = |u|·x/sin x round a circle, turning at |ω| = 2|x|/dt), so
    |d| ≤ S·|ω|·dt²/8 = |u|·dt·x²/(4·sin x) = l·x²/2 (≈ |u|²dt²/(8l), the arc's sagitta, which
    it bounds too)."""
    x = math.asin(min(speed * dt / (2.0 * lookahead), 1.0))
    return 0.5 * lookahead * x * x
