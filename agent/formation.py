"""The formation law (1)-(2) with scaling (8), rotation (9) and the evasive term of (12).

One agent's view: its own position, its neighbours' positions, the offsets δ of all of them, in
metres; velocities in m/s. Vectors are plain-float tuples of length dim (arrays are accepted):
the law runs for every agent every tick, where a numpy call on a 2-vector costs more than its
arithmetic. Each function does numpy's operations in numpy's order, so the bits are the same.
"""

from __future__ import annotations

from shoal.geometry.vectors import PointsLike, Vector, VectorLike, rotation, shaped, sub

__all__ = [
    "consensus_error",
    "evasive_error",
    "rotation",
    "shaped",
    "velocity",
]


def consensus_error(
    position: VectorLike,
    offset: VectorLike,
    neighbour_positions: PointsLike,
    neighbour_offsets: PointsLike,
) -> Vector:
    """e_i = Σ_j A_ij (x_i - x_j) + u_i with u_i = -Σ_j A_ij (δ_i - δ_j)  ((1), (2)).

    Written as Σ_j ((x_i - δ_i) - (x_j - δ_j)) over the neighbours that are passed in, i.e. the
    row of A in force this tick (Algorithm 2 may have dropped some), summed in their order.
    Returns (dim,); zero when there are no neighbours.
    """
    own = sub(position, offset)
    total: Vector | None = None
    for x, d in zip(neighbour_positions, neighbour_offsets):
        term = sub(own, sub(x, d))
        total = term if total is None else tuple([x + y for x, y in zip(total, term)])
    return tuple([0.0 for _ in own]) if total is None else total


def evasive_error(error: VectorLike, degree: int, evasive_offset: VectorLike) -> Vector:
    """The argument of (12): e_i - Δ_ii u^o_i.

    The paper prints "+ Δ_ii u^o". With e_i as in (2) the equilibrium of the law is where the
    argument vanishes, so "+" moves the agent's set-point by -u^o, towards the obstacle (u^o points
    from the obstacle to the ray). The minus sign here moves it by +u^o, away from the obstacle.
    """
    return tuple([e - degree * u for e, u in zip(error, evasive_offset)])


def _sign(x: float) -> float:
    """sign(x) as numpy has it: 1, −1, or 0 (a positive zero, also for −0)."""
    return 1.0 if x > 0.0 else -1.0 if x < 0.0 else 0.0


def velocity(argument: VectorLike, *, alpha: float, beta: float, boundary_layer: float) -> Vector:
    """v = -α e - β sign(e), per coordinate (law (1)); sat(e/φ) replaces sign when φ > 0."""
    if boundary_layer > 0:
        switching = [min(max(e / boundary_layer, -1.0), 1.0) for e in argument]
    else:
        switching = [_sign(e) for e in argument]
    return tuple([-alpha * e - beta * s for e, s in zip(argument, switching)])
