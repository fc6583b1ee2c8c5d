"""The leader's detour (relaxing Assumption 4, as the paper suggests): with the safety filter a
leader whose waypoint path runs into an obstacle's guard circle re-plans around it and resumes
its route; the followers know nothing of it, they follow the leader as always.

The leader then follows its route by position rather than by the clock: each tick it heads for
the next waypoint at the path's speed (the last step shortened to land on it), so a leader held
back by its filter, or sent round an obstacle, still visits every waypoint, in order. Points and
positions are (dim,) vectors in metres, plain floats (arrays are taken and turned into floats on
entry); speeds m/s; dt s. The arithmetic is numpy's elementwise arithmetic, term for term, so
the bits are what the array version gave.

A detour around obstacle j is a polygon circumscribing the circle of radius R' = r_j + ρ +
``clearance`` on the side of the leg away from the centre: the leg to its first vertex and from
its last vertex leave along tangents, and each edge touches the circle of radius R', so the whole
detour keeps R' from the centre (in 3-D the polygon lies in the plane of the leg and the centre).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence

from shoal.bus.types import REACHED
from shoal.geometry.vectors import (
    Vector,
    VectorLike,
    add,
    divide,
    dot,
    norm,
    plain,
    scale,
    segment_distance,
    sub,
)

_STEP = math.radians(30.0)  # the polygon's largest turn per vertex

Circle = tuple[Vector, float]  # (centre, radius), m


def lead(
    position: VectorLike,
    route: tuple[Vector, ...],
    speed: float,
    dt: float,
    *,
    reach: float = REACHED,
) -> tuple[Vector, tuple[Vector, ...]]:
    """The leader's velocity towards the next waypoint of ``route``, and the route left.

    Waypoints already reached (within ``reach`` m) are dropped first; with none left the
    leader stands still.
    """
    here = plain(position)
    while route and norm(sub(route[0], here)) <= reach:
        route = route[1:]
    if not route:
        return (0.0,) * len(here), route
    to_next = sub(route[0], here)
    dist = norm(to_next)
    return scale(min(speed * dt, dist) / (dist * dt), to_next), route


Known = tuple[tuple[int, Vector, float], ...]  # (obstacle id, centre m, radius m), by id


def remember(
    known: Known, ids: Sequence[int], centres: Sequence[VectorLike], radii: Sequence[float]
) -> Known:
    """``known`` with the sensed standing obstacles added, in id order (the order the world
    senses them in). A leader plans its detours against every obstacle it has seen, not only
    those in range now: planning against what is in view alone, a leader going round a cluster
    lost sight of one obstacle, planned round the other side, saw it again and turned back, for
    the rest of the run (measured on a hard field, tools/campaign/hard.py seed 33)."""
    if set(ids) <= {k for k, _, _ in known}:
        return known
    merged = {k: (k, c, r) for k, c, r in known}
    for i, c, r in zip(ids, centres, radii):
        merged.setdefault(i, (i, plain(c), float(r)))
    return tuple([merged[k] for k in sorted(merged)])


def steer(
    position: VectorLike,
    route: tuple[Vector, ...],
    planned: int,
    centres: Sequence[VectorLike],
    radii: Sequence[float],
    *,
    guard: float,
    clearance: float,
    reach: float = REACHED,
) -> tuple[tuple[Vector, ...], int]:
    """The route ahead of a leader at ``position``, and how many of its first points are the
    vertices of a detour (``planned``; the rest are the scenario's waypoints).

    A detour is planned against the obstacles sensed when it is planned; one that comes into
    view later can lie across it (a vertex inside its guard): then the detour still ahead is
    dropped and planned anew, from here to the next waypoint, against every obstacle sensed now.
    Without that the leader headed for a vertex it could never reach and circled the obstacle
    that held it for the rest of the run (5 of 6 fields of another generator that
    never arrived). While the detour ahead is clear it is kept as it is; with no detour ahead,
    :func:`detour` plans one if the next leg needs it. Points already reached (within ``reach``
    m) are dropped."""
    here = plain(position)
    while route and norm(sub(route[0], here)) <= reach:
        route, planned = route[1:], max(0, planned - 1)
    if planned and len(centres):
        circles = [(plain(c), float(r)) for c, r in zip(centres, radii)]
        ahead = [here, *route[: planned + 1]]
        if any(
            _blocks(a, b, c, r, guard, clearance)
            for a, b in itertools.pairwise(ahead)
            for c, r in circles
        ):
            route, planned = route[planned:], 0
    if planned:
        return route, planned
    planned_route = detour(here, route, centres, radii, guard=guard, clearance=clearance)
    return planned_route, len(planned_route) - len(route)


def detour(
    position: VectorLike,
    route: tuple[Vector, ...],
    centres: Sequence[VectorLike],
    radii: Sequence[float],
    *,
    guard: float,
    clearance: float,
) -> tuple[Vector, ...]:
    """``route`` with a detour in front when its next leg passes within r_j + ``guard`` +
    ``clearance``/2 of a sensed obstacle, else as it is. ``guard`` is ρ; the detour keeps
    r_j + ρ + ``clearance`` from the centre of the nearest such obstacle along the leg, round
    its shorter side unless that side's polygon crosses another sensed obstacle, then round the
    longer side, and if both are blocked, round one circle that encloses the obstacles in the
    way. A waypoint inside the circle cannot be gone round: the route is left as it is (the
    filter stops the leader at the guard). ``centres`` (m, dim) and ``radii`` (m,): the sensed
    obstacles."""
    if not route or len(centres) == 0:
        return route
    here = plain(position)
    circles = [(plain(c), float(r)) for c, r in zip(centres, radii)]
    target = route[0]
    hit = _first_in_way(here, target, circles, guard, clearance)
    for _ in range(len(circles)):
        if hit is None:
            return route
        centre, radius = hit
        keep = radius + guard + clearance
        if norm(sub(target, centre)) <= keep:
            return route  # the waypoint itself is in the way: no detour reaches it
        polygon: list[Vector] = []
        for longer in (False, True):
            polygon = _around(here, target, centre, keep, longer=longer)
            legs = list(zip([here, *polygon], [*polygon, target]))
            if not any(_blocks(a, b, c, r, guard, clearance) for a, b in legs for c, r in circles):
                return (*polygon, *route)
        hit = _enclosing([hit, *(c for c in circles if _near_polygon(c, polygon, hit))])
    return route


def _first_in_way(
    position: Vector, target: Vector, circles: list[Circle], guard: float, clearance: float
) -> Circle | None:
    """The obstacle nearest along the leg among those it passes too close to."""
    hits = [
        (dot(sub(c, position), sub(target, position)), i)
        for i, (c, r) in enumerate(circles)
        if _blocks(position, target, c, r, guard, clearance)
    ]
    return circles[min(hits)[1]] if hits else None


def _blocks(
    a: Vector, b: Vector, centre: Vector, radius: float, guard: float, clearance: float
) -> bool:
    return segment_distance(centre, a, b) < radius + guard + clearance / 2.0


def _near_polygon(circle: Circle, polygon: list[Vector], around: Circle) -> bool:
    """``circle`` is another obstacle than ``around`` and within the reach of its detour."""
    centre, radius = circle
    if centre is around[0]:
        return False
    reach = max([norm(sub(v, around[0])) for v in polygon])
    return norm(sub(centre, around[0])) - radius < reach


def _enclosing(circles: list[Circle]) -> Circle:
    """A circle (centre, radius) enclosing every one of ``circles``: about their centroid (the
    centres summed in order and divided by their count, as numpy's mean over axis 0)."""
    total = circles[0][0]
    for c, _ in circles[1:]:
        total = add(total, c)
    centre = divide(total, float(len(circles)))
    radius = max([norm(sub(c, centre)) + r for c, r in circles])
    return centre, radius


def _around(
    position: Vector, target: Vector, centre: Vector, radius: float, *, longer: bool
) -> list[Vector]:
    """The vertices of the polygon that takes a leg from ``position`` to ``target`` round the
    circle (``centre``, ``radius``): the shorter way, or with ``longer`` the other."""
    u = sub(position, centre)
    w = sub(target, centre)
    du, dw = norm(u), norm(w)
    e1 = divide(u, du)
    leg = sub(target, position)
    side = sub(w, scale(dot(w, e1), e1))  # the plane of the leg and the centre: e1, e2
    if norm(side) < 1e-12:  # the target straight behind the centre
        side = _perpendicular(leg if norm(leg) > 0 else e1)
    e2 = divide(side, norm(side))
    # Angles in that plane: the agent at 0, the target at φ_t ∈ (0, π] (e2 points to the
    # target's side); the leg crosses the wedge between them, so the shorter detour goes round
    # there, the longer one the other way (e2 flipped, the target at 2π − φ_t).
    phi_t = math.atan2(dot(w, e2), dot(w, e1))
    if phi_t < 0:
        phi_t += 2 * math.pi
    if longer:
        e2, phi_t = tuple([-x for x in e2]), 2 * math.pi - phi_t
    # Tangent angles: the agent lies on the circle's tangent at ``start``, the target on the
    # one at ``end``; tangents at angles a, b meet at angle (a+b)/2, radius R/cos((a−b)/2).
    # Tangents in between, at most _STEP apart, give the polygon; each of its edges, and both
    # legs, run along a tangent, so the route keeps R from the centre.
    start = math.acos(min(1.0, radius / du)) if du > radius else 0.0
    end = phi_t - (math.acos(min(1.0, radius / dw)) if dw > radius else 0.0)
    count = max(1, math.ceil(abs(end - start) / _STEP))
    step = (end - start) / count
    reach = radius / math.cos(step / 2.0)
    angles = [start + step * (i + 0.5) for i in range(count)]
    return [
        add(centre, scale(reach, add(scale(math.cos(a), e1), scale(math.sin(a), e2))))
        for a in angles
    ]


def _perpendicular(v: Vector) -> Vector:
    """A unit vector perpendicular to ``v`` (left of it in the plane); in 3-D v × the axis
    along which v is smallest (numpy's cross product, term for term)."""
    if len(v) == 2:
        out: Vector = (-v[1], v[0])
    else:
        k = min(range(3), key=lambda i: abs(v[i]))
        a = (1.0 if k == 0 else 0.0, 1.0 if k == 1 else 0.0, 1.0 if k == 2 else 0.0)
        out = (v[1] * a[2] - v[2] * a[1], v[2] * a[0] - v[0] * a[2], v[0] * a[1] - v[1] * a[0])
    return divide(out, norm(out))
