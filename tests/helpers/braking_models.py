"""Reference models of robots with mass for the reach layer's tests: not the physics plant, and
not the layer's own arithmetic — a point whose velocity loop is simulated in fine substeps.

A robot told u_j at tick j acts on it ``latency`` s later; its velocity w then follows the
command in force c through a first-order loop of time constant ``lag`` s whose acceleration is
clipped at ``accel`` m/s² (``lag`` 0: it accelerates at ``accel`` straight at c), or, with
``integral``, through a PI loop of time constant ``lag`` tuned as the physics plant's. Its pose
reaches its layer ``age`` s late, drawn afresh each tick up to a bound. Positions are kept at
every substep, so a breach between ticks is seen.
"""

from __future__ import annotations

import math
import random
from dataclasses import dataclass, field

import numpy as np

from shoal.bus.messages import Sensing
from shoal.geometry.vectors import FloatArray
from shoal.world.plant import Observed

SUBSTEPS = 20  # per tick


@dataclass
class Fleet:
    """Point robots with mass in a field of standing obstacles (see the module docstring)."""

    positions: FloatArray  # (n, dim) m, now
    dt: float
    latency: float
    accel: float
    lag: float
    max_age: float  # s: each tick's pose is up to this old
    rng: random.Random
    integral: bool = False  # a PI loop (kp = 2/lag, ki = 1/lag² per unit mass), as the engine's
    velocities: FloatArray = field(init=False)  # (n, dim) m/s, now
    history: list[FloatArray] = field(init=False)  # positions at every substep so far
    speeds: list[FloatArray] = field(init=False)  # velocities at every substep so far
    commands: list[FloatArray] = field(init=False)  # what each tick sent, (n, dim)

    def __post_init__(self) -> None:
        self.velocities = np.zeros_like(self.positions)
        self.memory = np.zeros_like(self.positions)  # the PI loop's integral of the error
        self.history = [self.positions.copy()]
        self.speeds = [self.velocities.copy()]
        self.commands = []

    @property
    def h(self) -> float:
        return self.dt / SUBSTEPS

    def observe(self, k: int, measured: bool) -> tuple[Observed, FloatArray]:
        """Tick ``k``'s poses (and velocities if ``measured``), each up to ``max_age`` old, in
        whole substeps; with the ages themselves."""
        n = len(self.positions)
        back = [self.rng.randint(0, int(self.max_age / self.h + 1e-9)) for _ in range(n)]
        back = [min(b, len(self.history) - 1) for b in back]
        poses = np.array([self.history[-1 - b][i] for i, b in enumerate(back)])
        vels = np.array([self.speeds[-1 - b][i] for i, b in enumerate(back)])
        ages = np.array([b * self.h for b in back])
        seen = Observed(poses, None, frozenset(), ages=ages, velocities=vels if measured else None)
        return seen, poses

    def _in_force(self, t: float) -> FloatArray:
        j = math.floor((t - self.latency) / self.dt + 1e-9)
        if j < 0 or not self.commands:
            return np.zeros_like(self.positions)
        return self.commands[min(j, len(self.commands) - 1)]

    def advance(self, k: int, commands: FloatArray) -> None:
        """Move every robot over tick ``k`` with ``commands`` sent at its start."""
        self.commands.append(commands.copy())
        h = self.h
        for s in range(SUBSTEPS):
            t = k * self.dt + s * h
            c = self._in_force(t + 1e-12)
            error = c - self.velocities
            size = np.linalg.norm(error, axis=1, keepdims=True)
            if self.integral:  # a PI loop, its force's norm clipped, no integration then
                raw = error * (2.0 / self.lag) + self.memory / (self.lag * self.lag)
                norm = np.linalg.norm(raw, axis=1, keepdims=True)
                acc = raw * np.minimum(1.0, self.accel / np.maximum(norm, 1e-300))
                self.memory = self.memory + np.where(norm > self.accel, 0.0, error * h)
                self.positions = self.positions + self.velocities * h + acc * (h * h / 2.0)
                self.velocities = self.velocities + acc * h
            elif self.lag == 0.0:  # at a straight at c until it is reached, then at c
                unit = error / np.where(size > 0.0, size, 1.0)
                reach = np.minimum(size / self.accel, h)  # s of the substep spent accelerating
                acc = unit * self.accel
                self.positions = (
                    self.positions + self.velocities * h + acc * reach * reach / 2.0
                    + acc * reach * (h - reach)
                )  # fmt: skip
                self.velocities = self.velocities + acc * reach
            else:
                want = error / self.lag
                norm = np.linalg.norm(want, axis=1, keepdims=True)
                acc = np.where(
                    norm > self.accel, want * (self.accel / np.maximum(norm, 1e-300)), want
                )
                self.positions = self.positions + self.velocities * h + acc * (h * h / 2.0)
                self.velocities = self.velocities + acc * h
            self.history.append(self.positions.copy())
            self.speeds.append(self.velocities.copy())


def sensings(k: int, poses: FloatArray, centres: FloatArray, radii: FloatArray) -> list[Sensing]:
    """Every robot's sensing from its pose: every obstacle, every other robot's pose."""
    n = len(poses)
    ids = tuple(range(len(radii)))
    out = []
    for i in range(n):
        others = tuple(j + 1 for j in range(n) if j != i)
        out.append(
            Sensing(
                tick=k,
                position=tuple(poses[i].tolist()),
                obstacle_ids=ids,
                obstacle_centres=tuple(map(tuple, centres.tolist())),
                obstacle_radii=tuple(radii.tolist()),
                agent_ids=others,
                agent_positions=tuple(tuple(poses[j - 1].tolist()) for j in others),
            )
        )
    return out


def least_margins(
    history: list[FloatArray], centres: FloatArray, radii: FloatArray, rho: float, two_r: float
) -> tuple[float, float]:
    """(least distance beyond every guard r + ρ, least distance beyond 2R between any pair), m,
    over every substep of ``history``."""
    path = np.array(history)  # (steps, n, dim)
    to_obstacles = np.linalg.norm(path[:, :, None, :] - centres[None, None], axis=3) - radii
    guard = float((to_obstacles - rho).min()) if len(radii) else math.inf
    n = path.shape[1]
    pair = math.inf
    for a in range(n):
        for b in range(a):
            pair = min(pair, float(np.linalg.norm(path[:, a] - path[:, b], axis=1).min()) - two_r)
    return guard, pair
