"""A unicycle's limits as a polygon of its point's velocities, in its body frame (pure).

Over a tick of (v, ω) held, the point l ahead of the axle moves by w·dt in the body frame
(world/unicycle.py): with x = ω·dt/2 and s = 2l/dt,

    w + (s, 0) = e^{ix}·(s·cos x + v·sinc x)

(points as complex numbers). So in polar coordinates about the pole O = (−s, 0) a point
velocity w has angle x, which fixes ω = 2x/dt, and radius r = s·cos x + v·sinc x, which grows
with v. The limits |v| ≤ v_max, |ω| ≤ ω_max and each wheel's rim speed |v ± ω·axle/2| ≤ rim are
linear in (x, v): |x| ≤ X and |v| ≤ V(x), V piecewise linear in |x|. The velocities that meet
them are therefore the points at angle |x| ≤ X about O between the two curves
C±(x) = O + e^{ix}·(s·cos x ± V(x)·sinc x): curved, so no polygon is exact.

The polygon built here lies inside them (docs/safety.md, Unicycles):

- **The turn rate**: two rays from O at angles ±X; they are exact.
- **The speed and the wheels**: each curve is cut where V bends into pieces, each piece into
  spans, and each span gets a line n·w = c with n pointing away from the origin (the chord's
  normal, or the radius's to the span's middle) and c = min(n·C(x_a), n·C(x_b)) − max(0, K)·Δx²/8,
  K ≥ n·C'' over the span. Writing C(x) = −s/2 + (s/2)·e^{2ix} + V(x)·h(x) with
  h(x) = sinc x·e^{ix} = ∫₀¹ e^{2ixt} dt, so |h'| ≤ 1 and |h''| ≤ 4/3, and V linear on the piece:
  K = max over the span of −2s·n·e^{2ix} (a cosine, exact) + 2|V'| + (4/3)·max V. Then n·C
  less its linear interpolant is ≥ −max(0, K)·Δx²/8, so the whole curve over the span is on or
  beyond the line; and every velocity that breaks the limit at such an angle lies farther along
  the same ray from O (the rays cross the line outwards: checked here), so the line keeps it
  out. At the front the curve bends away from the origin (K < 0, no shift).

The spans are a resolution, not a margin: the argument holds for any number of them. The front
gets enough chords per piece that even the unsigned bound's shift stays under
:data:`RESOLUTION` of the speed straight ahead; the back, where the set is not convex, is tried
with chords and radial normals, 1–16 per piece (:data:`BACK_CHORDS`), and the polygon whose
nearest side is farthest from 0 is kept. Where no line keeps 0 strictly inside (a slow robot
that turns fast), the turn rate is halved until one does: a stricter limit.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable

from shoal.bus.types import LimitSide

# The front's chords per piece: enough that even |C''|'s unsigned bound would shift each by at
# most this fraction of the speed straight ahead (v_max, or the wheels').
RESOLUTION = 0.002
MAX_CHORDS = 16  # per piece of the speed's envelope: bounds the rows the filter may meet
NARROWER = 12  # halvings of the turn rate tried where the band is too thin for its bend
BACK_CHORDS = (1, 2, 4, 8, 16)  # per piece, tried for the back (the best inner radius wins)


class LimitError(ValueError):
    """The limits leave the point no velocity about standing still (a zero limit)."""


def _sinc(x: float) -> float:
    return math.sin(x) / x if x != 0.0 else 1.0


def bow(bound: float, span: float) -> float:
    """m/s: how far a curve with |C''| ≤ ``bound`` over a parameter ``span`` may be from its
    chord: the largest linear-interpolation error, bound·span²/8."""
    return bound * span * span / 8.0


def limit_sides(
    lookahead: float,
    max_speed: float,
    max_turn_rate: float,
    dt: float,
    *,
    rim: float | None = None,
    half_axle: float | None = None,
) -> tuple[LimitSide, ...]:
    """The polygon of point velocities (m/s, body frame: x ahead, y to the left) whose (v, ω)
    held for ``dt`` s meets every limit: |v| ≤ ``max_speed``, |ω| ≤ ``max_turn_rate``, and, given
    ``rim`` (a wheel's rim speed limit, m/s) and ``half_axle`` (m), |v| + half_axle·|ω| ≤ rim.
    Only velocities up to l/dt are covered (the filter's speed limit never exceeds it).

    Each side is (n_x, n_y, c, nearest): the polygon is n·w ≤ c for every side, n a unit vector;
    ``nearest`` is how close the side's edge comes to standing still (m/s), which lets the filter
    leave out the sides that a velocity no faster than that cannot reach; nearest first."""
    s = 2.0 * lookahead / dt
    span = min(0.5 * max_turn_rate * dt, math.pi / 6.0)
    top = min(max_speed, 0.5 * s)
    wheels = rim is not None and half_axle is not None
    slope = 2.0 * half_axle / dt if half_axle is not None else 0.0
    if wheels and rim is not None:
        span = min(span, rim / slope)

    def limit(x: float) -> float:
        """V(x): the most |v| may be at x = ω·dt/2."""
        if wheels and rim is not None:
            return max(0.0, min(top, rim - slope * abs(x)))
        return top

    ahead = limit(0.0)
    if not (span > 0.0 and ahead > 0.0):
        raise LimitError("the limits leave the robot no way to move (a limit of 0)")
    for _ in range(NARROWER):
        best = _polygon(s, span, limit, wheels and rim is not None and rim > top,
                        (rim or 0.0) - top, slope, ahead)  # fmt: skip
        if best:
            return best
        # The band between the curves is too thin for its bend (a slow robot that turns fast:
        # a crescent): no line keeps 0 inside. A lower turn rate is a stricter limit.
        span *= 0.5
    raise LimitError("the limits leave the robot no velocity about standing still")


def _polygon(
    s: float,
    span: float,
    limit: Callable[[float], float],
    knees: bool,
    over: float,
    slope: float,
    ahead: float,
) -> tuple[LimitSide, ...]:
    """The polygon for turns up to x = ``span`` (the speed's envelope ``limit`` bends at ±
    ``over``/``slope`` where ``knees``), or () when no candidate keeps 0 strictly inside."""
    breaks = {-span, 0.0, span}
    if knees and over / slope < span:
        breaks |= {-over / slope, over / slope}
    cuts = sorted(breaks)
    pieces = [(a, b, limit(a), limit(b)) for a, b in itertools.pairwise(cuts)]
    turn = [(-math.sin(span), sign * math.cos(span), s * math.sin(span)) for sign in (1.0, -1.0)]
    front = _chain(s, pieces, 1.0, "chord", None, RESOLUTION * ahead)
    best: tuple[LimitSide, ...] = ()
    for kind in ("chord", "radius"):
        for count in BACK_CHORDS:
            lines = front + _chain(s, pieces, -1.0, kind, count, 0.0) + turn
            if any(c <= 0.0 for _, _, c in lines):
                continue
            sides = _sides(lines, s)
            if not best or min(x[3] for x in sides) > min(x[3] for x in best):
                best = sides
    return best


def _chain(
    s: float,
    pieces: list[tuple[float, float, float, float]],
    sign: float,
    kind: str,
    count: int | None,
    tolerated: float,
) -> list[tuple[float, float, float]]:
    """The lines along the curve v = ``sign``·V(x) over ``pieces`` (a, b, V(a), V(b)), V linear
    on each: ``count`` per piece, or as many as keep each line's bow under ``tolerated``;
    ``kind``: each line's normal is its chord's or the radius's to its middle."""
    lines = []
    for a, b, va, vb in pieces:
        rest = 2.0 * abs(vb - va) / (b - a) + (4.0 / 3.0) * max(va, vb)
        n = count
        if n is None:
            n = math.ceil(math.sqrt((2.0 * s + rest) * (b - a) ** 2 / (8.0 * tolerated)))
            n = max(1, min(MAX_CHORDS, n))
        for k in range(n):
            xa, xb = a + (b - a) * k / n, a + (b - a) * (k + 1) / n
            ends = (sign * (va + (vb - va) * (xa - a) / (b - a)),
                    sign * (va + (vb - va) * (xb - a) / (b - a)))  # fmt: skip
            lines.append(_line(s, xa, ends[0], xb, ends[1], sign, kind, rest))
    return lines


def _point(s: float, x: float, v: float) -> tuple[float, float]:
    """The point velocity (body frame) of (v, ω = 2x/dt) held: O + e^{ix}·(s·cos x + v·sinc x)."""
    radius = s * math.cos(x) + v * _sinc(x)
    return -s + radius * math.cos(x), radius * math.sin(x)


def _line(
    s: float, xa: float, va: float, xb: float, vb: float, sign: float, kind: str, rest: float
) -> tuple[float, float, float]:
    """A line (n_x, n_y, c) that the curve C(x) of v(x), linear from ``va`` at ``xa`` to ``vb``
    at ``xb``, stays beyond over [xa, xb]: n the chord's normal or the radius's to the middle
    (``kind``), pointing away from the origin; c = min(n·C(xa), n·C(xb)) less the bow
    K·Δx²/8, K ≥ n·C'' over the span. ``rest`` bounds |n·(2V'h' + Vh'')|."""
    ax, ay = _point(s, xa, va)
    bx, by = _point(s, xb, vb)
    if kind == "chord":
        dx, dy = bx - ax, by - ay
        size = math.hypot(dx, dy)
        nx, ny = sign * dy / size, -sign * dx / size
    else:
        mx, my = _point(s, 0.5 * (xa + xb), 0.5 * (va + vb))
        size = math.hypot(mx, my)
        nx, ny = mx / size, my / size
    for x in (xa, xb):  # the rays from O cross the line outwards (v above) or inwards (below)
        if sign * (nx * math.cos(x) + ny * math.sin(x)) <= 0.0:
            return nx, ny, -math.inf  # no bound at all: the candidate is dropped
    # n·C'' = −2s·n·e^{2ix} + n·(2V'h' + Vh''): the first term's largest over [xa, xb] exactly
    phi = math.atan2(ny, nx)
    top = max(-math.cos(2.0 * x - phi) for x in (xa, xb))
    k = math.ceil((2.0 * xa - phi - math.pi) / (2.0 * math.pi))
    if 2.0 * xa <= phi + math.pi + 2.0 * math.pi * k <= 2.0 * xb:
        top = 1.0
    bend = max(0.0, 2.0 * s * top + rest)
    return nx, ny, min(nx * ax + ny * ay, nx * bx + ny * by) - bow(bend, xb - xa)


def _sides(lines: list[tuple[float, float, float]], s: float) -> tuple[LimitSide, ...]:
    """The polygon cut by ``lines`` from a square that holds it, as its sides: each line that
    bounds it, with how near its edge comes to the origin."""
    poly = _cut(lines, 4.0 * s)
    nearest = [math.inf] * len(lines)
    for k, (p, label) in enumerate(poly):
        if label >= 0:
            q = poly[(k + 1) % len(poly)][0]
            nearest[label] = min(nearest[label], _to_segment(p, q))
    kept = [(nx, ny, c, nearest[k]) for k, (nx, ny, c) in enumerate(lines) if nearest[k] < math.inf]
    return tuple(sorted(kept, key=lambda side: side[3]))  # nearest first: the filter stops early


Polygon = list[tuple[tuple[float, float], int]]  # vertices, each with its edge's line's label


def _cut(lines: list[tuple[float, float, float]], big: float) -> Polygon:
    """The polygon n·w ≤ c for every line, cut from the square of half-side ``big``."""
    poly: Polygon = [((-big, -big), -1), ((big, -big), -1), ((big, big), -1), ((-big, big), -1)]
    for label, (nx, ny, c) in enumerate(lines):
        poly = _clip(poly, nx, ny, c, label)
    return poly


def _clip(poly: Polygon, nx: float, ny: float, c: float, label: int) -> Polygon:
    """Sutherland–Hodgman: the convex polygon ``poly`` (vertices, each with the label of the
    line its edge to the next vertex lies on) cut to n·w ≤ c; the new edge is ``label``'s."""
    out: Polygon = []
    for k, (p, edge) in enumerate(poly):
        q = poly[(k + 1) % len(poly)][0]
        fp = nx * p[0] + ny * p[1] - c
        fq = nx * q[0] + ny * q[1] - c
        if fp <= 0.0:
            out.append((p, edge))
        if (fp <= 0.0) != (fq <= 0.0):
            t = fp / (fp - fq)
            cross = (p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1]))
            out.append((cross, label if fp <= 0.0 else edge))
    return out


def _to_segment(p: tuple[float, float], q: tuple[float, float]) -> float:
    """The distance from the origin to the segment from ``p`` to ``q``."""
    dx, dy = q[0] - p[0], q[1] - p[1]
    size2 = dx * dx + dy * dy
    t = 0.0 if size2 == 0.0 else max(0.0, min(1.0, -(p[0] * dx + p[1] * dy) / size2))
    return math.hypot(p[0] + t * dx, p[1] + t * dy)


def outer(sides: tuple[LimitSide, ...]) -> float:
    """m/s: the fastest point velocity the polygon holds (its farthest vertex)."""
    lines = [(nx, ny, c) for nx, ny, c, _ in sides]
    return max(math.hypot(*p) for p, _ in _cut(lines, 1e3 * max(c for _, _, c in lines)))
