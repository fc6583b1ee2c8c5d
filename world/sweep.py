"""Least distances over each whole step, not only at its ticks.

Over tick k every agent moves in a straight line, from ``positions[k]`` to ``positions[k+1]``
(= positions[k] + dt·velocities[k], world/kinematics.py), so the least distance within the step
has a closed form. Sampling at ticks alone misses an agent that passes through a disc between
two ticks: a disc's outside is not convex.

- agent against a standing disc (sphere) of centre c: the distance from c to the segment;
- agent against agent: both move linearly in the same parameter, so their difference does too,
  and the least of ‖Δp + u·(Δp' − Δp)‖ over u ∈ [0, 1] is the same formula with c = 0.

Each least value is also taken against the step's two ends, computed exactly as a tick sample
is, so a swept minimum is never above the tick samples it spans (not even by an ulp).
Moving obstacles have their own exact sweep in world/contacts.py.
"""

from __future__ import annotations

import numpy as np

from shoal.geometry.vectors import FloatArray


def _least_norm(start: FloatArray, end: FloatArray) -> FloatArray:
    """min over u ∈ [0, 1] of ‖start + u·(end − start)‖ along the last axis, m.

    ``start``, ``end``: (..., dim) m, broadcast together; returns (...)."""
    move = end - start
    a = (move * move).sum(axis=-1)
    b = (start * move).sum(axis=-1)
    with np.errstate(over="ignore"):  # a step of 1e-300 m: u clips to 0 or 1 all the same
        u = np.where(a > 0.0, np.clip(-b / np.where(a > 0.0, a, 1.0), 0.0, 1.0), 0.0)
    nearest = start + u[..., None] * move
    inner = np.sqrt((nearest * nearest).sum(axis=-1))
    ends = np.minimum(np.linalg.norm(start, axis=-1), np.linalg.norm(end, axis=-1))
    return np.asarray(np.minimum(inner, ends), dtype=np.float64)


def step_clearances(positions: FloatArray, centres: FloatArray, radii: FloatArray) -> FloatArray:
    """(T, n, m) least distance from every agent to every standing obstacle's edge over every
    step, m (negative inside it).

    positions : (T+1, n, dim) m, at every tick and after the last;
    centres : (m, dim) m; radii : (m,) m."""
    rel = positions[:, :, None, :] - centres[None, None, :, :]  # (T+1, n, m, dim)
    return np.asarray(_least_norm(rel[:-1], rel[1:]) - radii, dtype=np.float64)


def step_separations(positions: FloatArray) -> FloatArray:
    """(T, n(n-1)/2) least distance between every pair of agents over every step, m, pairs in
    (i<j) order as :func:`shoal.world.metrics.pair_distances` has them.

    positions : (T+1, n, dim) m. Worked out one agent at a time against those after it, so the
    memory is (T+1)·n·dim at a time besides the (T, pairs) result."""
    n = positions.shape[1]
    columns = [
        _least_norm(rel[:-1], rel[1:])
        for i in range(n - 1)
        for rel in [positions[:, i : i + 1, :] - positions[:, i + 1 :, :]]
    ]
    if not columns:
        return np.zeros((positions.shape[0] - 1, 0))
    return np.concatenate(columns, axis=1)
