"""Where every follower should be: its slot s_1 + R(θ)δ_i/σ relative to the leader.

The σ, θ are the ones that follower applied at the tick (Remark 2, (8)-(9)); in 3-D the rotation
is about the z axis.
"""

from __future__ import annotations

import math

import numpy as np

from shoal.geometry.vectors import FloatArray
from shoal.world.scenario import Scenario
from shoal.world.trajectory import Trajectory


def slot_errors(scenario: Scenario, traj: Trajectory) -> FloatArray:
    """(T, n-1, dim) every follower's position minus its slot at the start of every tick, m.

    The demanded offsets are :func:`~shoal.geometry.vectors.shaped`'s, elementwise over all ticks
    at once: the same operations, so the same bits; cos and sin by ``math`` on each distinct θ
    (numpy's may be vectorised differently on another CPU)."""
    offsets = scenario.offsets[1:]
    ticks = traj.ticks
    rel = traj.positions[:-1, 1:] - traj.positions[:-1, :1]
    theta, sigma = traj.theta[:ticks, 1:], traj.sigma[:ticks, 1:]
    values, where = np.unique(theta, return_inverse=True)
    c = np.array([math.cos(t) for t in values.tolist()])[where].reshape(theta.shape)
    s = np.array([math.sin(t) for t in values.tolist()])[where].reshape(theta.shape)
    desired = np.broadcast_to(offsets, rel.shape).copy()
    x, y = offsets[:, 0], offsets[:, 1]
    desired[..., 0] = x * c + y * -s
    desired[..., 1] = x * s + y * c
    desired /= sigma[..., None]
    return np.asarray(rel - desired, dtype=np.float64)
