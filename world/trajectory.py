"""The record of a run: everything the metrics and the figures are computed from.

Shapes use T = number of ticks, n = agents, dim = 2 or 3. Tick k covers [k·dt, (k+1)·dt).
"""

from __future__ import annotations

import hashlib
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, BinaryIO, ClassVar

import numpy as np
from numpy.typing import NDArray

from shoal.bus.geometry import FloatArray
from shoal.bus.types import TickRecord


@dataclass(frozen=True)
class Trajectory:
    """positions : (T+1, n, dim) m, at the start of every tick and after the last.
    velocities : (T, n, dim) m/s, commanded during each tick.
    omega : (T, n) bool, Ω_i announced at each tick.
    bid : (T, n), each agent's value in Algorithm 1 as announced at each tick.
    sigma, theta : (T, n), the scale and rotation (rad) each agent applied at each tick.
    filtered : (T, n) bool, True where the agent's safety filter changed its nominal velocity.
    """

    dt: float
    positions: FloatArray
    velocities: FloatArray
    omega: NDArray[np.bool_]
    bid: FloatArray
    sigma: FloatArray
    theta: FloatArray
    filtered: NDArray[np.bool_]

    @classmethod
    def from_records(cls, records: Sequence[TickRecord], dt: float) -> Trajectory:
        """The world's tick records (in tick order) as a trajectory; the positions after the
        last record are integrated exactly as the world does (positions + dt · velocities)."""
        positions = np.asarray([r.positions for r in records], dtype=np.float64)
        velocities = np.asarray([r.velocities for r in records], dtype=np.float64)
        return cls(
            dt=dt,
            positions=np.concatenate([positions, (positions[-1] + dt * velocities[-1])[None]]),
            velocities=velocities,
            omega=np.asarray([r.omega for r in records], dtype=bool),
            bid=np.asarray([r.bid for r in records], dtype=np.float64),
            sigma=np.asarray([r.sigma for r in records], dtype=np.float64),
            theta=np.asarray([r.theta for r in records], dtype=np.float64),
            filtered=np.asarray([r.filtered for r in records], dtype=bool),
        )

    @property
    def ticks(self) -> int:
        return int(self.velocities.shape[0])

    def save(self, path: Path) -> None:
        """Write an .npz file (uncompressed, exact float64) at exactly ``path``, whole or not at
        all: it is written beside it and renamed into place."""
        part = path.with_name(path.name + ".part")
        with part.open("wb") as f:  # a file object: numpy appends no ".npz" to the name
            self._write(f)
        os.replace(part, path)

    def _write(self, f: BinaryIO) -> None:
        np.savez(
            f,
            dt=np.float64(self.dt),
            positions=self.positions,
            velocities=self.velocities,
            omega=self.omega,
            bid=self.bid,
            sigma=self.sigma,
            theta=self.theta,
            filtered=self.filtered,
        )

    @classmethod
    def load(cls, path: Path) -> Trajectory:
        with np.load(path) as z:
            return cls(
                dt=float(z["dt"]),
                positions=z["positions"],
                velocities=z["velocities"],
                omega=z["omega"],
                bid=z["bid"],
                sigma=z["sigma"],
                theta=z["theta"],
                filtered=z["filtered"],
            )

    ARRAYS: ClassVar[tuple[str, ...]] = (
        "positions",
        "velocities",
        "omega",
        "bid",
        "sigma",
        "theta",
        "filtered",
    )

    def arrays(self) -> tuple[NDArray[Any], ...]:
        """Every recorded array, in :data:`ARRAYS` order."""
        return tuple(getattr(self, k) for k in self.ARRAYS)

    def digest(self) -> str:
        """A short hash of every array's bytes: equal digests, equal runs (bit for bit)."""
        h = hashlib.sha256()
        for a in self.arrays():
            h.update(a.tobytes())
        return h.hexdigest()[:16]

    def equals(self, other: Trajectory) -> bool:
        """Bit-for-bit equality of every array."""
        return self.dt == other.dt and all(
            a.shape == b.shape and a.tobytes() == b.tobytes()
            for a, b in zip(self.arrays(), other.arrays(), strict=True)
        )
