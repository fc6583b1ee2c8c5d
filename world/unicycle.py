"""Unicycle kinematics for the control point ahead of the axle, as pure functions.

A unicycle at body centre c with heading θ drives at speed v along e(θ) = (cos θ, sin θ) and turns
at ω. shoal controls the point p = c + l·e(θ) a projection distance l ahead of the axle (the
Robotarium's "near-identity diffeomorphism"): the paper's law and the safety filter give the
point's velocity u, and

    v = e(θ)·u,   ω = e⊥(θ)·u / l,   e⊥(θ) = (−sin θ, cos θ),

make ṗ = u at the start of the tick. With (v, ω) held over the tick, ṗ(t) = R(ω t)·u: the point
moves at the constant speed |u| along a direction that turns at ω, so its displacement is at
most |u|·dt and it departs from the straight step p + u·t by at most |u|·|ω|·t²/2 ≤
|u|²·dt²/(2l) (:func:`arc_departure`). The body, a disc of ``agent_radius`` about c, lies within l
of p. So a body stays inside the disc of radius agent_radius + l + |u_max|²·dt²/(2l) about the
point's straight step: the single-integrator filter kept on that reach keeps the bodies apart
and off the obstacles along their true arcs (docs/safety.md, Unicycles).

|v| ≤ |u| and |ω| ≤ |u|/l for every θ, so capping |u| caps the speed, the turn rate and the wheel
speeds at once (:meth:`~shoal.world.scenario.Unicycle.point_speed_cap`); the filter's output is
never longer than its capped input (a projection onto a convex set that holds 0).
"""

from __future__ import annotations

import math

import numpy as np

from shoal.bus.geometry import FloatArray


def wheel_command(
    u: FloatArray, headings: FloatArray, lookahead: float
) -> tuple[FloatArray, FloatArray]:
    """(v, ω) per agent, m/s and rad/s, that move each point at velocity ``u`` (n, 2) now."""
    cos, sin = np.cos(headings), np.sin(headings)
    v = cos * u[:, 0] + sin * u[:, 1]
    omega = (-sin * u[:, 0] + cos * u[:, 1]) / lookahead
    return v, omega


def step(
    points: FloatArray, headings: FloatArray, u: FloatArray, lookahead: float, dt: float
) -> tuple[FloatArray, FloatArray]:
    """The points (n, 2) and headings (n,) after ``dt`` seconds with the (v, ω) of
    :func:`wheel_command` held: the exact arc (a straight line where ω = 0)."""
    v, omega = wheel_command(u, headings, lookahead)
    out = np.empty_like(points)
    after = np.empty_like(headings)
    for i in range(len(points)):
        theta, w, speed = float(headings[i]), float(omega[i]), float(v[i])
        cx = float(points[i, 0]) - lookahead * math.cos(theta)
        cy = float(points[i, 1]) - lookahead * math.sin(theta)
        turned = theta + w * dt
        # The chord of the arc: length v·dt·sin(x)/x along θ + x, x = ω·dt/2 (the same as
        # (v/ω)(sin θ' − sin θ, cos θ − cos θ'), without its cancellation when ω is tiny).
        half = 0.5 * w * dt
        chord = speed * dt * (math.sin(half) / half if half != 0.0 else 1.0)
        cx += chord * math.cos(theta + half)
        cy += chord * math.sin(theta + half)
        out[i, 0] = cx + lookahead * math.cos(turned)
        out[i, 1] = cy + lookahead * math.sin(turned)
        after[i] = turned
    return out, after


def body_centres(points: FloatArray, headings: FloatArray, lookahead: float) -> FloatArray:
    """Where each body's centre (the axle's midpoint) is, l behind its point."""
    return points - lookahead * np.stack([np.cos(headings), np.sin(headings)], axis=-1)


def arc_departure(speed: float, lookahead: float, dt: float) -> float:
    """m: the most a point moving at ``speed`` departs from its straight step over one tick,
    speed²·dt²/(2l)."""
    return speed * speed * dt * dt / (2.0 * lookahead)
