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

from shoal.bus.messages import TickRecord
from shoal.geometry.vectors import FloatArray
from shoal.world.unicycle import Lookahead
from shoal.world.unicycle import step as unicycle_step


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
    headings : (T+1, n) rad, every unicycle's heading at the start of every tick and after the
        last; None for single integrators (and then not part of :meth:`arrays`).
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
    headings: FloatArray | None = None

    @classmethod
    def from_records(
        cls, records: Sequence[TickRecord], dt: float, lookahead: Lookahead | None = None
    ) -> Trajectory:
        """The world's tick records (in tick order) as a trajectory; the positions after the
        last record are integrated exactly as the world does (positions + dt · velocities;
        for unicycles, whose records carry headings, their arcs with ``lookahead`` l)."""
        first = records[0]
        n, dim = len(first.positions), len(first.positions[0])
        if first.headings and lookahead is None:
            raise ValueError("tick records of unicycles: give their lookahead")
        recorder = Recorder(
            dt, n, dim, len(records), movers=len(first.mover_centres),
            lookahead=lookahead if first.headings else None,
        )  # fmt: skip
        for r in records:
            recorder.record(r)
        return recorder.finish()

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
                headings=z.get("headings"),
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
        with moving obstacles, then ``headings`` in a run of unicycles."""
        names = self.ARRAYS if self.movers is None else (*self.ARRAYS, *self.MOVER_ARRAYS)
        return names if self.headings is None else (*names, "headings")

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


class Recorder:
    """Builds a :class:`Trajectory` tick by tick, the one way every run is recorded (the
    reference simulator, the world process, a log's tick records). Arrays are allocated for
    ``steps`` ticks; a run that ends early keeps the ticks it recorded. ``movers``: how many
    moving obstacles the run has (0: the trajectory has no mover arrays)."""

    def __init__(
        self,
        dt: float,
        n: int,
        dim: int,
        steps: int,
        *,
        movers: int = 0,
        lookahead: Lookahead | None = None,
    ) -> None:
        self.dt = dt
        self.ticks = 0
        self._positions = np.empty((steps + 1, n, dim))
        self._velocities = np.empty((steps, n, dim))
        self._omega = np.zeros((steps, n), dtype=bool)
        self._filtered = np.zeros((steps, n), dtype=bool)
        self._bid, self._sigma, self._theta = (np.empty((steps, n)) for _ in range(3))
        self._movers = np.empty((steps + 1, movers, dim)) if movers else None
        self._mover_velocities = np.empty((steps, movers, dim)) if movers else None
        self.lookahead = lookahead  # unicycles: their headings are recorded too
        self._headings = np.empty((steps + 1, n)) if lookahead is not None else None

    def add(
        self,
        positions: Any,
        velocities: Any,
        announced: tuple[Sequence[bool], Sequence[float], Sequence[float], Sequence[float]],
        filtered: Sequence[bool],
        mover_centres: Any = (),
        mover_velocities: Any = (),
        headings: Any = (),
    ) -> None:
        """The next tick: positions (n, dim) at its start, velocities (n, dim) held during it,
        what the agents announced as (Ω, bid, σ, θ), each in agent order, where each agent's
        filter was active, and
        the moving obstacles' centres at its start and velocities over it."""
        k = self.ticks
        self._positions[k] = positions
        self._velocities[k] = velocities
        self._filtered[k] = filtered
        self._omega[k], self._bid[k], self._sigma[k], self._theta[k] = announced
        if self._movers is not None and self._mover_velocities is not None:
            self._movers[k] = mover_centres
            self._mover_velocities[k] = mover_velocities
        if self._headings is not None:
            self._headings[k] = headings
        self.ticks = k + 1

    def record(self, r: TickRecord) -> None:
        """The next tick from the world's record of it."""
        announced = (r.omega, r.bid, r.sigma, r.theta)
        self.add(r.positions, r.velocities, announced, r.filtered,
                 r.mover_centres, r.mover_velocities, r.headings)  # fmt: skip

    def finish(self, positions: Any = None, movers: Any = None, headings: Any = None) -> Trajectory:
        """The trajectory of the ticks added. ``positions`` (n, dim) and ``movers`` (m, dim):
        where the agents and the moving obstacles are after the last tick; None integrates
        them from the last tick (start + dt · velocity), as the world does for single
        integrators and obstacles; ``headings`` (n,): the unicycles' after the last tick (None:
        integrated from the tick records' positions and velocities, as the world does)."""
        k = self.ticks
        if k == 0:
            raise ValueError("a trajectory needs at least one tick")
        dt = self.dt
        if self._headings is not None and self.lookahead is not None and headings is None:
            last = self._positions[k - 1], self._headings[k - 1], self._velocities[k - 1]
            positions, headings = unicycle_step(*last, self.lookahead, dt)
        self._positions[k] = (
            self._positions[k - 1] + dt * self._velocities[k - 1]
            if positions is None
            else positions
        )
        mover_arrays: dict[str, FloatArray] = {}
        if self._movers is not None and self._mover_velocities is not None:
            self._movers[k] = (
                self._movers[k - 1] + dt * self._mover_velocities[k - 1]
                if movers is None
                else movers
            )
            mover_arrays = {
                "movers": self._movers[: k + 1], "mover_velocities": self._mover_velocities[:k]
            }  # fmt: skip
        if self._headings is not None:
            self._headings[k] = headings
            mover_arrays["headings"] = self._headings[: k + 1]
        return Trajectory(
            dt=dt,
            positions=self._positions[: k + 1],
            velocities=self._velocities[:k],
            omega=self._omega[:k],
            bid=self._bid[:k],
            sigma=self._sigma[:k],
            theta=self._theta[:k],
            filtered=self._filtered[:k],
            **mover_arrays,
        )
