"""Arrival: whether a run got where it was going, when, and if not, why (docs/campaign.md).

**Tolerance.** A follower is in its slot when within R = separation/2 of it, m. That is the
safety filter's own length: slots at least the separation apart (what the loader demands) have
disjoint discs of radius R, so a follower within R of its slot is nearer to it than any other
agent can be. It does not grow with β.

**Chatter.** The sign term moves a follower about β·dt per tick around its slot, so followers
are judged on their error s_i − s_1 − R(θ)δ_i/σ averaged over a trailing window of
:func:`window_ticks` ticks (1 s, at least 10 ticks, an even count so that a period-2 chatter
cancels); the leader, which does not chatter, on its position.

**Arrived** at tick k: the leader within R of its goal, every follower's window-averaged
error within R, and no agent's σ or θ changed over the window, at k and at every tick after it
to the end of the run; the arrival time is the first such k·dt. (A formation whose agreed σ
flips every epoch has errors that alternate in sign: their mean can be small while every
follower is metres off its slot at every tick — a hard field, σ 8 ↔ 1 every 2 ticks to the
end with followers 4.8–5.0 m off, counted as arrived before this rule.)
The leader's goal is its last waypoint; a sinusoid never ends, so there the goal is where the
path is at that tick (the formation arrives when it is on the moving path).

**Progress.** A follower makes no progress at tick k when the leader has been home and the
follower off its slot (d > R) throughout the last P = :data:`NO_PROGRESS_TIME` s, and d(k) is
not below its least over the P s before those by more than R (the leader must be home: while it
moves, so do the slots, and a follower trailing its slot is tracking it). It is **still** when its
window-averaged position moved slower than STALL_SPEED over the last window, else **moving**.
The leader makes no progress when its route left is not below its least up to P s ago by more
than R; the route left is the distance to the next waypoint it has not yet come within R
(+ one step) of, plus the legs after it (on a sinusoid: its distance to where the path is).

**Why not.** A run that has not arrived at its last tick is named by the state at that tick:
- "leader trapped": the leader is not within R of its goal and has made no progress;
- "deadlock": the leader has been home for the last P s and the formation made no progress in
  them: its farthest follower is not closer than the farthest was at best in the P s before
  those, by more than R; and that follower is still;
- "livelock": the same, but that follower moves; or the agreed shape changed more than twice
  in the last P s (a contraction and its return are two changes; more is Algorithm 1 flipping
  σ, which no follower's averaged error shows: see Arrived);
- "out of time": anything else (the leader still on its way or home for less than P s, or the
  formation still converging).

**Livelocks** are counted over the whole run, follower by follower: every maximal stretch of
ticks in which it moves and makes no progress, as long as the stretch plus the P s that
flagged its first tick.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from shoal.bus.types import PathSpec, Waypoints
from shoal.geometry.path import path_positions
from shoal.geometry.vectors import FloatArray
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
class ArrivalVerdict:
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


def trailing_min(x: FloatArray, p: int) -> FloatArray:
    """(T, ...) the least of ``x`` (T, ...) over the p+1 samples up to and including each one
    along axis 0 (fewer at the start): van Herk's blocks, O(T) for any p.

    The front is padded with copies of the first sample, which every early window holds
    anyway; the back only up to a whole block, which no window reaches."""
    m, t = p + 1, x.shape[0]
    head = np.repeat(x[:1], m - 1, axis=0)
    tail = np.repeat(x[-1:], -(t + m - 1) % m, axis=0)
    padded = np.concatenate([head, x, tail])
    blocks = padded.reshape(-1, m, *x.shape[1:])
    fwd = np.minimum.accumulate(blocks, axis=1).reshape(padded.shape)
    bwd = np.minimum.accumulate(blocks[:, ::-1], axis=1)[:, ::-1].reshape(padded.shape)
    k = np.arange(t)
    return np.asarray(np.minimum(bwd[k], fwd[k + m - 1]), dtype=np.float64)


def stuck(d: FloatArray, tol: float, p: int) -> BoolArray:
    """(T, k) whether each of k agents makes no progress at each tick: its distance ``d``
    (T, k) m has stayed above ``tol`` over the last p+1 ticks and is not below its least of the
    p ticks before those by more than ``tol``. False in the first 2p ticks."""
    recent = trailing_min(d, p)
    out = np.zeros(d.shape, dtype=bool)
    if d.shape[0] > 2 * p:
        earlier = recent[p:-p]  # the least over [k − 2p, k − p], for k from 2p on
        out[2 * p :] = (recent[2 * p :] > tol) & (d[2 * p :] > earlier - tol)
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


def _shape_changes(traj: Trajectory) -> BoolArray:
    """(T,) whether some agent applies another σ or θ at tick k than at tick k − 1."""
    out = np.zeros(traj.ticks, dtype=bool)
    if traj.ticks > 1:
        moved = (traj.sigma[1:] != traj.sigma[:-1]) | (traj.theta[1:] != traj.theta[:-1])
        out[1:] = moved.any(axis=1)
    return out


def arrival(scenario: Scenario, traj: Trajectory) -> ArrivalVerdict:
    """Whether, when, and if not why the run arrived, and its livelocks (module docstring)."""
    tol = arrival_tolerance(scenario)
    dt, ticks = traj.dt, traj.ticks
    w, p = window_ticks(dt), round(NO_PROGRESS_TIME / dt)
    leader = traj.positions[:ticks, 0]
    home = np.linalg.norm(leader - leader_goals(scenario.path, ticks, dt), axis=1) <= tol
    d = np.linalg.norm(trailing_mean(slot_errors(scenario, traj), w), axis=-1)  # (T, n-1)
    changed = _shape_changes(traj)
    steady = trailing_min((~changed).astype(np.float64), w) > 0.5  # no change over the window
    ok = home & (d <= tol).all(axis=1) & steady
    settled = trailing_min(home.astype(np.float64), p) > 0.5  # home for the last P s
    held = stuck(d, tol, p) & settled[:, None]  # while the leader moves, so do the slots
    still = window_speed(trailing_mean(traj.positions[:ticks, 1:], w), w, dt) < STALL_SPEED
    livelocked = held & ~still
    episodes = _episodes(livelocked, dt, p * dt)
    last = ticks - 1
    cause = None
    if not ok[last]:
        if not home[last]:
            left = route_left(scenario.path, leader, tol + scenario.path.speed * dt, dt)
            best = float(left[: last - p + 1].min()) if last >= p else -np.inf
            cause = "leader trapped" if left[last] > best - tol else "out of time"
        elif settled[last] and int(changed[last - p + 1 :].sum()) > 2:
            cause = "livelock"  # the agreed shape keeps changing: Algorithm 1 flips σ
        elif settled[last] and last >= 2 * p:
            worst = d.max(axis=1)  # the formation is as far as its farthest follower
            if worst[last] > trailing_min(worst, p)[last - p] - tol:  # no progress in P s
                cause = "deadlock" if still[last, int(np.argmax(d[last]))] else "livelock"
            else:
                cause = "out of time"
        else:
            cause = "out of time"
    before = np.flatnonzero(~ok)
    start = int(before[-1]) + 1 if before.size else 0
    return ArrivalVerdict(
        arrived=bool(ok[last]),
        time=start * dt if ok[last] else None,
        tolerance=tol,
        cause=cause,
        livelocks=len(episodes),
        longest_livelock=max(episodes, default=0.0),
        slot_distance=float(d[last].max()) if d.shape[1] else 0.0,
    )
