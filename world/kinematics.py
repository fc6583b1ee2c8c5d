"""Single-integrator kinematics ṡ_i = v_i and obstacle sensing, as pure functions.

positions, velocities : (n, dim) float64, m and m/s. Obstacles: centres (m, dim), radii (m,), m.
"""

from __future__ import annotations

import numpy as np

from bus.types import Sensing
from world.graph import FloatArray


def integrate(positions: FloatArray, velocities: FloatArray, dt: float) -> FloatArray:
    """One explicit Euler step of ṡ = v over dt seconds."""
    return positions + dt * velocities


def sense_all(
    tick: int,
    positions: FloatArray,
    centres: FloatArray,
    radii: FloatArray,
    sensing_radius: float,
) -> list[Sensing]:
    """The world's messages to every agent at the start of ``tick``, agent-id order."""
    rows = positions.tolist()
    if centres.shape[0] == 0:
        return [Sensing(tick, tuple(row), (), (), ()) for row in rows]
    near = np.linalg.norm(positions[:, None, :] - centres[None, :, :], axis=-1) <= sensing_radius
    centre_rows, radius_list = centres.tolist(), radii.tolist()
    out = []
    for i, row in enumerate(rows):
        seen = np.flatnonzero(near[i]).tolist()
        out.append(
            Sensing(
                tick=tick,
                position=tuple(row),
                obstacle_ids=tuple(seen),
                obstacle_centres=tuple(tuple(centre_rows[k]) for k in seen),
                obstacle_radii=tuple(radius_list[k] for k in seen),
            )
        )
    return out
