"""The numbers on the bag's metric topics, tick by tick, exact (float64, not rounded).

The same functions as the run's summary and the Foxglove plots (world/metrics.py), applied to
the tick records as the world logged them; per agent in id order (index i is agent i + 1).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from shoal.bus.messages import TickRecord
from shoal.geometry.vectors import FloatArray
from shoal.world.metrics import clearances, formation_errors, pair_distances
from shoal.world.scenario import Scenario
from shoal.world.trajectory import Trajectory


@dataclass(frozen=True)
class Metrics:
    """One block of ticks; every array has one row per record.

    formation_error (T, n) m: ‖s_i − s_1 − R(θ_i)δ_i/σ_i‖_∞, 0 for the leader; distance (T,) m:
    smallest distance between two agents' centres (nan for one agent); clearance (T, n) m: each
    agent's distance to the nearest obstacle's edge, or None without obstacles; sigma (T, n):
    σ applied; omega, alive, filtered (T, n): 1.0 while evading (Ω_i), while the agent's process
    is up, while its safety filter changed its command."""

    formation_error: FloatArray
    distance: FloatArray
    clearance: FloatArray | None
    sigma: FloatArray
    omega: FloatArray
    alive: FloatArray
    filtered: FloatArray


def metrics(scenario: Scenario, records: Sequence[TickRecord]) -> Metrics:
    """The metrics of ``records`` (consecutive ticks, at least one)."""
    s, traj = scenario, Trajectory.from_records(records, scenario.dt, scenario.lookaheads)
    rows = len(records)
    errors = np.zeros((rows, s.n))
    if s.n > 1:
        errors[:, 1:] = formation_errors(s, traj)
    distance = pair_distances(traj)[:-1].min(axis=1) if s.n > 1 else np.full(rows, np.nan)
    clear = clearances(s, traj)[:-1].min(axis=2) if s.obstacles else None
    return Metrics(
        formation_error=errors,
        distance=np.asarray(distance, dtype=np.float64),
        clearance=clear,
        sigma=traj.sigma,
        omega=traj.omega.astype(np.float64),
        alive=np.asarray([r.alive for r in records], dtype=np.float64),
        filtered=traj.filtered.astype(np.float64),
    )
