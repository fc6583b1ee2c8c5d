"""The formation law (1)-(2) with scaling (8), rotation (9) and the evasive term of (12).

One agent's view: its own position, its neighbours' positions, the offsets δ of all of them.
All vectors are (dim,) or (k, dim) float64 arrays in metres; velocities in m/s.
"""

from __future__ import annotations

import numpy as np

from shoal.bus.geometry import FloatArray, rotation, shaped

__all__ = [
    "consensus_error",
    "evasive_error",
    "rotation",
    "shaped",
    "velocity",
]


def consensus_error(
    position: FloatArray,
    offset: FloatArray,
    neighbour_positions: FloatArray,
    neighbour_offsets: FloatArray,
) -> FloatArray:
    """e_i = Σ_j A_ij (x_i - x_j) + u_i with u_i = -Σ_j A_ij (δ_i - δ_j)  ((1), (2)).

    Written as Σ_j ((x_i - δ_i) - (x_j - δ_j)) over the neighbours that are passed in, i.e. the
    row of A in force this tick (Algorithm 2 may have dropped some). Returns (dim,); zero when
    there are no neighbours.
    """
    own = position - offset
    if neighbour_positions.shape[0] == 0:
        return np.zeros_like(position)
    return np.asarray(
        (own - (neighbour_positions - neighbour_offsets)).sum(axis=0), dtype=np.float64
    )


def evasive_error(error: FloatArray, degree: int, evasive_offset: FloatArray) -> FloatArray:
    """The argument of (12): e_i - Δ_ii u^o_i.

    The paper prints "+ Δ_ii u^o". With e_i as in (2) the equilibrium of the law is where the
    argument vanishes, so "+" moves the agent's set-point by -u^o, towards the obstacle (u^o points
    from the obstacle to the ray). The minus sign here moves it by +u^o, away from the obstacle.
    """
    return error - degree * evasive_offset


def velocity(
    argument: FloatArray, *, alpha: float, beta: float, boundary_layer: float
) -> FloatArray:
    """v = -α e - β sign(e), per coordinate (law (1)); sat(e/φ) replaces sign when φ > 0."""
    if boundary_layer > 0:
        switching = np.clip(argument / boundary_layer, -1.0, 1.0)
    else:
        switching = np.sign(argument)
    return -alpha * argument - beta * switching
