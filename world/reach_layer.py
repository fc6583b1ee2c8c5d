"""The reach layer (``--safety-layer reach``): the referee for robots with mass (docs/safety.md,
Robots with mass).

The referee certifies each step from where a robot *is*; a robot with mass is not where it was
told to be, and does not stop when told. This layer certifies each step from what the robot can
*reach* (world/reach.py): from its last pose (however old, up to the horizon), the commands it
was sent since and its body's bounds (latency, braking, loop lag), where its step starts and how
far from there it can be — over the step and all the way to rest if it is told to stop after
it. Each robot's step is then the filter's (geometry/safety.py) from that predicted start, with
the guard widened by that margin and each pair's plane split so that both robots' margins fit.

The margin grows with the step's speed v (a faster step needs longer to shed), so each robot
first gets the fastest speed whose margin still fits (a *braking cap*): the clearance to every
guard, its share of every pair's gap, and the sensing horizon. Standing still always fits while
the bounds hold (the previous step was certified with the stop after it); where it does not (a
bound broken, a pose older than the horizon), the robot is told to stop — a command its loop
reaches within its bounds — and the summary counts it (``reach_brakes``).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from shoal.bus.messages import Sensing
from shoal.bus.types import ControlParams, SafetyLayer, Vector
from shoal.geometry.safety import SafetyFilter
from shoal.geometry.vectors import FloatArray
from shoal.world.plant import Observed
from shoal.world.reach import Bounds, Start, Track
from shoal.world.scenario import Scenario

_BISECTIONS = 40  # the braking cap to 2^-40 of the nominal's speed
# m: a pair pressed on its plane, or a robot on its guard, may sit this far inside by rounding
# (the filter's rows keep "no deeper than now" there); standing still still fits.
_ROUNDING = 1e-9
# A command follows its nominal by at most this fraction of the robot's braking over a tick: the
# envelope decays at the braking itself, so a command that changes at half of it leaves the
# envelope shrinking while it follows a turning nominal (at the whole braking it never did).
SHAPING = 0.5
_SAME_WAY = 0.999  # cos of the angle within which a slower command goes the same way


@dataclass(frozen=True, slots=True)
class Room:
    """What a robot's step has room for this tick: ``budget`` m, the least of every guard's
    clearance and its share of every pair's plane (from its predicted start); ``horizon`` m,
    what an obstacle it does not sense leaves; ``sensing``, its sensing moved to the predicted
    start, with every other robot's predicted start; ``offsets`` m, per other robot, how far
    the pair's plane lies off their midpoint towards the one that needs less margin."""

    budget: float
    horizon: float
    sensing: Sensing
    offsets: tuple[float, ...]


class Reach:
    """Every robot's step certified from what it can reach (module docstring)."""

    def __init__(
        self,
        params: ControlParams,
        dt: float,
        bounds: Sequence[Bounds],
        largest_obstacle: float,
    ) -> None:
        self.params, self.dt = params, dt
        self.n = len(bounds)
        self.bounds = tuple(bounds)
        self.filters = [SafetyFilter.of(params, i + 1, dt) for i in range(self.n)]
        self.tracks: list[Track] | None = None  # made at the first tick, when dim is known
        self.largest_obstacle = largest_obstacle  # m: r_max, for the sensing horizon
        self.brakes = 0  # robot-ticks told to stop: a bound broken, or a pose too old
        self.slowed = 0  # agent-ticks whose speed the braking cap lowered
        self.largest_margin = 0.0  # m: the most any certified step needed

    def act(
        self,
        k: int,
        sensings: Sequence[Sensing],
        commanded: FloatArray,
        seen: Observed | None = None,
    ) -> FloatArray:
        n, dim = commanded.shape
        if self.tracks is None:
            self.tracks = [Track(b, self.dt, dim) for b in self.bounds]
        tracks = self.tracks
        ages = seen.ages if seen is not None and seen.ages is not None else np.zeros(n)
        stale = seen.stale if seen is not None else frozenset()
        starts: list[Start | None] = []
        measured = seen.velocities if seen is not None else None
        for i in range(n):  # from what each robot knows of itself: its sensing's position
            velocity = None if measured is None else tuple(measured[i].tolist())
            start = tracks[i].start(k, sensings[i].position, float(ages[i]), velocity)
            starts.append(None if (i + 1) in stale else start)
        standing = [None if s is None else tracks[i].margin(s, 0.0) for i, s in enumerate(starts)]
        out = np.zeros_like(commanded)
        for i in range(n):
            start, m0 = starts[i], standing[i]
            step = None
            if start is not None and m0 is not None:
                step = self._step(i, start, m0, sensings[i], commanded[i], starts, standing)
            if step is None:
                step = (0.0,) * dim  # beyond its bounds: told to stop, which it reaches
                self.brakes += 1
            tracks[i].record(k, step)
            out[i] = step
        return out

    def _room(
        self,
        i: int,
        start: Start,
        m0: float,
        sensing: Sensing,
        starts: Sequence[Start | None],
        standing: Sequence[float | None],
    ) -> Room | None:
        """Robot ``i``'s room this tick (:class:`Room`); None when another robot has no start
        (nobody knows where it goes)."""
        p = self.params
        rho, half, at = p.safety_margin, p.separation / 2.0, start.position
        clearance = math.inf  # m: to the nearest guard, from the predicted start
        for c, r in zip(sensing.obstacle_centres, sensing.obstacle_radii, strict=True):
            clearance = min(clearance, math.dist(at, c) - r - rho)
        # Every other robot, not only those it senses: this layer is the world's, which knows
        # where each is (the rows of those farther than a step and both margins are dropped).
        ids: list[int] = []
        others: list[Vector] = []
        offsets: list[float] = []
        gap = math.inf
        for j, (other, mq) in enumerate(zip(starts, standing, strict=True), start=1):
            if j == i + 1:
                continue
            if other is None or mq is None:
                return None
            slack = math.dist(at, other.position) - 2.0 * half - m0 - mq
            gap = min(gap, m0 + slack / 2.0)
            ids.append(j)
            others.append(other.position)
            offsets.append((m0 - mq) / 2.0)
        moved = dataclasses.replace(
            sensing, position=at, agent_ids=tuple(ids), agent_positions=tuple(others)
        )
        horizon = p.sensing_radius - self.largest_obstacle - rho - start.drift
        return Room(min(clearance, gap), horizon, moved, tuple(offsets))

    def _step(
        self,
        i: int,
        start: Start,
        m0: float,
        sensing: Sensing,
        nominal_row: FloatArray,
        starts: Sequence[Start | None],
        standing: Sequence[float | None],
    ) -> tuple[float, ...] | None:
        """Robot ``i``'s certified step, or None: even standing does not fit (it brakes)."""
        room = self._room(i, start, m0, sensing, starts, standing)
        if room is None:
            return None
        p, track = self.params, self.tracks[i]  # type: ignore[index]
        rho, budget, horizon, moved, offsets = (
            p.safety_margin, room.budget, room.horizon, room.sensing, room.offsets
        )  # fmt: skip
        dt = self.dt
        if not _fits(track.margin(start, 0.0), 0.0, budget, horizon, dt):
            return None
        follow = SHAPING * track.bounds.braking * dt  # m/s a command may change by in a tick
        wanted = tuple(nominal_row.tolist())
        # Slowing down on its way, at the whole braking: a leader meeting its last point stops
        # as short as the body can (at half of it, past its arrival tolerance).
        slowing = _slowing(wanted, start.before)
        nominal = _shaped(wanted, start.before, follow / SHAPING if slowing else follow)
        speed = math.hypot(*nominal)
        fastest = min(speed, p.speed_limit)
        way = tuple([x / speed for x in nominal]) if speed > 0.0 else nominal

        def ahead(v: float) -> float:  # the margin of the nominal's own direction at speed v
            return track.margin(start, v, math.dist([x * v for x in way], start.before))

        def anyway(v: float) -> float:  # the margin of any step of speed ≤ v
            return track.margin(start, v)

        def fits_margin(u: Vector, m: float) -> bool:  # the step u needs no more than m
            return track.margin(start, math.hypot(*u), math.dist(u, start.before)) <= m

        def certified(f: SafetyFilter, shifts: Sequence[float], u: Vector, m: float) -> bool:
            return not f(u, moved, shifts=shifts).active and fits_margin(u, m)

        # First the nominal's own way (a robot going on as it goes sheds only its own speed);
        # if the filter turned it further than that margin allows, any way at all.
        for margin in (ahead, anyway):
            v = _fastest(margin, fastest, budget, horizon, dt)
            m = margin(v)
            slowed = v < fastest
            base = self.filters[i]
            # The speed the margin was taken for caps the step: the filter never lengthens a
            # nominal, but with a person within reach it may flee at its speed limit.
            # Guards are kept at the margin of the nominal's speed, not only the step's: a
            # robot that came as near as its slowed step allows could then only creep along
            # the guard (any faster step needs a stop it has no room for); kept there, it can
            # slide along at that speed. Rows built "no deeper than now": standing still fits.
            f = base if m == 0.0 and not slowed else dataclasses.replace(
                base, margin=rho + max(m, margin(fastest)), speed_limit=v
            )  # fmt: skip
            shifts = [m - offset for offset in offsets] if m != 0.0 or any(offsets) else ()
            u = f(nominal, moved, shifts=shifts).velocity
            if margin is anyway or fits_margin(u, m):
                break
            # The filter turned it: the same step, shorter, may still be within the margin (it
            # meets the rows wherever they hold 0; the filter leaving it unchanged says so).
            shorter = next((c for c in _shortened(u) if certified(f, shifts, c, m)), None)
            if shorter is not None:
                u = shorter
                break
        self.slowed += slowed
        self.largest_margin = max(self.largest_margin, m)
        # As smooth as it may be: the step changed by at most the robot's braking over a tick
        # where that step is feasible too (the filter leaves it unchanged: every row met, within
        # the cap) and needs no more margin. A projection that turns the command about at every
        # tick otherwise piles jump upon jump into the envelope, and the margins grow with it.
        smooth = _shaped(u, start.before, follow)
        if smooth != u and certified(f, shifts, smooth, m):
            return smooth
        return u

    def report(self) -> dict[str, Any]:
        return {
            "actuator_corrections": None,
            "safety_layer": str(SafetyLayer.REACH),
            "layer_standing": None,
            "referee_would_correct": None,
            "referee_largest_change": None,
            "reach_brakes": self.brakes,
            "reach_slowed": self.slowed,
            "reach_largest_margin": self.largest_margin,
        }


def reach_inputs(scenario: Scenario, dynamics: str | None) -> tuple[tuple[Bounds, ...], float]:
    """The reach layer's inputs for ``scenario``: each robot's bounds (its ``dynamics:``
    section, the preset replaced by ``dynamics`` if given; without either, robots that move
    as commanded) and the largest standing obstacle's radius, m."""
    radii = scenario.obstacle_radii
    largest = float(radii.max()) if len(radii) else 0.0
    if scenario.dynamics is None and dynamics is None:
        return (Bounds(),) * scenario.n, largest
    return tuple(Bounds.of(d) for d in scenario.robot_dynamics(dynamics)), largest


def _fits(m: float, v: float, budget: float, horizon: float, dt: float) -> bool:
    """Whether a step of speed ``v`` needing margin ``m`` fits: its margin and the step within
    the ``budget`` (every guard's clearance, every pair's share) and the sensing ``horizon`` (an
    obstacle not sensed). Standing needs only its margin within the budget. The step's length
    leaves it room to move towards what the budget is measured from (a margin that took the
    whole budget would pin it there); a robot that moves as commanded needs no margin (m = 0
    for every v), and then its rows alone keep it, as the referee's do."""
    room = v * dt if m > 0.0 else 0.0
    return m + room <= budget + _ROUNDING and m + v * dt <= horizon


def _fastest(
    margin: Callable[[float], float], fastest: float, budget: float, horizon: float, dt: float
) -> float:
    """The fastest speed up to ``fastest`` whose ``margin`` fits (standing, 0, does): the
    nominal's own speed when it fits, else found by bisection (which keeps a speed that fits;
    a margin that is not monotone in v may leave a faster one unfound)."""
    if _fits(margin(fastest), fastest, budget, horizon, dt):
        return fastest
    lo, hi = 0.0, fastest
    for _ in range(_BISECTIONS):
        mid = (lo + hi) / 2.0
        if _fits(margin(mid), mid, budget, horizon, dt):
            lo = mid
        else:
            hi = mid
    return lo


def _shaped(nominal: Vector, before: Vector, most: float) -> Vector:
    """``nominal`` changed from the command in force ``before`` by at most ``most`` m/s (the
    robot's braking over a tick): a robot with mass cannot follow a larger change anyway, and
    asking for it only widens the envelope every certified step has to make room for (a sign
    law's nominal turns about at every tick). Unchanged when the change is within it (always for
    a robot without an acceleration limit)."""
    change = math.dist(nominal, before)
    if change <= most:
        return nominal
    k = most / change
    return tuple([b + (x - b) * k for x, b in zip(nominal, before, strict=True)])


def _slowing(nominal: Vector, before: Vector) -> bool:
    """Whether ``nominal`` only slows the command in force ``before`` down along its own way
    (the same direction within 2.6°, slower)."""
    speed, was = math.hypot(*nominal), math.hypot(*before)
    if not speed < was:
        return False
    return speed == 0.0 or sum(a * b for a, b in zip(nominal, before, strict=True)) >= (
        _SAME_WAY * speed * was
    )


def _shortened(u: Vector) -> list[Vector]:
    """``u`` scaled by 0.9, 0.8, … 0.1: the same way, slower."""
    return [tuple([x * (k / 10.0) for x in u]) for k in range(9, 0, -1)]
