"""The collision-course flag Ω (11), Remark 4, and the evasive offset u^o of Section 3.

Obstacles are circles (spheres in 3-D): centres and radii in metres. ``heading`` is the agent's
filtered velocity (m/s); the ray of (11) starts at the agent and runs along it. The guard radius
of obstacle j is r_j + ρ, ρ the safety margin. Vectors are plain-float tuples (arrays are
accepted): this runs for every agent every tick, where a numpy call on a 2-vector costs more
than its arithmetic; the operations and their order are numpy's, so the bits are too.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Final

from shoal.bus.messages import picklable
from shoal.geometry.vectors import PointsLike, Vector, VectorLike, dot, norm, plain, scale, sub

_STILL = 1e-9  # m/s: below this speed the agent has no direction of motion, hence no ray


def ray_distance(origin: VectorLike, heading: VectorLike, centre: VectorLike) -> float:
    """d_ij: distance from ``centre`` to the ray from ``origin`` along ``heading``, m.

    Remark 4: inf (the paper's D̄) unless the obstacle is strictly ahead (an acute angle
    between the ray and the line to the obstacle), and inf for an agent that does not move.
    """
    speed = norm(heading)
    if speed < _STILL:
        return math.inf
    unit = [h / speed for h in heading]
    to_centre = sub(centre, origin)
    along = dot(to_centre, unit)
    if along <= 0.0:
        return math.inf
    return norm(sub(to_centre, scale(along, unit)))


def _left_of(unit: VectorLike) -> Vector:
    """A unit vector perpendicular to ``unit``, chosen deterministically (left in the plane;
    in 3-D the cross product of the axis ``unit`` is least along with ``unit``)."""
    if len(unit) == 2:
        return (-unit[1], unit[0])
    least = min(range(len(unit)), key=lambda k: abs(unit[k]))  # first of equals, as argmin
    axis = [1.0 if k == least else 0.0 for k in range(len(unit))]
    if len(unit) == 3:
        (a0, a1, a2), (u0, u1, u2) = axis, unit
        side: Vector = (a1 * u2 - a2 * u1, a2 * u0 - a0 * u2, a0 * u1 - a1 * u0)
    else:
        side = sub(axis, scale(dot(axis, unit), unit))
    size = norm(side)
    return tuple([x / size for x in side])


def evasive_offset(
    origin: VectorLike,
    heading: VectorLike,
    centre: VectorLike,
    radius: float,
    *,
    safety_margin: float,
    epsilon: float,
) -> Vector:
    """u^o: perpendicular to ``heading``, from the obstacle towards the ray, (dim,) in m.

    The paper's magnitude r_j - d_ij would leave the new path touching the obstacle. Here it is
    r_j + ρ + ε - d_ij: the shifted ray passes at r_j + ρ + ε, exactly where (11) stops firing,
    so ε covers the chattering band and ρ is the clearance kept. Zero if the ray already passes
    that far out. A ray through the centre (d_ij = 0) is pushed to the left of the heading.
    """
    size = norm(heading)
    unit = [h / size for h in heading]
    to_centre = sub(centre, origin)
    along = dot(to_centre, unit)
    foot = [o + along * u for o, u in zip(origin, unit)]
    away = sub(foot, centre)
    d = norm(away)
    direction = [a / d for a in away] if d > 1e-12 else _left_of(unit)
    magnitude = max(0.0, radius + safety_margin + epsilon - d)
    return scale(magnitude, direction)


@dataclass(init=False, slots=True, unsafe_hash=True)
class Evasion:
    """An evasive episode: the obstacle evaded and u^o, set at τ_i (grown by ``_ratchet``)."""

    obstacle_id: Final[int]
    centre: Final[Vector]
    radius: Final[float]
    offset: Final[Vector]

    def __init__(self, obstacle_id: int, centre: Vector, radius: float, offset: Vector) -> None:
        self.obstacle_id = obstacle_id
        self.centre = centre
        self.radius = radius
        self.offset = offset


picklable(Evasion)


def _ratchet(
    held: Evasion, position: Vector, heading: Vector, clearance: float, cap: float
) -> Evasion:
    """Grow u^o (never shrink it) while the ray still passes within r_j + ρ + ε of the obstacle,
    up to ``cap`` × (r_j + ρ + ε).

    u^o is fixed at τ_i from the heading of that instant, which the sign term's chattering blurs;
    re-measuring the ray while the episode lasts corrects a misjudged τ_i, along u^o's direction.
    Unbounded (the paper mode, cap = inf) it grew to 93 × (r_j + ρ + ε) in the campaign while an
    agent was held still: a set-point that far off keeps the agent away from its slot for long
    after the obstacle is passed.
    """
    short = held.radius + clearance - ray_distance(position, heading, held.centre)
    if not short > 0:
        return held
    size = norm(held.offset)
    if size == 0.0:
        return held
    most = cap * (held.radius + clearance)
    if size >= most:
        return held
    grown = scale(min(size + short, most) / size, held.offset)
    return Evasion(held.obstacle_id, held.centre, held.radius, grown)


def _triggers(
    position: Vector,
    heading: Vector,
    centres: Sequence[Vector],
    radii: VectorLike,
    *,
    trigger_radius: float,
    safety_margin: float,
    epsilon: float,
) -> list[tuple[float, int]]:
    """(distance to centre, index) of every obstacle that fires the first clause of (11)."""
    hits = []
    for k, (centre, radius) in enumerate(zip(centres, radii)):
        dist = norm(sub(position, centre))
        if dist > trigger_radius:
            continue
        if ray_distance(position, heading, centre) <= radius + safety_margin + epsilon:
            hits.append((dist, k))
    return sorted(hits)


def collision_course(
    position: VectorLike,
    heading: VectorLike,
    obstacle_ids: tuple[int, ...],
    centres: PointsLike,
    radii: VectorLike,
    held: Evasion | None,
    *,
    trigger_radius: float,
    sensing_radius: float,
    safety_margin: float,
    epsilon: float,
    ratchet_cap: float = math.inf,
) -> Evasion | None:
    """Ω_i(t) of (11): the evasion in force this tick, or None for Ω_i = 0.

    Fires when some obstacle within d̄ of the agent lies within r_j + ρ + ε of its ray. An
    episode, once started, holds (our reading of the second clause of (11)) while its obstacle
    is sensed (within d, not d̄: chattering at the d̄ boundary must not flicker Ω) and the
    agent has not yet passed the obstacle's guard circle r_j + ρ along its
    current heading. A newly
    firing obstacle nearer than the held one starts a new episode (new τ_i, new u^o). While an
    episode holds, u^o only grows if the ray still passes too close (see ``_ratchet``), to at
    most ``ratchet_cap`` × (r_j + ρ + ε).
    """
    return _course(
        plain(position),
        plain(heading),
        obstacle_ids,
        [plain(c) for c in centres],
        plain(radii),
        held,
        trigger_radius=trigger_radius,
        sensing_radius=sensing_radius,
        safety_margin=safety_margin,
        epsilon=epsilon,
        ratchet_cap=ratchet_cap,
    )


def _course(
    position: Vector,
    heading: Vector,
    obstacle_ids: tuple[int, ...],
    centres: Sequence[Vector],
    radii: Vector,
    held: Evasion | None,
    *,
    trigger_radius: float,
    sensing_radius: float,
    safety_margin: float,
    epsilon: float,
    ratchet_cap: float,
) -> Evasion | None:
    """:func:`collision_course` on plain-float tuples."""
    hits = _triggers(
        position,
        heading,
        centres,
        radii,
        trigger_radius=trigger_radius,
        safety_margin=safety_margin,
        epsilon=epsilon,
    )
    if held is not None:
        from_centre = sub(position, held.centre)
        dist = norm(from_centre)
        speed = norm(heading)
        along = dot(from_centre, heading) / speed if speed > _STILL else 0.0
        if dist <= sensing_radius and along < held.radius + safety_margin:
            nearer = [k for d, k in hits if d < dist and obstacle_ids[k] != held.obstacle_id]
            if not nearer:
                return _ratchet(held, position, heading, safety_margin + epsilon, ratchet_cap)
    if not hits:
        return None
    _, k = hits[0]
    offset = evasive_offset(
        position, heading, centres[k], radii[k], safety_margin=safety_margin, epsilon=epsilon
    )
    return Evasion(obstacle_id=obstacle_ids[k], centre=centres[k], radius=radii[k], offset=offset)
