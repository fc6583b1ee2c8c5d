"""The leader's detour (relaxing Assumption 4, as the paper suggests): with the safety filter a
leader whose waypoint path runs into an obstacle's guard circle re-plans around it and resumes
its route; the followers know nothing of it, they follow the leader as always.

The leader then follows its route by position rather than by the clock: each tick it heads for
the next waypoint at the path's speed (the last step shortened to land on it), so a leader held
back by its filter, or sent round an obstacle, still visits every waypoint, in order. Points and
positions are (dim,) arrays in metres; speeds m/s; dt s.

A detour around obstacle j is a polygon circumscribing the circle of radius R' = r_j + ρ +
``clearance`` on the side of the leg away from the centre: the leg to its first vertex and from
its last vertex leave along tangents, and each edge touches the circle of radius R', so the whole
detour keeps R' from the centre (in 3-D the polygon lies in the plane of the leg and the centre).
"""

from __future__ import annotations

import math

import numpy as np

from shoal.bus.geometry import FloatArray, dot, norm, segment_distance

_STEP = math.radians(30.0)  # the polygon's largest turn per vertex
_REACHED = 1e-9  # m: a waypoint this close counts as visited


def lead(
    position: FloatArray, route: tuple[FloatArray, ...], speed: float, dt: float
) -> tuple[FloatArray, tuple[FloatArray, ...]]:
    """The leader's velocity towards the next waypoint of ``route``, and the route left.

    Waypoints already reached are dropped first; with none left the leader stands still.
    """
    while route and norm(route[0] - position) <= _REACHED:
        route = route[1:]
    if not route:
        return np.zeros_like(position), route
    to_next = route[0] - position
    dist = norm(to_next)
    return to_next * (min(speed * dt, dist) / (dist * dt)), route


def detour(
    position: FloatArray,
    route: tuple[FloatArray, ...],
    centres: FloatArray,
    radii: FloatArray,
    *,
    guard: float,
    clearance: float,
) -> tuple[FloatArray, ...]:
    """``route`` with a detour in front when its next leg passes within r_j + ``guard`` +
    ``clearance``/2 of a sensed obstacle, else as it is. ``guard`` is ρ; the detour keeps
    r_j + ρ + ``clearance`` from the centre of the nearest such obstacle along the leg, round
    its shorter side unless that side's polygon crosses another sensed obstacle, then round the
    longer side, and if both are blocked, round one circle that encloses the obstacles in the
    way. A waypoint inside the circle cannot be gone round: the route is left as it is (the
    filter stops the leader at the guard)."""
    if not route or centres.shape[0] == 0:
        return route
    circles = [(centres[k], float(radii[k])) for k in range(centres.shape[0])]
    target = route[0]
    hit = _first_in_way(position, target, circles, guard, clearance)
    for _ in range(len(circles)):
        if hit is None:
            return route
        centre, radius = hit
        keep = radius + guard + clearance
        if norm(target - centre) <= keep:
            return route  # the waypoint itself is in the way: no detour reaches it
        for longer in (False, True):
            polygon = _around(position, target, centre, keep, longer=longer)
            legs = list(zip([position, *polygon], [*polygon, target], strict=True))
            if not any(_blocks(a, b, c, r, guard, clearance) for a, b in legs for c, r in circles):
                return (*polygon, *route)
        hit = _enclosing([hit, *(c for c in circles if _near_polygon(c, polygon, hit))])
    return route


def _first_in_way(
    position: FloatArray,
    target: FloatArray,
    circles: list[tuple[FloatArray, float]],
    guard: float,
    clearance: float,
) -> tuple[FloatArray, float] | None:
    """The obstacle nearest along the leg among those it passes too close to."""
    hits = [
        (dot(c - position, target - position), i)
        for i, (c, r) in enumerate(circles)
        if _blocks(position, target, c, r, guard, clearance)
    ]
    return circles[min(hits)[1]] if hits else None


def _blocks(
    a: FloatArray, b: FloatArray, centre: FloatArray, radius: float, guard: float, clearance: float
) -> bool:
    return segment_distance(centre, a, b) < radius + guard + clearance / 2.0


def _near_polygon(
    circle: tuple[FloatArray, float],
    polygon: list[FloatArray],
    around: tuple[FloatArray, float],
) -> bool:
    """``circle`` is another obstacle than ``around`` and within the reach of its detour."""
    centre, radius = circle
    if centre is around[0]:
        return False
    reach = max(norm(v - around[0]) for v in polygon)
    return norm(centre - around[0]) - radius < reach


def _enclosing(circles: list[tuple[FloatArray, float]]) -> tuple[FloatArray, float]:
    """A circle (centre, radius) enclosing every one of ``circles``: about their centroid."""
    centre = np.mean([c for c, _ in circles], axis=0)
    radius = max(norm(c - centre) + r for c, r in circles)
    return np.asarray(centre, dtype=np.float64), radius


def _around(
    position: FloatArray, target: FloatArray, centre: FloatArray, radius: float, *, longer: bool
) -> list[FloatArray]:
    """The vertices of the polygon that takes a leg from ``position`` to ``target`` round the
    circle (``centre``, ``radius``): the shorter way, or with ``longer`` the other."""
    u = position - centre
    w = target - centre
    du, dw = norm(u), norm(w)
    e1 = u / du
    leg = target - position
    side = w - dot(w, e1) * e1  # the plane of the leg and the centre: e1, e2
    if norm(side) < 1e-12:  # the target straight behind the centre
        side = _perpendicular(leg if norm(leg) > 0 else e1)
    e2 = side / norm(side)
    # Angles in that plane: the agent at 0, the target at φ_t ∈ (0, π] (e2 points to the
    # target's side); the leg crosses the wedge between them, so the shorter detour goes round
    # there, the longer one the other way (e2 flipped, the target at 2π − φ_t).
    phi_t = math.atan2(dot(w, e2), dot(w, e1))
    if phi_t < 0:
        phi_t += 2 * math.pi
    if longer:
        e2, phi_t = -e2, 2 * math.pi - phi_t
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
    return [centre + reach * (math.cos(a) * e1 + math.sin(a) * e2) for a in angles]


def _perpendicular(v: FloatArray) -> FloatArray:
    """A unit vector perpendicular to ``v`` (left of it in the plane)."""
    if v.shape[0] == 2:
        out = np.array([-v[1], v[0]])
    else:
        axis = np.zeros(3)
        axis[int(np.argmin(np.abs(v)))] = 1.0
        out = np.cross(v, axis)
    return np.asarray(out / norm(out), dtype=np.float64)
