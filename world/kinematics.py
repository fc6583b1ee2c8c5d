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


def sensed(position: FloatArray, centres: FloatArray, sensing_radius: float) -> list[int]:
    """Indices of the obstacles whose centre is within the sensing radius d (Section 3)."""
    if centres.shape[0] == 0:
        return []
    dist = np.linalg.norm(centres - position, axis=1)
    return [int(k) for k in np.flatnonzero(dist <= sensing_radius)]


def sensing_for(
    tick: int,
    position: FloatArray,
    centres: FloatArray,
    radii: FloatArray,
    sensing_radius: float,
) -> Sensing:
    """The world's message to one agent at the start of ``tick``."""
    seen = sensed(position, centres, sensing_radius)
    return Sensing(
        tick=tick,
        position=tuple(float(x) for x in position),
        obstacle_ids=tuple(seen),
        obstacle_centres=tuple(tuple(float(x) for x in centres[k]) for k in seen),
        obstacle_radii=tuple(float(radii[k]) for k in seen),
    )
