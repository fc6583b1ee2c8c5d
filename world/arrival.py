"""Arrival: whether a run got where it was going, when, and if not, why (docs/campaign.md).

**Tolerance.** A follower is in its slot when within R = separation/2 of it, m. That is the
safety filter's own length: slots at least the separation apart (what the loader demands) have
disjoint discs of radius R, so a follower within R of its slot is nearer to it than any other
agent can be. It does not grow with β.

**Chatter.** The sign term moves a follower about β·dt per tick around its slot, so followers
are judged on their error s_i − s_1 − R(θ)δ_i/σ averaged over a trailing window of
:func:`window_ticks` ticks (1 s, at least 10 ticks, an even count so that a period-2 chatter
cancels); the leader, which does not chatter, on its position.

**Arrived** at tick k: the leader within R of its goal and every follower's window-averaged
error within R, at k and at every tick after it to the end of the run; the arrival time is the
first such k·dt. The leader's goal is its last waypoint; a sinusoid never ends, so there the
goal is where the path is at that tick (the formation arrives when it is on the moving path).

**Progress.** An agent off its goal (distance d > R) makes no progress at tick k when, in the
stretch of ticks it has been off, it is not closer by more than R than its best up to
P = :data:`NO_PROGRESS_TIME` s before: d(k) > min d(stretch start .. k − P) − R. An agent is
**still** when its window-averaged position moved slower than STALL_SPEED over the last window,
else **moving**. For the leader d is the route left: the distance to the next waypoint it has
not yet come within R (+ one step) of, plus the legs after it (on a sinusoid: its distance to
where the path is).

**Why not.** A run that has not arrived at its last tick is named by the state at that tick:
- "leader trapped": the leader is not within R of its goal and has made no progress;
- "deadlock": the leader is home and some follower off its slot made no progress and is still;
- "livelock": the leader is home and some follower off its slot made no progress but moves;
- "out of time": anything else (the leader still on its way, or followers still converging).

**Livelocks** are counted over the whole run, follower by follower: every maximal stretch of
ticks in which it is off its slot, moving and making no progress, as long as the stretch plus
the P s of no progress that flagged its first tick.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from shoal.bus.geometry import FloatArray
from shoal.bus.path import path_positions
from shoal.bus.types import PathSpec, Waypoints
from shoal.world.scenario import Scenario
from shoal.world.slots import slot_errors
from shoal.world.trajectory import Trajectory

BoolArray = np.ndarray[Any, np.dtype[np.bool_]]

# An agent slower than this is still, m/s (the stall rule's speed, world/metrics.py).
STALL_SPEED = 0.05
WINDOW = 1.0  # s: the trailing window followers' errors are averaged over ...
WINDOW_TICKS = 10  # ... and at least this many ticks
NO_PROGRESS_TIME = 10.0  # s: P, how long without getting closer counts as no progress

CAUSES = ("leader trapped", "deadlock", "livelock", "out of time")


@dataclass(frozen=True)
class Arrival:
    """Whether and when a run arrived (module docstring). ``time`` s or None; ``tolerance``
    R, m; ``cause`` one of :data:`CAUSES` or None if it arrived; ``livelocks`` episodes and
    the ``longest_livelock`` s; ``slot_distance``: the largest window-averaged distance of a
    follower from its slot at the last tick, m."""

    arrived: bool
    time: float | None
    tolerance: float
    cause: str | None
    livelocks: int
    longest_livelock: float
    slot_distance: float


def arrival_tolerance(scenario: Scenario) -> float:
    """R = separation / 2, m (module docstring)."""
    return scenario.separation / 2.0


def window_ticks(dt: float) -> int:
    """Ticks in the trailing averaging window: WINDOW s, at least WINDOW_TICKS, even."""
    w = max(WINDOW_TICKS, round(WINDOW / dt))
    return w + w % 2


def trailing_mean(x: FloatArray, w: int) -> FloatArray:
    """(T, ...) the mean of ``x`` (T, ...) over the w samples up to and including each one
    along axis 0 (over all of them before the w-th)."""
    total = np.cumsum(x, axis=0)
    total[w:] = total[w:] - total[:-w]
    count = np.minimum(np.arange(1, x.shape[0] + 1), w).astype(np.float64)
    return np.asarray(total / count.reshape(-1, *([1] * (x.ndim - 1))), dtype=np.float64)


def window_speed(x: FloatArray, w: int, dt: float) -> FloatArray:
    """(T, k) how fast each of the window-averaged positions ``x`` (T, k, dim) m moved over the
    last ``w`` ticks, m/s (from the first sample before the w-th)."""
    back = np.concatenate([np.repeat(x[:1], w, axis=0), x[:-w]]) if w < x.shape[0] else x[:1]
    return np.asarray(np.linalg.norm(x - back, axis=-1) / (w * dt), dtype=np.float64)


def no_progress(d: FloatArray, tol: float, p: int) -> BoolArray:
    """(T, k) whether each of k agents, off its goal (``d`` (T, k) > ``tol``, m), is no closer
    than ``tol`` better than its best of the same off-stretch up to ``p`` ticks before."""
    out = np.zeros(d.shape, dtype=bool)
    off = d > tol
    for i in range(d.shape[1]):
        flags = np.concatenate([[False], off[:, i], [False]]).astype(np.int8)
        edges = np.flatnonzero(np.diff(flags))
        for a, b in zip(edges[::2], edges[1::2], strict=True):
            if b - a <= p:
                continue  # off for less than P: too soon to say
            best = np.minimum.accumulate(d[a:b, i])
            out[a + p : b, i] = d[a + p : b, i] > best[: b - a - p] - tol
    return out


def leader_goals(path: PathSpec, ticks: int, dt: float) -> FloatArray:
    """(T, dim) the leader's goal at every tick, m: its last waypoint, or on a sinusoid where the
    path is then."""
    if isinstance(path, Waypoints):
        last = np.asarray(path.points[-1], dtype=np.float64)
        return np.asarray(np.broadcast_to(last, (ticks, last.shape[0])), dtype=np.float64)
    return path_positions(path, np.arange(ticks, dtype=np.float64) * dt)


def route_left(path: PathSpec, leader: FloatArray, reach: float, dt: float) -> FloatArray:
    """(T,) m: the leader's route left at every tick, from ``leader`` (T, dim) m: the distance
    to the next waypoint it has not yet come within ``reach`` m of plus the legs after it; on a
    sinusoid, its distance to where the path is."""
    ticks = leader.shape[0]
    if not isinstance(path, Waypoints):
        return np.asarray(
            np.linalg.norm(leader - leader_goals(path, ticks, dt), axis=1), dtype=np.float64
        )
    points = np.asarray(path.points, dtype=np.float64)
    legs = np.linalg.norm(np.diff(points, axis=0), axis=1)
    after = np.concatenate([np.cumsum(legs[::-1])[::-1], [0.0]])  # legs from waypoint j on
    out = np.empty(ticks)
    k = 0
    for j in range(points.shape[0]):
        dist = np.linalg.norm(leader[k:] - points[j], axis=1)
        near = np.flatnonzero(dist <= reach)
        stop = k + int(near[0]) if near.size and j + 1 < points.shape[0] else ticks
        out[k:stop] = dist[: stop - k] + after[j]
        k = stop
        if k >= ticks:
            break
    return out


def _episodes(flags: BoolArray, dt: float, extra: float) -> list[float]:
    """The length, s, of every maximal run of True along axis 0 of (T, k) ``flags``, each
    lengthened by ``extra`` s."""
    out: list[float] = []
    for i in range(flags.shape[1]):
        f = np.concatenate([[False], flags[:, i], [False]]).astype(np.int8)
        edges = np.flatnonzero(np.diff(f))
        out += [float((b - a) * dt + extra) for a, b in zip(edges[::2], edges[1::2], strict=True)]
    return out


def arrival(scenario: Scenario, traj: Trajectory) -> Arrival:
    """Whether, when, and if not why the run arrived, and its livelocks (module docstring)."""
    tol = arrival_tolerance(scenario)
    dt, ticks = traj.dt, traj.ticks
    w, p = window_ticks(dt), round(NO_PROGRESS_TIME / dt)
    leader = traj.positions[:ticks, 0]
    home = np.linalg.norm(leader - leader_goals(scenario.path, ticks, dt), axis=1) <= tol
    d = np.linalg.norm(trailing_mean(slot_errors(scenario, traj), w), axis=-1)  # (T, n-1)
    ok = home & (d <= tol).all(axis=1)
    stuck = no_progress(d, tol, p)
    still = window_speed(trailing_mean(traj.positions[:ticks, 1:], w), w, dt) < STALL_SPEED
    livelocked = (d > tol) & stuck & ~still
    episodes = _episodes(livelocked, dt, p * dt)
    last = ticks - 1
    cause = None
    if not ok[last]:
        left = route_left(scenario.path, leader, tol + scenario.path.speed * dt, dt)
        if not home[last]:
            trapped = no_progress(left[:, None], tol, p)[last, 0]
            cause = "leader trapped" if trapped else "out of time"
        elif (stuck[last] & still[last] & (d[last] > tol)).any():
            cause = "deadlock"
        elif livelocked[last].any():
            cause = "livelock"
        else:
            cause = "out of time"
    before = np.flatnonzero(~ok)
    start = int(before[-1]) + 1 if before.size else 0
    return Arrival(
        arrived=bool(ok[last]),
        time=start * dt if ok[last] else None,
        tolerance=tol,
        cause=cause,
        livelocks=len(episodes),
        longest_livelock=max(episodes, default=0.0),
        slot_distance=float(d[last].max()) if d.shape[1] else 0.0,
    )
