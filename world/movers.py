"""Moving obstacles: how each one moves, as pure functions the world and the reference call.

Three kinds (docs/people.md):

- :class:`Drift`: a constant velocity for the whole run (a blind walker, a cart);
- :class:`Route`: waypoints walked in order at a constant speed, optionally in a loop;
- :class:`Person`: a pedestrian of the social force model (Helbing & Molnár 1995): it
  accelerates towards its next goal at its preferred speed with relaxation time
  :data:`RELAXATION` and is pushed away from other people, from standing obstacles and, if
  ``reactive``, from the robots, by forces that fall off exponentially with the gap between
  bodies; its speed never exceeds its cap u_max.

A tick k of a run: from the obstacles' centres c_k and last velocities, :func:`plan` gives the
velocity w_k each holds over the tick (people react to the agents' positions at the start of
the tick); the agents sense c_k and w_k; then c_{k+1} = c_k + dt·w_k (:func:`advance`). All
arithmetic is on plain Python floats in a fixed order, so every machine gets the same bits
(geometry/vectors.py).

Why not a library: PySocialForce (PyPI 1.1.2) is 2-D only, needs numba and scipy (a JIT
compiler in every world process, whose float results are not promised across CPUs), and is
built around its own scene and stepping loop. No RVO2 (ORCA) binding is on PyPI (checked
2026-12: rvo2, pyrvo2, python-rvo2, rvo2-py, Cython-RVO2; ``rvo`` is an unrelated tool). The
model below is the paper's equations in about sixty lines.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from shoal.bus.types import Vector
from shoal.geometry.vectors import right_of, vdot

RELAXATION = 0.5  # s: τ, how fast a person takes up its preferred velocity
# The repulsions, each (V/σ)·exp(−gap/σ), the gradient of the 1995 paper's exponential
# potentials: from another person or a robot V = 2.1 m²/s², σ = 0.3 m; from a standing
# obstacle ("walls") U = 10 m²/s², R = 0.2 m.
PUSH, PUSH_RANGE = 2.1 / 0.3, 0.3  # m/s², m
WALL_PUSH, WALL_RANGE = 10.0 / 0.2, 0.2  # m/s², m
BEHIND = 0.5  # λ: the weight of what is behind a person against what is ahead (1 = isotropic)
# People keep to the right: a body ahead also pushes sideways, to the right of the heading, by
# this fraction of its push. It decides the symmetric encounters the model cannot (two people
# exactly head on, a circle of people crossing at its centre would otherwise stand locked).
KEEP_RIGHT = 0.5
AT_GOAL = 0.2  # m: a person this close to its goal heads for the next one
PUSH_REACH = 3.0  # m: gaps beyond this push with less than e^-10 of the contact push


@dataclass(frozen=True, slots=True)
class Drift:
    """A constant ``velocity`` (m/s) all run."""

    velocity: Vector

    @property
    def speed_cap(self) -> float:
        return math.sqrt(vdot(self.velocity, self.velocity))


@dataclass(frozen=True, slots=True)
class Route:
    """``waypoints`` (m) walked in order from the obstacle's centre at ``speed`` (m/s); at the
    last one it stops, or with ``loop`` heads for the first again."""

    waypoints: tuple[Vector, ...]
    speed: float
    loop: bool = False

    @property
    def speed_cap(self) -> float:
        return self.speed


@dataclass(frozen=True, slots=True)
class Person:
    """A pedestrian walking to its ``goals`` (m) in order at its preferred ``speed`` (m/s), never
    faster than ``u_max``; ``reactive``: it also gives way to the robots (else it sees only
    people and standing obstacles); ``loop``: after the last goal it heads for the first."""

    goals: tuple[Vector, ...]
    speed: float
    u_max: float
    reactive: bool = True
    loop: bool = False

    @property
    def speed_cap(self) -> float:
        return self.u_max


Motion = Drift | Route | Person


@dataclass(frozen=True, slots=True)
class Body:
    """A circle (sphere) that a person is pushed away from: another person or an agent, or
    (``wall``) a standing obstacle."""

    centre: Vector
    radius: float
    wall: bool = False


@dataclass(frozen=True, slots=True)
class MoverState:
    """Every moving obstacle at the start of a tick, in scenario order: centres (m), the
    velocity each held over the last tick (m/s; before tick 0 its start velocity), and the
    index of the waypoint or goal each is heading for."""

    centres: tuple[Vector, ...]
    velocities: tuple[Vector, ...]
    legs: tuple[int, ...]


def _toward(here: Vector, there: Vector, speed: float) -> Vector:
    diff = [b - a for a, b in zip(here, there, strict=True)]
    dist = math.sqrt(vdot(diff, diff))
    if dist == 0.0:
        return tuple(0.0 for _ in here)
    return tuple(x * (speed / dist) for x in diff)


def _targets(motion: Route | Person) -> tuple[Vector, ...]:
    return motion.waypoints if isinstance(motion, Route) else motion.goals


def _next_leg(motion: Route | Person, leg: int) -> int:
    """The leg after ``leg``: the next target, the first again in a loop, else past the end."""
    n = len(_targets(motion))
    return (leg + 1) % n if motion.loop else leg + 1


def start(motions: Sequence[Motion], centres: Sequence[Vector]) -> MoverState:
    """The state before tick 0: drifts at their velocity, everyone else heading for their first
    target (a person already walking at its preferred speed)."""
    velocities = []
    for m, c in zip(motions, centres, strict=True):
        if isinstance(m, Drift):
            velocities.append(m.velocity)
        elif isinstance(m, Person):
            velocities.append(_toward(c, m.goals[0], m.speed))
        else:
            velocities.append(tuple(0.0 for _ in c))
    return MoverState(tuple(centres), tuple(velocities), tuple(0 for _ in motions))


def plan(
    motions: Sequence[Motion],
    radii: Sequence[float],
    state: MoverState,
    agents: Sequence[Vector],
    agent_radius: float,
    standing: Sequence[Body],
    dt: float,
) -> MoverState:
    """The same state with the velocity every moving obstacle holds over this tick (and the
    leg it is on): ``agents`` are the robots' positions at the start of the tick."""
    velocities: list[Vector] = []
    legs: list[int] = []
    for k, (m, c) in enumerate(zip(motions, state.centres, strict=True)):
        leg = state.legs[k]
        if isinstance(m, Drift):
            velocities.append(m.velocity)
        elif isinstance(m, Route):
            w, leg = _route_velocity(m, c, leg, dt)
            velocities.append(w)
        else:
            others = [Body(state.centres[q], radii[q]) for q in range(len(motions)) if q != k]
            if m.reactive:
                others += [Body(a, agent_radius) for a in agents]
            w, leg = _person_velocity(
                m, c, radii[k], state.velocities[k], leg, [*others, *standing], dt
            )
            velocities.append(w)
        legs.append(leg)
    return MoverState(state.centres, tuple(velocities), tuple(legs))


def advance(state: MoverState, dt: float) -> MoverState:
    """The state at the start of the next tick: c + dt·w for every moving obstacle."""
    centres = tuple(
        tuple(x + dt * v for x, v in zip(c, w, strict=True))
        for c, w in zip(state.centres, state.velocities, strict=True)
    )
    return MoverState(centres, state.velocities, state.legs)


def _route_velocity(m: Route, here: Vector, leg: int, dt: float) -> tuple[Vector, int]:
    """Towards the current waypoint at ``m.speed``; a waypoint nearer than one step is reached
    exactly (the step is shortened to it) and the next one taken up from the next tick."""
    if leg >= len(m.waypoints):
        return tuple(0.0 for _ in here), leg
    target = m.waypoints[leg]
    diff = [b - a for a, b in zip(here, target, strict=True)]
    dist = math.sqrt(vdot(diff, diff))
    if dist <= m.speed * dt:
        return tuple(x / dt for x in diff), _next_leg(m, leg)
    return tuple(x * (m.speed / dist) for x in diff), leg


def _person_velocity(
    m: Person,
    here: Vector,
    radius: float,
    last: Vector,
    leg: int,
    bodies: Sequence[Body],
    dt: float,
) -> tuple[Vector, int]:
    """One step of the social force model: v ← v + dt·(f_goal + Σ f_push), capped at u_max."""
    if leg < len(m.goals) and math.dist(here, m.goals[leg]) <= AT_GOAL:
        leg = _next_leg(m, leg)
    if leg < len(m.goals):
        wanted = _toward(here, m.goals[leg], m.speed)
    else:
        wanted = tuple(0.0 for _ in here)  # arrived: it stands
    force = [(w - v) / RELAXATION for w, v in zip(wanted, last, strict=True)]
    speed = math.sqrt(vdot(last, last))
    heading = tuple(v / speed for v in last) if speed > 0.0 else None
    for b in bodies:
        diff = [a - c for a, c in zip(here, b.centre, strict=True)]
        dist = math.sqrt(vdot(diff, diff))
        gap = dist - radius - b.radius
        if dist == 0.0 or gap > PUSH_REACH:
            continue
        away = [x / dist for x in diff]
        if b.wall:
            size = WALL_PUSH * math.exp(-gap / WALL_RANGE)
        else:
            size = PUSH * math.exp(-gap / PUSH_RANGE)
        side = 0.0
        if heading is not None:  # what lies ahead (away points back at the person) counts more
            ahead = -vdot(heading, away)
            size *= BEHIND + (1.0 - BEHIND) * (1.0 + ahead) / 2.0
            side = KEEP_RIGHT * size * max(ahead, 0.0)
        for c in range(len(force)):
            force[c] += size * away[c]
        if side and heading is not None:
            right = right_of(heading)
            for c in range(len(force)):
                force[c] += side * right[c]
    velocity = [v + dt * f for v, f in zip(last, force, strict=True)]
    size = math.sqrt(vdot(velocity, velocity))
    if size > m.u_max:
        velocity = [v * (m.u_max / size) for v in velocity]
    return tuple(velocity), leg
