"""Formation geometry shared by agents and the world: the demanded shape R(θ)δ/σ of Remark 2.

The agent steers to it; the world measures the formation error against it.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]


def segment_distance(point: FloatArray, a: FloatArray, b: FloatArray) -> float:
    """Distance from ``point`` to the segment from ``a`` to ``b``, m."""
    ab = b - a
    length2 = float(ab @ ab)
    t = 0.0 if length2 == 0.0 else min(1.0, max(0.0, float((point - a) @ ab) / length2))
    return float(np.linalg.norm(point - (a + t * ab)))


def rotation(theta: float, dim: int) -> FloatArray:
    """R(θ): (dim, dim) rotation by θ rad counter-clockwise; about the z axis in 3-D.

    This is (9) without its printed leading minus sign, which would rotate by θ + π.
    """
    c, s = math.cos(theta), math.sin(theta)
    r = np.eye(dim)
    r[:2, :2] = ((c, -s), (s, c))
    return r


def shaped(offsets: FloatArray, *, sigma: float, theta: float) -> FloatArray:
    """Desired offsets under Remark 2: R(θ) δ / σ, for (dim,) or (k, dim) offsets in m."""
    r = rotation(theta, offsets.shape[-1])
    return (offsets @ r.T) / sigma
