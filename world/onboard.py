"""Each robot's own safety layer, with no referee (docs/safety.md, "Without a referee").

In realtime an agent's command reaches its robot late, computed from positions that are older
still. The robot's layer filters it again at every tick of the robot's own clock, knowing only
what that robot knows: its own position now, the obstacles and people its own sensor sees now
(relative to itself), and every other robot's position as last heard on the robots' radio,
with its age. It never uses another robot's position *now*.

Two robots keep apart through **cells from a common snapshot**. Time is cut into epochs of
``epoch`` ticks; at the start t_E of each, every robot broadcasts its position. For robots i
and q the plane P_E is the bisector of their positions at t_E: both compute it from the same two
numbers, so their cells are exactly complementary, as in lockstep. Robot i, at t_E:

- **far**: if q's position as last heard (at tick m, age t_E − m) is at least
  ``far + v_max·(t_E − m)·dt`` away, q cannot come within 2R of i during the epoch whatever
  either does (each moves at most v_max·epoch·dt): no row, no wait.
- **near** otherwise: until q's snapshot has reached it, i stays within its *leeway* of its own
  snapshot position, (‖s_i − ŝ_q‖ − v_max·age·dt)/2 − R (0: it stands), so that it is still R
  deep on its side of P_E, whatever P_E turns out to be; q does the same (its test cannot say
  "far" of a pair that is near at t_E, because i moved at most v_max·age since q last heard
  it). Once i has the snapshot (every broadcast of the epoch carries it) its steps must end at
  least τ = min(R, D_E/2) deep on its side of P_E (nothing when D_E ≥ ``far``).

Both depths start at ≥ τ and never fall below τ, so the two robots stay 2τ apart through the
epoch — for *any* delays and losses: a lost snapshot only keeps a robot in its leeway. The
delay bound matters for how long, not for safety. The proof is in docs/safety.md. Obstacles and
people keep the filter's rows from the robot's fresh relative sensing.

Positions here are what the robots believe: the theorem holds for estimates that move exactly
as the robots do (odometry; in the simulation exact), with the separation widened by twice the
estimate's error bound by the caller.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from shoal.bus.messages import Sensing
from shoal.bus.types import ControlParams, LimitSide, Vector
from shoal.geometry.safety import Row, SafetyFilter
from shoal.geometry.vectors import FloatArray

HEARD_WITHIN = 256  # ticks: an older last-heard position counts as never heard (near)
_MASK = (1 << 64) - 1
_UNIT = 1.0 / (1 << 53)


def _mix(x: int) -> int:
    """SplitMix64's finaliser: a well-spread 64-bit word from ``x``, the same on every machine
    (the link's draws for a (seed, sender, receiver, tick), n² of them per epoch)."""
    x = (x + 0x9E3779B97F4A7C15) & _MASK
    x = ((x ^ (x >> 30)) * 0xBF58476D1CE4E5B9) & _MASK
    x = ((x ^ (x >> 27)) * 0x94D049BB133111EB) & _MASK
    return x ^ (x >> 31)


@dataclass(frozen=True, slots=True)
class Link:
    """The robots' own radio between their layers: each broadcast is late by ``delay`` ±
    ``jitter`` ticks (uniform), or lost with probability ``drop_rate``, drawn from
    (``seed``, sender, receiver, tick) so that a run's losses do not depend on the machine."""

    delay: float = 0.0
    jitter: float = 0.0
    drop_rate: float = 0.0
    seed: int = 0

    def __post_init__(self) -> None:
        if not 0.0 <= self.jitter <= self.delay or not 0.0 <= self.drop_rate < 1.0:
            raise ValueError(
                f"link: need 0 ≤ jitter ≤ delay and 0 ≤ drop rate < 1, got delay {self.delay}, "
                f"jitter {self.jitter}, drop rate {self.drop_rate}"
            )

    @property
    def perfect(self) -> bool:
        return self.delay == 0.0 and self.drop_rate == 0.0

    def arrival(self, sender: int, receiver: int, tick: int) -> int | None:
        """The first tick at which ``receiver`` knows ``sender``'s position of ``tick``, or
        None if that broadcast is lost."""
        if self.perfect:
            return tick
        word = _mix(_mix(_mix(_mix(self.seed) ^ sender) ^ receiver) ^ tick)
        if self.drop_rate > 0.0 and (word >> 11) * _UNIT < self.drop_rate:
            return None
        spread = (_mix(word) >> 11) * _UNIT * 2.0 - 1.0  # uniform in [−1, 1)
        return tick + math.ceil(self.delay + self.jitter * spread)


def plane_row(
    now: Vector, own: Vector, other: Vector, half_separation: float, *, lower: bool
) -> Row:
    """The row that keeps a step ending ``min(R, D/2)`` deep on this robot's side of the
    bisector of ``own`` and ``other`` (both robots' positions at the snapshot, D apart),
    for a robot at ``now``: g·u·dt ≥ min(τ − g·(now − mid), 0). The robot is never deeper than
    τ but for rounding (its depth at the snapshot is D/2 ≥ τ, computed another way) and the
    solver's tolerance, which the min turns into "no deeper than now", as in lockstep."""
    diff = [a - b for a, b in zip(own, other, strict=True)]
    dist = math.sqrt(sum(x * x for x in diff))
    target = min(half_separation, dist / 2.0)
    if dist == 0.0:  # a state the layers never lead to: any unit normal keeps the proof's form
        diff, dist = [1.0 if lower else -1.0] + [0.0] * (len(own) - 1), 1.0
    normal: Vector = tuple(x / dist for x in diff)
    mid = [(a + b) / 2.0 for a, b in zip(own, other, strict=True)]
    depth = sum(g * (p - c) for g, p, c in zip(normal, now, mid, strict=True))
    return Row(normal, min(target - depth, 0.0))


@dataclass
class Held:
    """What one tick of the layers did: ``velocities`` (n, dim) the robots hold, ``changed``
    how many commands a layer changed (held ones included), ``standing`` how many robots stood
    still waiting for a neighbour's snapshot (their leeway was 0)."""

    velocities: FloatArray
    changed: int
    standing: int


@dataclass(slots=True)
class Pair:
    """What robot i knows of a near robot q in the current epoch: the first tick at which q's
    snapshot has reached it (None: not in this epoch), and ``leeway`` (m), how far i may move
    from its own snapshot position before it has it."""

    arrival: int | None
    leeway: float


class OnboardLayers:
    """Every robot's layer, as the world simulates them: each sees only its own row of the
    positions, its own sensing, and the others' positions as its :class:`Link` delivered them.

    ``far`` (m): the distance at a snapshot beyond which a pair needs no cell for an epoch,
    2R + 2·v_max·epoch·dt (:meth:`far_for`). Every broadcast carries the sender's snapshot of
    the epoch as well as its position now, so a snapshot is missing only while every broadcast
    since it is late or lost.
    """

    def __init__(
        self,
        params: ControlParams,
        dt: float,
        epoch: int,
        link: Link,
        n: int,
        limits: Sequence[tuple[LimitSide, ...]] = (),
    ) -> None:
        if epoch < 1:
            raise ValueError(f"epoch: need at least 1 tick, got {epoch}")
        # Each robot's filter, its own sensing's agents left out: its cells stand for them.
        self.filters = [
            SafetyFilter.of(params, i + 1, dt, limits[i] if limits else (), agents=False)
            for i in range(n)
        ]
        self.params = params
        self.dt = dt
        self.epoch = epoch
        self.link = link
        self.half = params.separation / 2.0
        self.far = self.far_for(params, dt, epoch)
        self.history: dict[int, list[Vector]] = {}  # tick → every robot's position then
        self.snapshot: list[Vector] = []
        self.start = 0
        self.near: list[dict[int, Pair]] = []  # per robot: its near robots this epoch

    @staticmethod
    def far_for(params: ControlParams, dt: float, epoch: int) -> float:
        return params.separation + 2.0 * params.speed_limit * epoch * dt

    def _heard(self, q: int, i: int, k: int) -> tuple[int, Vector] | None:
        """(tick, position) of robot q as robot i last heard it by tick k; None if never."""
        for m in range(k, max(k - HEARD_WITHIN, -1), -1):
            seen = self.history.get(m)
            if seen is None:
                return None
            at = self.link.arrival(q, i, m)
            if at is not None and at <= k:
                return m, seen[q]
        return None

    def _first(self, q: int, i: int, k: int) -> int | None:
        """The first tick robot i has q's snapshot of tick k: the earliest of the epoch's
        broadcasts to arrive (each carries it); None if none arrives within the epoch."""
        times = [self.link.arrival(q, i, m) for m in range(k, k + self.epoch)]
        return min((t for t in times if t is not None), default=None)

    def _begin(self, k: int, rows: list[Vector]) -> None:
        """A new epoch at tick k: every robot's snapshot, and each robot's near neighbours."""
        self.start, self.snapshot = k, rows
        self.near = []
        for i, own in enumerate(rows):
            near: dict[int, Pair] = {}
            for q in range(len(rows)):
                heard = self._heard(q, i, k) if q != i else None
                if q != i and self.may_be_near(own, heard, k):
                    near[q] = Pair(self._first(q, i, k), self.leeway(own, heard, k))
            self.near.append(near)
        for old in [t for t in self.history if t <= k - HEARD_WITHIN]:
            del self.history[old]

    def _reach(self, heard: tuple[int, Vector], k: int) -> float:
        """m: how far a robot last heard at ``heard`` may be from there at tick k."""
        return self.params.speed_limit * self.dt * (k - heard[0])

    def may_be_near(self, own: Vector, heard: tuple[int, Vector] | None, k: int) -> bool:
        """Whether a robot at ``own`` at the snapshot tick k may be nearer than ``far`` to one
        last heard at ``heard`` (tick, position): that one moved at most v_max·dt a tick since."""
        return heard is None or math.dist(own, heard[1]) < self.far + self._reach(heard, k)

    def leeway(self, own: Vector, heard: tuple[int, Vector] | None, k: int) -> float:
        """m: how far a robot at ``own`` at the snapshot may move before it has the snapshot of
        a robot last heard at ``heard``: D_E/2 − R for the least D_E that robot allows (it is
        within its reach of where it was heard), so that it is still R deep in its cell when
        it learns the plane, and the pair 2R apart meanwhile. 0: it stands."""
        if heard is None:
            return 0.0
        least = math.dist(own, heard[1]) - self._reach(heard, k)
        return max(0.0, least / 2.0 - self.half)

    def cell(self, i: int, k: int, now: Vector) -> tuple[list[Row], float]:
        """Robot i's rows at tick k (0-based i), from the snapshots it has, and the leeway (m)
        the snapshots it has not yet leave it around its own snapshot position (inf: none)."""
        out = []
        leeway = math.inf
        own = self.snapshot[i]
        for q, pair in self.near[i].items():
            if pair.arrival is None or pair.arrival > k:
                leeway = min(leeway, pair.leeway)
                continue
            other = self.snapshot[q]
            if math.dist(own, other) < self.far:
                out.append(plane_row(now, own, other, self.half, lower=i < q))
        return out, leeway

    def act(self, k: int, sensings: Sequence[Sensing], commanded: FloatArray) -> Held:
        """Every robot's velocity for tick k: its command (``commanded``, (n, dim) m/s) through
        its own layer, which knows where its robot is from its own sensing (an estimate, with a
        scenario's position error: world.kinematics.estimated) and broadcasts that; a
        unicycle's layer meets its limits too (world/limits.py)."""
        rows = [s.position for s in sensings]
        self.history[k] = rows
        if k % self.epoch == 0 or not self.snapshot:
            self._begin(k, rows)
        out = np.zeros_like(commanded)
        changed = standing = 0
        for i, sensing in enumerate(sensings):
            cell, leeway = self.cell(i, k, rows[i])
            wanted = tuple(commanded[i].tolist())
            if leeway <= 0.0:
                standing += 1
                changed += any(wanted)
                continue
            result = self.filters[i](wanted, sensing, extra=cell)
            velocity = result.velocity
            if leeway < math.inf:
                velocity = within(velocity, rows[i], self.snapshot[i], leeway, self.dt)
            out[i] = velocity
            changed += result.active or velocity is not result.velocity
        return Held(out, changed, standing)


def within(velocity: Vector, now: Vector, centre: Vector, radius: float, dt: float) -> Vector:
    """``velocity`` shortened, if it must be, so that a step of ``dt`` from ``now`` (inside the
    ball of ``radius`` about ``centre``) ends inside it: the largest t ≤ 1 with
    ‖now + t·velocity·dt − centre‖ ≤ radius. Every row a step meets with a bound ≤ 0, its
    shortening meets too (0 and the step are both feasible)."""
    step = [v * dt for v in velocity]
    off = [a - c for a, c in zip(now, centre, strict=True)]
    a = sum(x * x for x in step)
    b = sum(x * y for x, y in zip(off, step, strict=True))
    c = sum(x * x for x in off) - radius * radius
    if a == 0.0 or a + 2.0 * b + c <= 0.0:
        return velocity
    t = max(0.0, (-b + math.sqrt(max(b * b - a * c, 0.0))) / a)
    return tuple(v * min(t, 1.0) for v in velocity)


def epoch_ticks(seconds: float, dt: float) -> int:
    """Ticks between the robots' snapshots for an epoch of ``seconds`` of simulated time (at
    least 2: a snapshot must be able to arrive within its epoch)."""
    return max(2, round(seconds / dt))
