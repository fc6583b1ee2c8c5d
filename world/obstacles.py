"""A run's obstacles as the tick loop uses them: the standing ones as arrays for sensing, the
moving ones as a :class:`~shoal.world.movers.MoverState` stepped once per tick.

The world process and the reference simulator both drive a run through this class, in the
same order (plan → sense → act → integrate → advance), so they agree bit for bit.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from shoal.bus.messages import Mover, Sensing
from shoal.bus.types import Vector
from shoal.geometry.vectors import FloatArray
from shoal.world.kinematics import estimated, sense_all
from shoal.world.movers import Body, Motion, MoverState, advance, plan, start
from shoal.world.scenario import Scenario


@dataclass(frozen=True)
class Obstacles:
    """The obstacles of ``scenario``: ``centres``/``radii``/``ids`` of the standing ones and
    what moves the others (``motions``, in ``mover_ids`` order)."""

    centres: FloatArray
    radii: FloatArray
    ids: tuple[int, ...]
    mover_ids: tuple[int, ...]
    motions: tuple[Motion, ...]
    mover_radii: tuple[float, ...]
    agent_radius: float
    standing: tuple[Body, ...]
    dt: float
    biases: FloatArray | None = None  # (n, dim): each robot's position estimate's error

    @classmethod
    def of(cls, s: Scenario) -> Obstacles:
        movers = [s.obstacles[k] for k in s.mover_ids]
        return cls(
            centres=s.obstacle_centres,
            radii=s.obstacle_radii,
            ids=s.standing_ids,
            mover_ids=s.mover_ids,
            motions=tuple(o.motion for o in movers if o.motion is not None),
            mover_radii=tuple(o.radius for o in movers),
            agent_radius=s.agent_radius,
            standing=tuple(Body(o.centre, o.radius, wall=True) for o in s.standing),
            dt=s.dt,
            biases=s.position_biases,
        )

    @property
    def moving(self) -> bool:
        return bool(self.mover_ids)

    def start(self, s: Scenario) -> MoverState:
        """The moving obstacles before tick 0."""
        return start(self.motions, [s.obstacles[k].centre for k in self.mover_ids])

    def plan(self, state: MoverState, positions: FloatArray) -> MoverState:
        """``state`` with the velocity each moving obstacle holds over this tick, given the
        agents' ``positions`` (n, dim) at its start."""
        if not self.moving:
            return state
        agents: list[Vector] = [tuple(p) for p in positions.tolist()]
        return plan(
            self.motions, self.mover_radii, state, agents, self.agent_radius, self.standing, self.dt
        )

    def sense(
        self,
        tick: int,
        positions: FloatArray,
        state: MoverState,
        sensing_radius: float,
        headings: FloatArray | None = None,
    ) -> tuple[MoverState, list[Sensing]]:
        """The start of a tick, for the world and the reference alike: the moving obstacles'
        velocities over it (:meth:`plan`), then every agent's sensing of the standing and the
        moving obstacles and the other agents — as the robot knows them, with ``biases``
        (:func:`~shoal.world.kinematics.estimated`); unicycles' ``headings`` (n,), rad."""
        state = self.plan(state, positions)
        sensings = sense_all(
            tick, positions, self.centres, self.radii, sensing_radius,
            ids=self.ids, movers=self.sensed(state), headings=headings,
        )  # fmt: skip
        if self.biases is not None:
            sensings = estimated(sensings, self.biases)
        return state, sensings

    def advance(self, state: MoverState) -> MoverState:
        return advance(state, self.dt) if self.moving else state

    def sensed(self, state: MoverState) -> tuple[Mover, ...]:
        """Every moving obstacle as a sensor reports it (the truth: docs/people.md)."""
        return tuple(
            Mover(k, c, r, w, m.speed_cap)
            for k, c, r, w, m in zip(
                self.mover_ids, state.centres, self.mover_radii, state.velocities, self.motions,
                strict=True,
            )
        )  # fmt: skip


def centres_at(s: Scenario, movers: FloatArray | None, ticks: int) -> FloatArray:
    """(ticks, m, dim) the centre of every obstacle of ``s`` (scenario order) at every tick:
    standing ones where they stand, moving ones from ``movers`` (ticks, m_moving, dim)."""
    out = np.empty((ticks, len(s.obstacles), s.dim))
    for k, o in enumerate(s.obstacles):
        out[:, k] = o.centre
    if movers is not None:
        for q, k in enumerate(s.mover_ids):
            out[:, k] = movers[:ticks, q]
    return out
