"""Contacts between agents and moving obstacles, and whose fault each was (docs/people.md).

With people about, safety cannot mean "no contact ever": a person can walk into a robot that
stands still or flees. What the filter promises is *passive* safety: an agent never moves
into a collision; if contact happens, it is at rest or moving away. A contact is therefore
classified by exactly that rule:

- **agent at fault**: at some tick of the contact the agent moved towards the obstacle, its
  velocity v with g·v < −:data:`TOWARDS` (g the unit vector from the obstacle's centre to
  the agent at the start of the tick);
- **obstacle at fault**: at every tick of the contact the agent stood or moved away.

Contact is continuous in time: both move in straight lines over a tick, so the least distance
within a tick is found exactly, and a contact that begins and ends between two samples counts.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from shoal.world.scenario import Scenario
from shoal.world.trajectory import Trajectory

TOWARDS = 1e-9  # m/s: an approach slower than this is rounding, not motion


@dataclass(frozen=True)
class Contact:
    """One contact: agent ``agent`` (id) touched obstacle ``obstacle`` (scenario index) from
    tick ``start`` for ``ticks`` ticks; ``closest`` the least gap between the bodies, m (< 0);
    ``approach`` the fastest the agent moved towards it meanwhile, m/s (≤ 0: never)."""

    agent: int
    obstacle: int
    start: int
    ticks: int
    closest: float
    approach: float

    @property
    def agent_at_fault(self) -> bool:
        return self.approach > TOWARDS

    @property
    def fault(self) -> str:
        return "agent" if self.agent_at_fault else "obstacle"


def least_gaps(s: Scenario, traj: Trajectory) -> tuple[np.ndarray, np.ndarray]:
    """(T, n, m) the least gap between agent body and moving obstacle within every tick, m,
    and (T, n, m) how fast each agent moved towards each one's centre, m/s."""
    if traj.movers is None or traj.mover_velocities is None:
        empty = np.zeros((traj.ticks, traj.positions.shape[1], 0))
        return empty, empty
    ticks = traj.ticks
    rel = traj.positions[:ticks, :, None, :] - traj.movers[:ticks, None, :, :]
    closing = traj.velocities[:, :, None, :] - traj.mover_velocities[:, None, :, :]
    a = (closing * closing).sum(axis=-1)
    b = (rel * closing).sum(axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        when = np.where(a > 0.0, np.clip(-b / a, 0.0, traj.dt), 0.0)
    nearest = rel + when[..., None] * closing
    radii = np.asarray([s.obstacles[k].radius for k in s.mover_ids])
    # body_reach: a unicycle's body lies within it of its point's chord (world/unicycle.py)
    gaps = np.sqrt((nearest * nearest).sum(axis=-1)) - radii - s.body_reach
    dist = np.sqrt((rel * rel).sum(axis=-1))
    with np.errstate(divide="ignore", invalid="ignore"):
        towards = np.where(
            dist > 0.0, -(rel * traj.velocities[:, :, None, :]).sum(axis=-1) / dist, 0.0
        )
    return gaps, towards


def contacts(s: Scenario, traj: Trajectory) -> list[Contact]:
    """Every contact of the run between an agent and a moving obstacle, in time order."""
    gaps, towards = least_gaps(s, traj)
    out: list[Contact] = []
    touching = gaps < 0.0
    for i, q in zip(*np.nonzero(touching.any(axis=0)), strict=True):
        flags = np.concatenate([[False], touching[:, i, q], [False]]).astype(np.int8)
        edges = np.flatnonzero(np.diff(flags))
        for a, b in zip(edges[::2], edges[1::2], strict=True):
            out.append(
                Contact(
                    agent=int(i) + 1,
                    obstacle=s.mover_ids[int(q)],
                    start=int(a),
                    ticks=int(b - a),
                    closest=float(gaps[a:b, i, q].min()),
                    approach=float(towards[a:b, i, q].max()),
                )
            )
    return sorted(out, key=lambda c: (c.start, c.agent, c.obstacle))
