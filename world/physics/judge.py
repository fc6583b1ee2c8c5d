"""The engine judges a physics run: at every physics step, the contacts MuJoCo reports between a
robot and an obstacle, a person or another robot, and the least distances of the agents' points
to the standing obstacles and to each other (what the safety theorem's guard and separation
are about), read from the bodies the engine moved. A contact is a collision, whatever shoal's
own geometry says — except a person walking into a robot that was not driving towards them,
which is counted beside, as the kinematic summary counts it (world/contacts.py).

The figures replace the ticks' in a physics run's summary (world/metrics.py reads only the
ticks, which the engine's motion passes between).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import mujoco
import numpy as np

from shoal.geometry.vectors import FloatArray
from shoal.world.contacts import TOWARDS
from shoal.world.scenario import Scenario


class Judge:
    """What the engine's motion amounted to, physics step by physics step."""

    def __init__(
        self,
        scenario: Scenario,
        model: mujoco.MjModel,
        points_of: Callable[[FloatArray], FloatArray],
    ) -> None:
        """``points_of``: the agents' points (k, n, dim) at k rows of the engine's qpos."""
        s = scenario
        self.n, self.dim, self.rho, self.separation = (
            s.n,
            s.dim,
            s.control.safety_margin,
            s.separation,
        )
        self.centres, self.radii = s.obstacle_centres, s.obstacle_radii
        self.people = {k: model.body(f"person{k}").mocapid[0] for k in s.mover_ids}
        # who each geom is: agent i (0-based), n + obstacle k, or -1 (floor, wheels, casters)
        self.who = np.full(model.ngeom, -1, dtype=np.int64)
        for i in range(s.n):
            self.who[model.geom(f"body{i + 1}").id] = i
        for k in range(len(s.obstacles)):
            self.who[model.geom(f"obstacle{k}").id] = s.n + k
        self.upper = np.triu_indices(s.n, 1)
        self.points_of = points_of
        self.qpos = np.empty((0, model.nq))  # the stretch's positions, one row per physics step
        self.commanded = np.zeros((s.n, s.dim))
        self.tracked = False
        self.stretch: dict[tuple[int, int], float] = {}  # pair → the deepest this stretch
        self.touching: set[tuple[int, int]] = set()
        self.contacts: list[tuple[int, int, float]] = []  # onsets: (agent, other, physics step)
        self.at_fault = 0  # onsets with a person the robot was driving towards, or any other
        self.deepest = 0.0  # m: the deepest penetration the engine reported (≤ 0)
        self.steps = 0
        self.clearance = np.inf  # m: least point-to-edge distance to a standing obstacle
        self.distance = np.inf  # m: least distance between two agents' points
        self.tracking: list[FloatArray] = []  # per tick, per agent: |achieved − commanded|, m/s

    def begin(self, qpos: FloatArray, commanded: FloatArray | None, steps: int) -> None:
        """A stretch of ``steps`` physics steps from the engine's positions ``qpos``, meant to
        move the points at ``commanded`` (None: no tracking error is taken)."""
        if self.qpos.shape[0] != steps + 1:
            self.qpos = np.empty((steps + 1, qpos.shape[0]))
        self.qpos[0] = qpos
        self.stretch = {}
        self.commanded = np.zeros((self.n, self.dim)) if commanded is None else commanded
        self.tracked = commanded is not None

    def physics_step(self, data: mujoco.MjData, sub: int) -> None:
        self.qpos[sub + 1] = data.qpos
        self.steps += 1
        if not self.touching and not data.sensordata.any():  # no robot's body touches anything
            return
        now: set[tuple[int, int]] = set()
        if data.ncon:
            geoms = data.contact.geom[: data.ncon]
            dist = data.contact.dist[: data.ncon]
            who = self.who[geoms]
            judged = (who >= 0).all(axis=1) & (who.min(axis=1) < self.n) & (dist < 0)
            for (a, b), depth in zip(who[judged].tolist(), dist[judged].tolist(), strict=True):
                pair = (min(a, b), max(a, b))
                now.add(pair)
                self.deepest = min(self.deepest, depth)
                self.stretch[pair] = min(self.stretch.get(pair, 0.0), depth)
        for pair in sorted(now - self.touching):
            self._onset(*pair, self.points_of(self.qpos[sub + 1 : sub + 2])[0], data)
        self.touching = now

    def _onset(self, agent: int, other: int, points: FloatArray, data: mujoco.MjData) -> None:
        self.contacts.append((agent, other, float(self.steps)))
        k = other - self.n
        if k not in self.people:
            self.at_fault += 1
            return
        # a person: the robot's fault only if it was driving towards them
        towards = data.mocap_pos[self.people[k], : self.dim] - points[agent]
        size = float(np.linalg.norm(towards))
        approach = float(self.commanded[agent] @ towards) / size if size > 0 else 0.0
        self.at_fault += approach > TOWARDS

    def end(self, elapsed: float) -> None:
        path = self.points_of(self.qpos)
        if len(self.radii):
            gaps = np.linalg.norm(path[:, :, None, :] - self.centres, axis=-1) - self.radii
            self.clearance = min(self.clearance, float(gaps.min()))
        if self.n > 1:
            apart = np.linalg.norm(path[:, self.upper[0]] - path[:, self.upper[1]], axis=-1)
            self.distance = min(self.distance, float(apart.min()))
        if self.tracked:
            achieved = (path[-1] - path[0]) / elapsed
            self.tracking.append(np.linalg.norm(achieved - self.commanded, axis=-1))

    def stretch_contacts(self) -> tuple[tuple[float, float, float], ...]:
        """Every pair in contact during the last stretch: (agent id, what it touched — an agent
        id, or n + 1 + k for obstacle k —, the deepest depth, m)."""
        return tuple((a + 1.0, b + 1.0, d) for (a, b), d in sorted(self.stretch.items()))

    def report(self) -> dict[str, Any]:
        errors = np.concatenate(self.tracking) if self.tracking else None
        clearance = None if not np.isfinite(self.clearance) else self.clearance
        out: dict[str, Any] = {
            "collisions": self.at_fault,
            "engine_contacts": len(self.contacts),
            "engine_deepest_contact": self.deepest,
            "physics_steps": self.steps,
            "min_clearance": clearance,
            "guard_margin": None if clearance is None else clearance - self.rho,
            "tracking_error_p50": None if errors is None else float(np.percentile(errors, 50)),
            "tracking_error_p99": None if errors is None else float(np.percentile(errors, 99)),
            "tracking_error_max": None if errors is None else float(errors.max()),
        }
        if self.n > 1:
            out["min_interagent_distance"] = self.distance
            out["separation_margin"] = self.distance - self.separation
        return out
