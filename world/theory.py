"""Convergence-time bounds of Theorem 1 (undirected) and Remark 3 (directed).

Both are stated per coordinate (the laws are decoupled by coordinate); the bound for a multi-
dimensional formation is the largest of its coordinates' bounds. The paper's x̃(0) is read as the
formation error z_i(0) = x_i(0) - x_1(0) - δ_i: the printed "- u_xi" does not make the error
vanish at the desired formation (see docs/paper-notes.md, Theorem 1).
"""

from __future__ import annotations

import math

import numpy as np

from shoal.geometry.vectors import FloatArray
from shoal.world.graph import follower_matrix


def formation_error(positions: FloatArray, offsets: FloatArray) -> FloatArray:
    """z: (n-1, dim) error of every follower from its slot, positions and offsets (n, dim) in m."""
    return np.asarray(positions[1:] - positions[0] - offsets[1:], dtype=np.float64)


def theorem1_bound(a: FloatArray, z0: FloatArray, *, beta: float, f_max: FloatArray) -> float:
    """t̄ = sqrt(z(0)ᵀ M z(0) λ_max) / ((β - f_max) λ_min), s, max over coordinates.

    a : (n, n) symmetric adjacency; z0 : (n-1, dim) initial error, m; f_max : (dim,) largest
    |leader velocity| per coordinate, m/s. Returns inf when β ≤ f_max in some coordinate.
    """
    m = follower_matrix(a)
    eig = np.linalg.eigvalsh(m)
    lam_min, lam_max = float(eig[0]), float(eig[-1])
    worst = 0.0
    for c in range(z0.shape[1]):
        margin = beta - float(f_max[c])
        if margin <= 0:
            return math.inf
        z = z0[:, c]
        worst = max(worst, math.sqrt(float(z @ m @ z) * lam_max) / (margin * lam_min))
    return worst


def remark3_bound(z0: FloatArray, *, beta: float, f_max: FloatArray) -> float:
    """t̄ = max_i |z_i(0)| / (β - f_max), s, max over coordinates (directed graphs)."""
    worst = 0.0
    for c in range(z0.shape[1]):
        margin = beta - float(f_max[c])
        if margin <= 0:
            return math.inf
        worst = max(worst, float(np.abs(z0[:, c]).max(initial=0.0)) / margin)
    return worst


def convergence_bound(
    a: FloatArray, z0: FloatArray, *, directed: bool, beta: float, f_max: FloatArray
) -> float:
    """The bound that applies to the graph kind: Remark 3 if directed, else Theorem 1."""
    if directed:
        return remark3_bound(z0, beta=beta, f_max=f_max)
    return theorem1_bound(a, z0, beta=beta, f_max=f_max)
