"""The safety filter (docs/safety.md): the velocity nearest the nominal that keeps every step safe.

    v = argmin_u ‖u − v̂‖²   subject to   g_r · u · dt ≥ h_r   for every row r

One row per sensed obstacle (stay outside its guard circle r_j + ρ over the whole step) and one
per sensed agent (a buffered Voronoi cell: stay R = separation / 2 on your own side of the
bisector). Every h_r ≤ 0, so u = 0 is feasible for an agent that is currently safe and the
problem always has a solution. A moving obstacle's row also gives way to the distance it may
walk in the step, u_max·dt (:func:`mover_row`); its h can be > 0, u = 0 is then no longer
feasible, and where no velocity within the speed limit meets every row (a person corners the
agent) the filter keeps *passive* safety: the agent moves straight away from whoever presses
it, or stands, and never towards them (:func:`evade`, docs/people.md). With 2 or 3 unknowns
it is solved exactly by enumerating active sets of at most ``dim`` rows: no solver, no
iteration, the same bits in every process.

It lives in geometry/, which the agents and the world share, because two processes run it: the
agent filters its own command (the theorem's setting), and the world applies the very same
filter in its safety layer with fresh positions before the plant moves the agents, standing in
for a robot's onboard safety layer (in lockstep the command is already feasible and comes back
unchanged, bit for bit).

All arithmetic is on plain floats: the vectors have 2 or 3 coordinates, where a numpy call costs
more than the work. Vectors are tuples in metres (positions) or m/s (velocities); dt in s.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Final

from shoal.bus.messages import Mover, Sensing, picklable
from shoal.bus.types import ControlParams, LimitSide, Vector
from shoal.geometry.vectors import right_of, vdot

# m: a row counts as met when g·u·dt ≥ h − TOLERANCE. Rounding of a 3×3 solve is ~1e-16 m; this
# only keeps an exactly-on-the-boundary solution from failing its own check.
TOLERANCE = 1e-12
# A speed this close above the limit is not capped again: the world re-applies the cap to a
# command the agent already capped and filtered, whose norm rounding may have moved by an ulp.
_CAP_SLACK = 1.0 + 1e-12
# The right-hand rule turns the nominal only when the projection keeps less than this fraction
# of its speed: the agent is (nearly) stopped against a row, not sliding along one.
SIDESTEP_BELOW = 0.25
# A multiplier this far below zero still counts as ≥ 0 (same reason).
_LAMBDA_TOLERANCE = 1e-12


@dataclass(init=False, slots=True, unsafe_hash=True)
class Row:
    """One half-space g · u · dt ≥ h: ``normal`` g a unit (dim,) vector, ``bound`` h, m (≤ 0
    except for a moving obstacle's row); ``obstacle``: the row of an obstacle (else of another
    agent); ``moving``: of a moving obstacle."""

    normal: Final[Vector]
    bound: Final[float]
    obstacle: Final[bool]
    moving: Final[bool]

    def __init__(
        self, normal: Vector, bound: float, obstacle: bool = False, moving: bool = False
    ) -> None:
        self.normal = normal
        self.bound = bound
        self.obstacle = obstacle
        self.moving = moving


@dataclass(init=False, slots=True, unsafe_hash=True)
class Filtered:
    """The filter's answer: the velocity to hold (m/s), and whether it differs from the nominal
    (``active``). ``fallback`` is True when no active set passed its checks and the agent is
    stopped (u = 0, feasible for a safe agent); it is counted, never expected. ``cornered``:
    no velocity within the speed limit met a moving obstacle's row, and the agent keeps
    passive safety instead (:func:`evade`)."""

    velocity: Final[Vector]
    active: Final[bool]
    fallback: Final[bool]
    cornered: Final[bool]

    def __init__(
        self, velocity: Vector, active: bool, fallback: bool = False, cornered: bool = False
    ) -> None:
        self.velocity = velocity
        self.active = active
        self.fallback = fallback
        self.cornered = cornered


picklable(Row, Filtered)


def _unit_away(own: Vector, other: Vector, axis_sign: float) -> tuple[Vector, float]:
    """(unit vector from ``other`` to ``own``, their distance). For coincident points (a state
    the filter never leads to) the x axis, signed so that the two ends of a pair get opposite
    normals."""
    diff = tuple([a - b for a, b in zip(own, other)])
    dist = math.sqrt(vdot(diff, diff))
    if dist == 0.0:
        return (axis_sign, *([0.0] * (len(own) - 1))), 0.0
    return tuple([x / dist for x in diff]), dist


def obstacle_row(position: Vector, centre: Vector, radius: float, margin: float) -> Row:
    """The row that keeps the step outside the guard circle ``radius`` + ``margin`` (m).

    D = ‖s − c‖, g = (s − c)/D, h = min(r + ρ, D) − D: the half-space g·(y − c) ≥ r + ρ is
    tangent to the guard circle at the point nearest the agent, so it lies wholly outside it.
    """
    normal, dist = _unit_away(position, centre, 1.0)
    return Row(normal, min(radius + margin, dist) - dist, obstacle=True)


def agent_row(position: Vector, other: Vector, half_separation: float, *, lower: bool) -> Row:
    """The row that keeps the step R = ``half_separation`` (m) on this agent's side of the
    bisector with ``other``: g = (s_i − s_q)/D, h = min(R, D/2) − D/2. The other agent's row has
    exactly the opposite normal, so the two add up to ‖y_i − y_q‖ ≥ 2R. ``lower``: this agent
    has the smaller id (it only matters for coincident positions)."""
    normal, dist = _unit_away(position, other, 1.0 if lower else -1.0)
    half = dist / 2.0
    return Row(normal, min(half_separation, half) - half)


def mover_row(position: Vector, mover: Mover, margin: float, dt: float) -> Row:
    """The row of a moving obstacle: g·u·dt ≥ min(r + ρ, D) − D + u_max·dt.

    Whichever way the obstacle moves at up to u_max over the step, g·(y − c) falls by at most
    u_max·dt: an agent that starts outside the guard circle r + ρ stays outside it all step
    (the same affine argument as :func:`obstacle_row`'s). One already inside (a person stepped
    into the guard) must at least not let the gap shrink. Its bound is > 0 within u_max·dt of
    the guard: the agent has to move away, and standing still is not enough."""
    normal, dist = _unit_away(position, mover.centre, 1.0)
    bound = min(mover.radius + margin, dist) - dist + mover.speed_cap * dt
    return Row(normal, bound, obstacle=True, moving=True)


def rows_for(
    sensing: Sensing,
    agent_id: int,
    *,
    margin: float,
    half_separation: float,
    reach: float = math.inf,
    dt: float = 0.0,
    shifts: Sequence[float] = (),
) -> list[Row]:
    """The rows of an agent from its sensing: its obstacles, then its sensed agents.

    ``reach`` (m): only rows whose boundary is nearer than this are built, i.e. obstacles whose
    guard circle and agents whose cell edge are within ``reach`` of the agent; with reach =
    ‖v̂‖·dt the others cannot be active (see :func:`project`), so skipping them is exact.
    Moving obstacles' rows (``dt`` s steps) come last; one whose bound is > 0 is always built.
    ``shifts`` (m, one per sensed agent, if given) are added to the agents' rows' bounds: how
    much deeper than R on its side of the bisector this agent's step must end (the reach layer's
    margins for robots with mass, world/reach_layer.py).
    """
    pos = sensing.position
    dist = math.dist
    rows = [
        obstacle_row(pos, c, r, margin)
        for c, r in zip(sensing.obstacle_centres, sensing.obstacle_radii)
        if dist(pos, c) < r + margin + reach
    ]
    near = 2.0 * (half_separation + reach)
    for index, (j, q) in enumerate(zip(sensing.agent_ids, sensing.agent_positions)):
        shift = shifts[index] if shifts else 0.0
        if dist(pos, q) < near + 2.0 * shift:
            row = agent_row(pos, q, half_separation, lower=agent_id < j)
            rows.append(Row(row.normal, row.bound + shift) if shifts else row)
    for m in sensing.movers:
        if dist(pos, m.centre) < m.radius + margin + m.speed_cap * dt + reach:
            rows.append(mover_row(pos, m, margin, dt))
    return rows


def limit_rows(sides: Sequence[LimitSide], heading: float, speed: float, dt: float) -> list[Row]:
    """The rows of a unicycle's limits at ``heading`` (rad): each side n·w ≤ c of its polygon
    of point velocities in the body frame (world/limits.py) turned into the world frame,
    −R(θ)n · u · dt ≥ −c·dt. Only the sides whose edge comes nearer than ``speed`` (m/s) are
    built: a projection onto a set that holds 0 is never faster than what it projects, and
    a velocity within that speed outside the polygon leaves it through one of those edges, so
    the others cannot be active (exact, as :func:`rows_for`'s ``reach``). ``sides`` come
    nearest first."""
    out: list[Row] = []
    if not sides or sides[0][3] > speed:
        return out
    cos, sin = math.cos(heading), math.sin(heading)
    for nx, ny, c, nearest in sides:  # nearest first (world/limits.py)
        if nearest > speed:
            break
        out.append(Row((-(cos * nx - sin * ny), -(sin * nx + cos * ny)), -c * dt))
    return out


def cap_to_limits(velocity: Vector, sides: Sequence[LimitSide], heading: float) -> Vector:
    """``velocity`` scaled down onto a unicycle's polygon of point velocities (its body frame,
    at ``heading``, rad) if it is outside it: the speed limit in its direction, as
    :func:`cap_speed` for a disc; unchanged if inside."""
    speed = math.hypot(velocity[0], velocity[1])
    if not sides or sides[0][3] > speed:
        return velocity  # within every edge's reach: inside (see limit_rows)
    cos, sin = math.cos(heading), math.sin(heading)
    wx = cos * velocity[0] + sin * velocity[1]
    wy = -sin * velocity[0] + cos * velocity[1]
    k = 1.0
    for nx, ny, c, nearest in sides:  # nearest first: the ray leaves through an edge nearer
        if nearest > speed:
            break
        rate = nx * wx + ny * wy
        if rate > c * _CAP_SLACK:  # on the edge up to rounding is inside, as in cap_speed
            k = min(k, c / rate)
    if k == 1.0:
        return velocity
    return (velocity[0] * k, velocity[1] * k)


def satisfies(velocity: Sequence[float], rows: Sequence[Row], dt: float) -> bool:
    """Every row met by ``velocity`` held for ``dt`` s, within :data:`TOLERANCE` m."""
    return all(vdot(r.normal, velocity) * dt >= r.bound - TOLERANCE for r in rows)


def cap_speed(velocity: Vector, limit: float) -> Vector:
    """``velocity`` scaled down to the speed ``limit`` (m/s) if it is faster; unchanged if not."""
    speed = math.hypot(*velocity)
    if speed <= limit * _CAP_SLACK:
        return velocity
    k = limit / speed
    return tuple([x * k for x in velocity])


def project(
    nominal: Vector, rows: Sequence[Row], dt: float, *, radius: float | None = None
) -> Filtered:
    """The feasible velocity nearest ``nominal`` (m/s) for a step of ``dt`` s.

    A feasible nominal comes back unchanged (the same tuple). Rows that the ball of radius
    ‖v̂‖ lies inside are dropped first: the projection onto a convex set that holds 0 is never
    longer than v̂, so they cannot be active; and of the rest only those whose plane comes near
    enough to v̂ to be active (:func:`_within_reach`). Then every set of at most ``dim`` rows is
    tried as the active set (KKT: the equality-constrained minimiser, multipliers ≥ 0, every row
    met); the nearest accepted candidate wins, ties to the first in enumeration order. Where
    some bound is > 0 (0 is not feasible) the caller gives the ``radius`` (m/s) no answer may
    exceed instead; rows with a bound > 0 are never dropped.
    """
    speed2 = vdot(nominal, nominal) if radius is None else radius * radius
    # A row's boundary lies −h/dt from the origin (‖g‖ = 1); farther than ‖v̂‖: never active.
    near = [r for r in rows if (r.bound / dt) ** 2 < speed2 or r.bound >= 0.0]
    if satisfies(nominal, near, dt):
        return Filtered(nominal, active=False)
    if radius is None:
        near = _within_reach(nominal, near, dt)
    dim = len(nominal)
    best: Vector | None = None
    best_dist = math.inf
    for size in range(1, min(dim, len(near)) + 1):
        for chosen in itertools.combinations(near, size):
            candidate = _on_planes(nominal, chosen, dt)
            if candidate is None or not satisfies(candidate, near, dt):
                continue
            change = tuple([a - b for a, b in zip(candidate, nominal)])
            dist = vdot(change, change)
            if dist < best_dist:
                best, best_dist = candidate, dist
    if best is None:
        return Filtered(tuple([0.0 for _ in nominal]), active=True, fallback=True)
    return Filtered(best, active=True)


def _within_reach(nominal: Vector, rows: list[Row], dt: float) -> list[Row]:
    """The rows that can be active in the projection of ``nominal``, every bound ≤ 0 (0 is
    feasible): those whose plane comes within r of v̂, where r = (1 − t)·‖v̂‖ for the largest
    t ≤ 1 that keeps t·v̂ feasible. The answer is no farther than r from v̂ (t·v̂ is a
    candidate), so the projection onto the rows kept lies in that ball; a row dropped has its
    plane outside the ball and t·v̂ on its feasible side, so the ball, and the answer, are on
    that side too: the projection onto the rows kept is the projection onto all (and the same
    active set, the same bits). A unicycle's limits are many nearly parallel rows, of which
    this keeps the two or three by the nominal."""
    t = 1.0
    slopes = []
    for r in rows:
        if r.bound > 0.0:
            return rows  # 0 is not feasible: no candidate on the way to it
        rate = vdot(r.normal, nominal)
        slopes.append(rate)
        if rate < 0.0:
            t = min(t, r.bound / (dt * rate))
    reach2 = (1.0 - t) ** 2 * vdot(nominal, nominal) * (1.0 + 1e-9) + 1e-24
    return [r for r, rate in zip(rows, slopes) if (rate - r.bound / dt) ** 2 <= reach2]


def _on_planes(nominal: Vector, chosen: Sequence[Row], dt: float) -> Vector | None:
    """The point nearest ``nominal`` on the planes g·u = h/dt of ``chosen``: u = v̂ + Gᵀλ with
    (G Gᵀ) λ = h/dt − G v̂; None when the normals are dependent or some λ < 0 (not a KKT point)."""
    gram = [[vdot(a.normal, b.normal) for b in chosen] for a in chosen]
    rhs = [r.bound / dt - vdot(r.normal, nominal) for r in chosen]
    lam = _solve(gram, rhs)
    if lam is None or min(lam) < -_LAMBDA_TOLERANCE:
        return None
    out = list(nominal)
    for weight, r in zip(lam, chosen):
        for c in range(len(out)):
            out[c] += weight * r.normal[c]
    return tuple(out)


_SINGULAR = 1e-12  # |det| of a Gram matrix of unit normals below this: dependent rows


def _solve(a: list[list[float]], b: list[float]) -> list[float] | None:
    """Solve a 1×1, 2×2 or 3×3 symmetric system by Cramer's rule; None if (near) singular."""
    n = len(b)
    if n == 1:
        return [b[0] / a[0][0]]
    if n == 2:
        det = a[0][0] * a[1][1] - a[0][1] * a[1][0]
        if abs(det) < _SINGULAR:
            return None
        return [
            (b[0] * a[1][1] - a[0][1] * b[1]) / det,
            (a[0][0] * b[1] - b[0] * a[1][0]) / det,
        ]
    det = _det3(a)
    if abs(det) < _SINGULAR:
        return None
    out = []
    for col in range(3):
        m = [row[:] for row in a]
        for r in range(3):
            m[r][col] = b[r]
        out.append(_det3(m) / det)
    return out


def _det3(m: list[list[float]]) -> float:
    return (
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    )


def _tight(row: Row, velocity: Vector, dt: float) -> bool:
    """Whether ``velocity`` held for ``dt`` lies on ``row``'s boundary (within 1e-9 m)."""
    return abs(vdot(row.normal, velocity) * dt - row.bound) <= 1e-9


def sidestep(
    nominal: Vector, filtered: Vector, rows: Sequence[Row], dt: float, *, held: bool = False
) -> Vector | None:
    """The right-hand rule against deadlock, or None when it does not apply.

    A projection can leave an agent standing: when its nominal points straight into a row that
    holds (another agent coming head on, an obstacle with the slot behind it), the projection
    keeps only the tangential part, which is zero. Only when the projection keeps less than
    :data:`SIDESTEP_BELOW` of the nominal's speed (an agent that still slides along a row is
    left alone, whichever way it slides), for every row that is tight at ``filtered``
    and that the nominal pushes into, the pushing part is turned to the right of the direction
    towards the other agent or obstacle and added to the nominal, which is then rescaled to the
    nominal's speed. Two agents head on each step to their own right and pass each other, as
    people do; an agent behind an obstacle goes round it to the right. The caller projects the
    result again, so safety does not depend on it.

    ``held``: the agent's heading (its averaged velocity) is below that fraction of the
    nominal's speed, so it is going nowhere, whatever the projection keeps this tick; then a
    tight agent row turns the nominal too. The sign term's part across such a row flips every
    tick and survives the projection whole: a follower pressed head on against an agent
    standing between it and its slot (a leader at its goal) kept 40–100 % of its nominal's
    speed at every tick, left and right in turn, and stood there for good (13 of the 19 hard
    fields that still did not arrive). Obstacle rows are left to :func:`keep_going` then.
    """
    speed = math.sqrt(vdot(nominal, nominal))
    slow = vdot(filtered, filtered) < (SIDESTEP_BELOW * speed) ** 2
    if not (slow or held):
        return None
    push = [0.0] * len(nominal)
    for r in rows:
        if not _tight(r, filtered, dt):
            continue  # not what holds the agent back
        if r.obstacle and not slow:
            continue  # held, yet sliding along an obstacle: keep_going's case, not this one
        into = -vdot(r.normal, nominal)
        if into <= 0.0:
            continue
        right = right_of(tuple([-g for g in r.normal]))  # right of "towards it"
        for c in range(len(push)):
            push[c] += into * right[c]
    if not any(push):
        return None
    turned = [a + b for a, b in zip(nominal, push)]
    size = math.sqrt(vdot(turned, turned))
    if size == 0.0:
        return None
    return tuple([x * (speed / size) for x in turned])


def slide_right(nominal: Vector, filtered: Vector, rows: Sequence[Row], dt: float) -> Vector | None:
    """In a jam, the way out along the right-hand face of the agent's cell; None when the agent
    is not jammed or no face leads out.

    The right-hand rule (:func:`sidestep`) turns the nominal to the right of whoever holds the
    agent; in a crowd pressed together from every side (eight followers on a ring, each sent to
    the opposite side through the leader in the middle) the turned nominal is blocked
    too, every agent's projection is 0, and nobody moves again. The cell of a jammed agent is a
    cone at its position that opens away from the crowd: its faces are the bisectors with the
    agents that hold it. So when the velocity kept is still below :data:`SIDESTEP_BELOW` of the
    nominal's speed, each tight agent row's face is followed to the right of "towards that
    agent" at the nominal's speed, projected onto every row, and the direction that keeps the
    most speed wins (ties: the first row, in sensing order). Every agent of the jam turns the
    same way round, so the crowd unwinds like a roundabout instead of waiting for a gap
    (Zhou, Wang, Bandyopadhyay & Schwager 2017, buffered Voronoi cells: the right-hand rule on
    the cell's boundary). The answer is a projection onto the same rows: safety does not depend
    on it. Obstacles' rows are left to :func:`keep_going`: they do not move out of the way."""
    speed = math.sqrt(vdot(nominal, nominal))
    if speed == 0.0 or vdot(filtered, filtered) >= (SIDESTEP_BELOW * speed) ** 2:
        return None
    best: Vector | None = None
    best_size = 0.0
    for r in rows:
        if r.obstacle or not _tight(r, filtered, dt):
            continue
        right = right_of(tuple([-g for g in r.normal]))
        again = project(tuple([x * speed for x in right]), rows, dt)
        if again.fallback:
            continue
        size = vdot(again.velocity, again.velocity)
        if size > best_size * (1 + 1e-9):
            best, best_size = again.velocity, size
    return best


def keep_going(
    nominal: Vector, filtered: Vector, previous: Vector, rows: Sequence[Row], dt: float
) -> Vector | None:
    """Against an obstacle, go on the way the agent was going; None when it already does.

    The nominal of a sign-term law turns from tick to tick. Pressed against an obstacle that its
    nominal pushes into (its slot behind it), the projection keeps the nominal's part along the
    guard circle, and that part can point one way at one tick and back the next: the agent then
    shuffles on the spot for good (measured: the main cause of formations that never settled).
    So for every such tight obstacle row (other agents' rows are left to the right-hand rule:
    they move) where the tangential part of ``filtered`` points against that of ``previous``
    (the velocity the agent held last), it is turned to point along the previous one, at the
    same speed; the normal part is left as it is. Going round a convex guard circle one way,
    the agent leaves the arc from which its goal lies behind the obstacle. The caller projects
    the result again: safety does not depend on it."""
    out = list(filtered)
    changed = False
    for r in rows:
        if not r.obstacle or r.moving:
            continue
        if not _tight(r, filtered, dt) or vdot(r.normal, nominal) >= 0.0:
            continue  # not holding the agent, or the nominal does not push into it
        n = r.normal
        along = vdot(n, out)
        tangent = [x - along * g for x, g in zip(out, n)]
        before = vdot(n, previous)
        was = [x - before * g for x, g in zip(previous, n)]
        if vdot(tangent, was) >= 0.0:
            continue
        scale = math.sqrt(vdot(tangent, tangent) / vdot(was, was))
        out = [along * g + scale * w for g, w in zip(n, was)]
        changed = True
    return tuple(out) if changed else None


@dataclass(frozen=True, slots=True, kw_only=True)
class SafetyFilter:
    """One agent's safety filter, configured once per run (the Robotarium's
    ``create_si_barrier_certificate`` likewise returns a configured function): call it every
    tick with what changes every tick.

    ``agent_id``: whose filter (its rows against a neighbour at the same position need it);
    ``dt`` s; ``margin`` ρ and ``half_separation`` R, m; ``speed_limit`` v_max, m/s;
    ``limits``: a unicycle's polygon of point velocities in its body frame (world/limits.py),
    met as rows at the heading of each tick's sensing (:func:`limit_rows`), so the (v, ω) it
    holds keeps its speed, turn-rate and wheel limits (docs/safety.md, Unicycles);
    ``right_hand`` False: the bare projection (no sidestep, no keep-going); ``agents`` False:
    leave out the rows of the agents a sensing names (a robot's own layer meets its cells from
    a common snapshot instead, as ``extra`` rows: world/onboard.py)."""

    agent_id: int
    dt: float
    margin: float
    half_separation: float
    speed_limit: float
    limits: tuple[LimitSide, ...] = ()
    right_hand: bool = True
    agents: bool = True

    @staticmethod
    def of(
        params: ControlParams,
        agent_id: int,
        dt: float,
        limits: Sequence[LimitSide] = (),
        *,
        agents: bool = True,
    ) -> SafetyFilter:
        """Agent ``agent_id``'s filter with a run's margins, separation and speed limit."""
        return SafetyFilter(
            agent_id=agent_id,
            dt=dt,
            margin=params.safety_margin,
            half_separation=params.separation / 2.0,
            speed_limit=params.speed_limit,
            limits=tuple(limits),
            agents=agents,
        )

    def __call__(
        self,
        nominal: Vector,
        sensing: Sensing,
        *,
        previous: Vector | None = None,
        extra: Sequence[Row] = (),
        shifts: Sequence[float] = (),
    ) -> Filtered:
        """The whole filter for one tick: cap the nominal at the speed limit, project it onto
        the rows of ``sensing`` (and ``extra``), and where that leaves the agent pressed
        against a row, project the right-hand turn of the nominal instead (:func:`sidestep`).
        Given the agent's velocity averaged over the last ticks (``previous``), an agent
        pressed against an obstacle goes on along it the way it was going rather than back
        (:func:`keep_going`), and one going nowhere turns right of an agent in its way
        (:func:`sidestep`'s ``held``). ``active`` is True when the result differs from the
        nominal as given (the cap alone counts). The result always meets every row and is never
        faster than the capped nominal; a feasible nominal comes back unchanged."""
        return self._filter(nominal, sensing, previous, extra, sensing.heading, shifts)

    def _filter(
        self,
        nominal: Vector,
        sensing: Sensing,
        previous: Vector | None,
        extra: Sequence[Row],
        heading: float,
        shifts: Sequence[float] = (),
    ) -> Filtered:
        dt, margin, half_separation = self.dt, self.margin, self.half_separation
        speed_limit, limits, agent_id = self.speed_limit, self.limits, self.agent_id
        capped = cap_speed(nominal, speed_limit)
        if limits:
            capped = cap_to_limits(capped, limits, heading)
        speed = math.hypot(*capped)
        if not self.agents:
            sensing = dataclasses.replace(sensing, agent_ids=(), agent_positions=())
        rows = rows_for(
            sensing,
            agent_id,
            margin=margin,
            half_separation=half_separation,
            reach=speed * dt,
            dt=dt,
            shifts=shifts,
        )
        rows += extra
        if limits:
            rows += limit_rows(limits, heading, speed, dt)
        if any(r.bound > 0.0 for r in rows):  # a moving obstacle within reach of the guard
            every = rows_for(
                sensing, agent_id, margin=margin, half_separation=half_separation,
                reach=speed_limit * dt, dt=dt, shifts=shifts,
            )  # fmt: skip
            every += extra
            if limits:
                every += limit_rows(limits, heading, speed_limit * _CAP_SLACK, dt)
            out = evade(capped, every, dt, speed_limit)
            return dataclasses.replace(out, active=out.velocity != nominal)
        out = project(capped, rows, dt) if rows else Filtered(capped, active=False)
        if out.active and self.right_hand:
            held = previous is not None and vdot(previous, previous) < vdot(capped, capped) * (
                SIDESTEP_BELOW**2
            )
            turned = sidestep(capped, out.velocity, rows, dt, held=held)
            if turned is not None:
                again = project(turned, rows, dt)
                if not again.fallback:
                    out = Filtered(again.velocity, active=True)
            if previous is not None and any(previous):
                onward = keep_going(capped, out.velocity, previous, rows, dt)
                if onward is not None:
                    again = project(onward, rows, dt)
                    kept = vdot(again.velocity, again.velocity)
                    # Only if the way onward is open: blocked there (another agent, another row),
                    # going back is the agent's way out, and insisting held it for good (measured).
                    if not again.fallback and kept >= SIDESTEP_BELOW**2 * vdot(
                        out.velocity, out.velocity
                    ):
                        out = Filtered(again.velocity, active=True)
            way = slide_right(capped, out.velocity, rows, dt)
            if way is not None:
                out = Filtered(way, active=True)
        if capped is not nominal and not out.active:
            return Filtered(out.velocity, active=True)
        return out


def safe_velocity(
    nominal: Vector,
    sensing: Sensing,
    agent_id: int,
    *,
    previous: Vector | None = None,
    extra: Sequence[Row] = (),
    heading: float | None = None,
    **settings: Any,
) -> Filtered:
    """One call of a filter configured for it (tests, one-off checks): ``settings`` are
    :class:`SafetyFilter`'s; ``heading`` (rad) in place of the sensing's. A process configures
    its filter once and calls it every tick."""
    f = SafetyFilter(agent_id=agent_id, **settings)
    return f._filter(
        nominal, sensing, previous, extra, sensing.heading if heading is None else heading
    )


def _towards_limit(inner: Vector, outer: Vector, limit: float) -> Vector:
    """The point of the segment from ``inner`` (‖inner‖ ≤ limit) to ``outer`` (faster) whose
    speed is ``limit``: the larger root t of ‖inner + t(outer − inner)‖² = limit²."""
    step = tuple([b - a for a, b in zip(inner, outer)])
    a = vdot(step, step)
    b = vdot(inner, step)
    c = vdot(inner, inner) - limit * limit
    t = min(1.0, max(0.0, (-b + math.sqrt(max(b * b - a * c, 0.0))) / a))
    return tuple([x + t * d for x, d in zip(inner, step)])


def evade(nominal: Vector, rows: Sequence[Row], dt: float, speed_limit: float) -> Filtered:
    """The filter when some row's bound is > 0 (a moving obstacle near the guard), so that
    standing still is not safe: the velocity within ``speed_limit`` nearest ``nominal`` that
    meets every row, or, where none does, passive safety.

    1. The projection of the nominal onto every row, if it is within the speed limit.
    2. Else the slowest velocity that meets every row (the projection of 0); if that is within
       the limit, the point where the segment from it to the projection of the nominal crosses
       the limit (both meet every row, so every point between them does).
    3. Else the agent is cornered: no velocity it can reach keeps the guard. It then flees:
       it heads at the speed limit straight away from the moving obstacles whose rows it
       cannot meet (weighted by how far each row is from holding), projected onto the other
       rows with the moving rows relaxed to "do not come closer" (g·u ≥ 0). That problem
       holds 0, so it has an answer, and the agent never moves towards anyone pressing it:
       if contact happens, it is at rest or moving away (``cornered`` True).
    """
    limit = speed_limit * _CAP_SLACK
    near = project(nominal, rows, dt, radius=speed_limit)
    if not near.fallback and vdot(near.velocity, near.velocity) <= limit * limit:
        return near
    zero = tuple([0.0 for _ in nominal])
    slowest = project(zero, rows, dt, radius=speed_limit)
    if not slowest.fallback and vdot(slowest.velocity, slowest.velocity) <= limit * limit:
        if near.fallback:
            return Filtered(slowest.velocity, active=True)
        return Filtered(_towards_limit(slowest.velocity, near.velocity, speed_limit), active=True)
    away = [0.0] * len(nominal)
    for r in rows:
        if r.moving and r.bound > 0.0:
            for c in range(len(away)):
                away[c] += r.bound * r.normal[c]
    size = math.sqrt(vdot(away, away))
    flee = zero if size == 0.0 else tuple([x * (speed_limit / size) for x in away])
    relaxed = [Row(r.normal, min(r.bound, 0.0), r.obstacle, r.moving) for r in rows]
    out = project(flee, relaxed, dt)
    return Filtered(out.velocity, active=True, fallback=out.fallback, cornered=True)
