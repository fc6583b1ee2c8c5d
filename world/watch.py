"""The leader's progress, watched tick by tick while a run goes on (the world's log events).

The summary names a run whose leader never got home "leader trapped" after the fact
(world/arrival.py). A person watching a run live, or reading its log, should hear of it when it
happens: :class:`LeaderWatch` applies the same rule to each tick as it comes — the leader is
trapped at tick k when it is not within R of its goal and its route left is not shorter than
its least up to P s before by more than R — and says so once, and once more if it gets going
again. Same R, P and route left as world/arrival.py, so the event and the summary agree
(tests/world/test_watch.py checks them against each other).
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np

from shoal.bus.types import Waypoints
from shoal.geometry.path import path_position
from shoal.geometry.vectors import FloatArray
from shoal.world.arrival import NO_PROGRESS_TIME, arrival_tolerance
from shoal.world.scenario import Scenario


class LeaderWatch:
    """Feed it the leader's position at the start of every tick, in order (:meth:`update`)."""

    def __init__(self, scenario: Scenario) -> None:
        self.path = scenario.path
        self.dt = scenario.dt
        self.tol = arrival_tolerance(scenario)
        self.reach = self.tol + scenario.path.speed * scenario.dt
        self.p = round(NO_PROGRESS_TIME / scenario.dt)
        self.points: FloatArray | None = None
        self.after: FloatArray | None = None
        if isinstance(self.path, Waypoints):
            self.points = np.asarray(self.path.points, dtype=np.float64)
            legs = np.linalg.norm(np.diff(self.points, axis=0), axis=1)
            self.after = np.concatenate([np.cumsum(legs[::-1])[::-1], [0.0]])
        self.next = 0  # the waypoint the leader heads for
        self.recent: deque[float] = deque()  # route left over the last P ticks
        self.best = math.inf  # least route left before those
        self.trapped = False

    def _goal_and_left(self, k: int, leader: FloatArray) -> tuple[FloatArray, float]:
        """Where the leader's goal is at tick k, and its route left there, m."""
        if self.points is None or self.after is None:
            goal = np.asarray(path_position(self.path, k * self.dt), dtype=np.float64)
            return goal, float(np.linalg.norm(leader - goal))
        last = self.points.shape[0] - 1
        while self.next < last and np.linalg.norm(leader - self.points[self.next]) <= self.reach:
            self.next += 1
        here = float(np.linalg.norm(leader - self.points[self.next]))
        return self.points[last], here + float(self.after[self.next])

    def update(self, k: int, leader: FloatArray) -> str | None:
        """The event to log at tick ``k`` for the leader at ``leader`` (dim,) m, or None."""
        goal, left = self._goal_and_left(k, leader)
        self.recent.append(left)
        if len(self.recent) > self.p:  # the value from tick k − P joins the least before
            self.best = min(self.best, self.recent.popleft())
        home = float(np.linalg.norm(leader - goal)) <= self.tol
        stuck = not home and k >= self.p and left > self.best - self.tol
        if stuck and not self.trapped:
            self.trapped = True
            return (
                f"leader trapped: no progress along its route for {NO_PROGRESS_TIME:g} s, "
                f"{left:.2f} m of it left, at ({', '.join(f'{x:.2f}' for x in leader)})"
            )
        if self.trapped and not stuck:
            self.trapped = False
            return f"leader moving again, {left:.2f} m of its route left"
        return None
