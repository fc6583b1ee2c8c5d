"""The reference simulator: every agent and the world in one process, in lockstep.

It calls exactly what the distributed run calls: the world's ``Obstacles`` (moving obstacles),
``sense_all``, ``actuate`` and ``integrate`` and each agent's ``Controller.announce`` /
``Controller.act``, in the same order and on the same float64 values, so a lockstep run over
Zenoh must reproduce its trajectory bit for bit. setup.py compiles it with those modules: a
campaign spends most of its time in this loop.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Final

import numpy as np

from shoal.agent.controller import Controller
from shoal.bus.geometry import FloatArray
from shoal.bus.messages import AgentState, picklable
from shoal.world.kinematics import actuate, move
from shoal.world.movers import MoverState
from shoal.world.obstacles import Obstacles
from shoal.world.scenario import Scenario
from shoal.world.trajectory import Recorder, Trajectory

Progress = Callable[[int], None]


@dataclass(init=False, slots=True, eq=False)
class Tick:
    """One tick of a run: positions (n, dim) at its start, the states announced, the
    velocities (n, dim) held during it (after the world's safety layer, which in lockstep
    changes nothing), where each agent's filter was active (n,), the positions it ends at, and
    the moving obstacles over it (their centres at its start and velocities held); for
    unicycles their headings at its start and after it (else None)."""

    tick: Final[int]
    positions: Final[FloatArray]
    states: Final[tuple[AgentState, ...]]
    velocities: Final[FloatArray]
    filtered: Final[tuple[bool, ...]]
    next_positions: Final[FloatArray]
    movers: Final[MoverState]
    headings: Final[FloatArray | None]
    next_headings: Final[FloatArray | None]

    def __init__(
        self,
        tick: int,
        positions: FloatArray,
        states: tuple[AgentState, ...],
        velocities: FloatArray,
        filtered: tuple[bool, ...],
        next_positions: FloatArray,
        movers: MoverState,
        headings: FloatArray | None = None,
        next_headings: FloatArray | None = None,
    ) -> None:
        self.tick = tick
        self.positions = positions
        self.states = states
        self.velocities = velocities
        self.filtered = filtered
        self.next_positions = next_positions
        self.movers = movers
        self.headings = headings
        self.next_headings = next_headings


picklable(Tick)


def run(scenario: Scenario) -> Iterator[Tick]:
    """Yield every tick of ``scenario`` in order; stop iterating to stop the run early."""
    n = scenario.n
    controllers = [Controller(scenario.agent_config(i + 1)) for i in range(n)]
    memories = [c.start() for c in controllers]
    obstacles = Obstacles.of(scenario)
    crowd = obstacles.start(scenario)
    d = scenario.control.sensing_radius
    params = scenario.params()
    positions = scenario.initial_positions
    bodies = scenario.lookaheads  # unicycles: l per agent (0: a single integrator)
    headings = scenario.initial_headings if bodies is not None else None
    for k in range(scenario.steps):
        crowd, sensings = obstacles.sense(k, positions, crowd, d, headings)
        states: dict[int, AgentState] = {}
        for i, c in enumerate(controllers):
            memories[i], states[i + 1] = c.announce(memories[i], sensings[i])
        commanded = []
        filtered = []
        for i, c in enumerate(controllers):
            heard = {j: states[j] for j in c.listens_to}
            memories[i], command = c.act(memories[i], sensings[i], heard)
            commanded.append(command.velocity)
            filtered.append(command.filtered)
        velocities, _ = actuate(sensings, np.array(commanded), params, scenario.dt, scenario.limits)
        moved, turned = move(positions, headings, velocities, bodies, scenario.dt)
        ordered = tuple(states[i + 1] for i in range(n))
        yield Tick(
            k, positions, ordered, velocities, tuple(filtered), moved, crowd, headings, turned
        )
        positions, headings = moved, turned
        crowd = obstacles.advance(crowd)


def simulate(scenario: Scenario, *, progress: Progress | None = None) -> Trajectory:
    """Run ``scenario`` for all its ticks; ``progress(k)`` is called after each tick."""
    recorder = Recorder(
        scenario.dt,
        scenario.n,
        scenario.dim,
        scenario.steps,
        movers=len(scenario.mover_ids),
        lookahead=scenario.lookaheads,
    )
    after = scenario.initial_positions
    turned: FloatArray | None = scenario.initial_headings
    for t in run(scenario):
        states = t.states
        announced = (
            [s.omega for s in states], [s.bid for s in states],
            [s.sigma for s in states], [s.theta for s in states],
        )  # fmt: skip
        recorder.add(t.positions, t.velocities, announced, t.filtered,
                     t.movers.centres, t.movers.velocities, t.headings)  # fmt: skip
        after, turned = t.next_positions, t.next_headings
        if progress is not None:
            progress(t.tick)
    return recorder.finish(after, headings=turned)
