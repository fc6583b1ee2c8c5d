"""Formation geometry shared by agents and the world: the demanded shape R(θ)δ/σ of Remark 2,
and the small-vector arithmetic every process must do to the same bits.

The agent steers to the shape; the world measures the formation error against it.

**Portable arithmetic.** numpy hands ``a @ b``, ``np.dot`` and ``np.linalg.norm`` of a 1-D array to
BLAS, and OpenBLAS picks its kernel by the CPU it runs on: on an AVX-512 machine (kernel
"SkylakeX") ``np.linalg.norm`` of a 2-vector differs in the last bit from the same call under
kernel "Haswell", and a run then leaves the reference by 1e-15 m within a thousand ticks
(measured: the same numpy 2.4.6 wheel in a container, where OPENBLAS_CORETYPE was not set, and
on the host, where it was). :func:`dot`, :func:`norm` and :func:`shaped` below do the sums in
plain Python floats, in a fixed order (x·x + y·y + z·z), which IEEE 754 rounds the same way on
every machine; elementwise numpy (+, −, ×, ÷, sqrt) is exact and needs no such care.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
Vector = tuple[float, ...]  # a plain-float vector: the per-tick arithmetic's (see above)
VectorLike = Sequence[float] | FloatArray  # a (dim,) vector either way
PointsLike = Sequence[Sequence[float]] | FloatArray  # (k, dim) vectors either way


def dot(a: VectorLike, b: VectorLike) -> float:
    """a · b of two (dim,) vectors (arrays or plain-float tuples), summed left to right from
    the first product in Python floats: the same bits on every machine (see the module's
    docstring)."""
    x = a.tolist() if isinstance(a, np.ndarray) else a
    y = b.tolist() if isinstance(b, np.ndarray) else b
    if len(x) == 2:
        return x[0] * y[0] + x[1] * y[1]
    s = x[0] * y[0]
    for k in range(1, len(x)):
        s += x[k] * y[k]
    return s


def floats(v: VectorLike) -> Sequence[float]:
    """A (dim,) vector as plain floats (an array's ``tolist()``, the same values): compiled code
    that compares elements of an array gets numpy.bool where mypyc expects a bool, a TypeError."""
    return v.tolist() if isinstance(v, np.ndarray) else v


def norm(v: VectorLike) -> float:
    """‖v‖ of a (dim,) vector: sqrt(v · v) with :func:`dot`; portable where np.linalg.norm is
    not."""
    return math.sqrt(dot(v, v))


def sub(a: VectorLike, b: VectorLike) -> Vector:
    """a − b of two plain-float vectors, as a tuple (elementwise: the same bits as numpy's)."""
    return tuple([x - y for x, y in zip(a, b)])


def add(a: VectorLike, b: VectorLike) -> Vector:
    """a + b of two plain-float vectors, as a tuple."""
    return tuple([x + y for x, y in zip(a, b)])


def scale(k: float, v: VectorLike) -> Vector:
    """k · v of a plain-float vector, as a tuple."""
    return tuple([k * x for x in v])


def divide(v: VectorLike, d: float) -> Vector:
    """v / d elementwise, as a tuple: numpy's ``v / d`` (not v · (1/d), which rounds
    differently)."""
    return tuple([x / d for x in v])


def plain(v: VectorLike) -> Vector:
    """``v`` as a tuple of Python floats (a tuple of floats comes back as it is)."""
    if type(v) is tuple:
        return v
    return tuple(v.tolist()) if hasattr(v, "tolist") else tuple(float(x) for x in v)


def vdot(a: Sequence[float], b: Sequence[float]) -> float:
    """a · b of two plain-float vectors (tuples, lists), summed from 0.0 left to right: the
    small-vector arithmetic of the safety filter and the crowd model, the same bits anywhere."""
    s = 0.0
    for x, y in zip(a, b):
        s += x * y
    return s


def right_of(heading: Sequence[float]) -> tuple[float, ...]:
    """A unit vector to the right of the unit ``heading``: clockwise in the plane; in 3-D
    heading × z (horizontal), or for a vertical heading the x axis, its sign by the heading's:
    two agents head on along z then turn opposite ways and pass, where one axis for both sent
    them side by side the same way and held them for good."""
    if len(heading) == 2:
        return (heading[1], -heading[0])
    hx, hy, hz = heading
    size = math.hypot(hx, hy)
    if size < 1e-9:
        return (1.0 if hz >= 0.0 else -1.0, 0.0, 0.0)
    return (hy / size, -hx / size, 0.0)


def segment_distance(point: VectorLike, a: VectorLike, b: VectorLike) -> float:
    """Distance from ``point`` to the segment from ``a`` to ``b``, m (arrays or tuples)."""
    if isinstance(point, np.ndarray) or isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        point, a, b = np.asarray(point).tolist(), np.asarray(a).tolist(), np.asarray(b).tolist()
    ab = sub(b, a)
    length2 = dot(ab, ab)
    t = 0.0 if length2 == 0.0 else min(1.0, max(0.0, dot(sub(point, a), ab) / length2))
    return norm(sub(point, add(a, scale(t, ab))))


def rotation(theta: float, dim: int) -> FloatArray:
    """R(θ): (dim, dim) rotation by θ rad counter-clockwise; about the z axis in 3-D.

    This is (9) without its printed leading minus sign, which would rotate by θ + π.
    """
    c, s = math.cos(theta), math.sin(theta)
    r = np.eye(dim)
    r[:2, :2] = ((c, -s), (s, c))
    return r


def shaped(offsets: FloatArray, *, sigma: float, theta: float) -> FloatArray:
    """Desired offsets under Remark 2: R(θ) δ / σ, for (dim,) or (k, dim) offsets in m.

    R(θ)δ written out, (x·c + y·(−s), x·s + y·c[, z]), rather than a matrix product, which
    numpy leaves to BLAS (see the module's docstring)."""
    c, s = math.cos(theta), math.sin(theta)
    out = np.array(offsets, dtype=np.float64, copy=True)
    x, y = offsets[..., 0], offsets[..., 1]
    out[..., 0] = x * c + y * -s
    out[..., 1] = x * s + y * c
    return out / sigma


def shaped_vector(offset: Sequence[float], *, sigma: float, theta: float) -> Vector:
    """:func:`shaped` of one (dim,) offset, in plain floats, to the same bits."""
    c, s = math.cos(theta), math.sin(theta)
    x, y = offset[0], offset[1]
    return ((x * c + y * -s) / sigma, (x * s + y * c) / sigma, *[z / sigma for z in offset[2:]])
