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
from shoal.bus.messages import TickRecord


@dataclass(frozen=True)
class Trajectory:
    """positions : (T+1, n, dim) m, at the start of every tick and after the last.
    velocities : (T, n, dim) m/s, commanded during each tick.
    omega : (T, n) bool, Ω_i announced at each tick.
    bid : (T, n), each agent's value in Algorithm 1 as announced at each tick.
    sigma, theta : (T, n), the scale and rotation (rad) each agent applied at each tick.
    filtered : (T, n) bool, True where the agent's safety filter changed its nominal velocity.
    movers : (T+1, m, dim) m, every moving obstacle's centre at the start of every tick and
        after the last, in scenario order; mover_velocities : (T, m, dim) m/s, held over each
        tick. Both None in a run where nothing moves (and then not part of :meth:`arrays`).
    """

    dt: float
    positions: FloatArray
    velocities: FloatArray
    omega: NDArray[np.bool_]
    bid: FloatArray
    sigma: FloatArray
    theta: FloatArray
    filtered: NDArray[np.bool_]
    movers: FloatArray | None = None
    mover_velocities: FloatArray | None = None

    @classmethod
    def from_records(cls, records: Sequence[TickRecord], dt: float) -> Trajectory:
        """The world's tick records (in tick order) as a trajectory; the positions after the
        last record are integrated exactly as the world does (positions + dt · velocities)."""
        positions = np.asarray([r.positions for r in records], dtype=np.float64)
        velocities = np.asarray([r.velocities for r in records], dtype=np.float64)
        movers = mover_velocities = None
        if records[0].mover_centres:
            centres = np.asarray([r.mover_centres for r in records], dtype=np.float64)
            mover_velocities = np.asarray([r.mover_velocities for r in records], dtype=np.float64)
            movers = np.concatenate([centres, (centres[-1] + dt * mover_velocities[-1])[None]])
        return cls(
            dt=dt,
            positions=np.concatenate([positions, (positions[-1] + dt * velocities[-1])[None]]),
            velocities=velocities,
            omega=np.asarray([r.omega for r in records], dtype=bool),
            bid=np.asarray([r.bid for r in records], dtype=np.float64),
            sigma=np.asarray([r.sigma for r in records], dtype=np.float64),
            theta=np.asarray([r.theta for r in records], dtype=np.float64),
            filtered=np.asarray([r.filtered for r in records], dtype=bool),
            movers=movers,
            mover_velocities=mover_velocities,
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
        arrays: dict[str, Any] = dict(zip(self.names(), self.arrays(), strict=True))
        np.savez(f, dt=np.float64(self.dt), **arrays)

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
                movers=z.get("movers"),
                mover_velocities=z.get("mover_velocities"),
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

    MOVER_ARRAYS: ClassVar[tuple[str, ...]] = ("movers", "mover_velocities")

    def names(self) -> tuple[str, ...]:
        """The names of :meth:`arrays`: :data:`ARRAYS`, then :data:`MOVER_ARRAYS` in a run
        with moving obstacles."""
        return self.ARRAYS if self.movers is None else (*self.ARRAYS, *self.MOVER_ARRAYS)

    def arrays(self) -> tuple[NDArray[Any], ...]:
        """Every recorded array, in :meth:`names` order."""
        return tuple(getattr(self, k) for k in self.names())

    def digest(self) -> str:
        """A short hash of every array's bytes: equal digests, equal runs (bit for bit)."""
        h = hashlib.sha256()
        for a in self.arrays():
            h.update(a.tobytes())
        return h.hexdigest()[:16]

    def equals(self, other: Trajectory) -> bool:
        """Bit-for-bit equality of every array."""
        return (
            self.dt == other.dt
            and self.names() == other.names()
            and all(
                a.shape == b.shape and a.tobytes() == b.tobytes()
                for a, b in zip(self.arrays(), other.arrays(), strict=True)
            )
        )
