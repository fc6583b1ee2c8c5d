"""One tick of a run, written once: sense → the tick's commands → the safety layer → the body →
the record.

A :class:`Step` is configured once per run with its scenario, its safety layer
(world/layers.py) and its plant (world/plant.py: the world's own kinematics, or robots), and
driven by two loops that differ only in where the commands come from: the world process
(world/process.py) collects them from the agents over the bus, the reference simulator
(tools/simulator.py) asks each agent's controller in turn. Both call :meth:`Step.sense`, then
:meth:`Step.act` with the commands, on the same float64 values in the same order, so a
lockstep run equals the reference bit for bit.

Arrays at this boundary: positions and velocities (n, dim) float64, m and m/s; headings (n,)
rad. Commands come in as the agents' messages; the tick goes out as one :class:`TickRecord`.
"""

from __future__ import annotations

from collections.abc import Collection, Mapping

import numpy as np

from shoal.bus.messages import AgentState, Command, Sensing, TickRecord
from shoal.geometry.vectors import FloatArray
from shoal.world.layers import Layer
from shoal.world.movers import MoverState
from shoal.world.obstacles import Obstacles
from shoal.world.plant import Observed, Plant
from shoal.world.scenario import Scenario
from shoal.world.trajectory import Recorder, Trajectory

# What an agent said at a tick: the state it announced and the command it sent.
Report = tuple[AgentState, Command]
# Per agent: Ω, σ bid, σ, θ announced, and whether its own filter changed its command.
Said = tuple[list[bool], list[float], list[float], list[float], list[bool]]


class Step:
    """A run's tick, configured once. Between :meth:`sense` and :meth:`act` the driver gets the
    tick's commands; ``seen`` is where the plant reported the agents at the tick's start,
    ``sensings`` what each agent senses then, ``newly_stale`` the robots whose pose went stale
    at this tick, ``sent`` what the plant sent the robots (None for a simulated plant)."""

    def __init__(self, scenario: Scenario, layer: Layer, plant: Plant) -> None:
        s = scenario
        self.n, self.radius = s.n, s.control.sensing_radius
        self.standing: tuple[float, ...] = (0.0,) * s.dim  # the command of an agent with none
        self.layer, self.plant = layer, plant
        self.obstacles = Obstacles.of(s)
        self.crowd = self.obstacles.start(s)
        self.recorder = Recorder(
            s.dt, s.n, s.dim, s.steps, movers=len(s.mover_ids), lookahead=s.lookaheads
        )
        self.seen = Observed(s.initial_positions, s.initial_headings, frozenset())
        self.sensings: list[Sensing] = []
        self.newly_stale: frozenset[int] = frozenset()
        self.sent: FloatArray | None = None
        self.pose_holds = 0  # robot-ticks held still because the robot's own pose was too old

    def sense(self, k: int) -> list[Sensing]:
        """The start of tick ``k``: where the plant has the agents, and each one's sensing."""
        seen = self.plant.observe()
        self.newly_stale = seen.stale - self.seen.stale
        self.seen = seen
        self.crowd, self.sensings = self.obstacles.sense(
            k, seen.positions, self.crowd, self.radius, seen.headings
        )
        return self.sensings

    def act(self, k: int, reports: Mapping[int, Report]) -> None:
        """The rest of tick ``k``: ``reports`` (agent id → its state and command for the tick;
        an agent without one stands) through the safety layer to the plant, and into the
        trajectory."""
        self._apply(k, reports)

    def act_recorded(
        self, k: int, reports: Mapping[int, Report], alive: Collection[int]
    ) -> TickRecord:
        """:meth:`act`, and the tick's record (``alive``: the agents still in the run)."""
        velocities, said, crowd = self._apply(k, reports)
        return _record(k, self.seen, velocities, said, alive, crowd)

    def _apply(self, k: int, reports: Mapping[int, Report]) -> tuple[FloatArray, Said, MoverState]:
        seen, crowd = self.seen, self.crowd
        said = _said(reports, seen.stale, self.n)
        rows = [self.standing] * self.n
        for i, (_state, command) in reports.items():
            if i not in seen.stale:  # a robot not seen stands, and says nothing this tick
                rows[i - 1] = command.velocity
        commanded: FloatArray = np.array(rows, dtype=np.float64)
        velocities = self.layer.act(k, self.sensings, commanded, seen)
        for i in seen.stale:  # whatever a layer made of it: a robot not seen stands
            velocities[i - 1] = 0.0
        self.pose_holds += len(seen.stale)
        headings = () if seen.headings is None else seen.headings
        self.recorder.add(seen.positions, velocities, said[:4], said[4],
                          crowd.centres, crowd.velocities, headings)  # fmt: skip
        self.crowd = self.obstacles.advance(crowd)
        walked = (crowd.centres, self.crowd.centres) if self.obstacles.moving else None
        self.sent = self.plant.send(velocities, seen.headings, walked)
        return velocities, said, crowd

    def finish(self) -> Trajectory:
        """Stop the plant and return the run's trajectory, to where the agents ended."""
        self.plant.stop()
        seen = self.plant.observe()
        return self.recorder.finish(seen.positions, self.crowd.centres, seen.headings)


def _said(reports: Mapping[int, Report], stale: frozenset[int], n: int) -> Said:
    """What each agent announced for the tick, (Ω, bid, σ, θ), and whether its own filter
    changed its command; an agent without a report (or whose robot is not seen) is taken as
    not evading, bidding 1, unscaled, unfiltered."""
    omega, bid, sigma, theta = [False] * n, [1.0] * n, [1.0] * n, [0.0] * n
    filtered = [False] * n
    for i, (state, command) in reports.items():
        if i not in stale:
            omega[i - 1], bid[i - 1] = state.omega, state.bid
            sigma[i - 1], theta[i - 1] = state.sigma, state.theta
            filtered[i - 1] = command.filtered
    return omega, bid, sigma, theta, filtered


def _record(
    k: int,
    seen: Observed,
    velocities: FloatArray,
    said: Said,
    alive: Collection[int],
    crowd: MoverState,
) -> TickRecord:
    """The ground truth of tick k, with the velocities the agents really hold during it (and
    for unicycles their headings at its start)."""
    omega, bid, sigma, theta, filtered = said
    headings = seen.headings
    return TickRecord(
        tick=k,
        positions=tuple(map(tuple, seen.positions.tolist())),
        velocities=tuple(map(tuple, velocities.tolist())),
        omega=tuple(omega),
        bid=tuple(bid),
        sigma=tuple(sigma),
        theta=tuple(theta),
        alive=tuple(i in alive for i in range(1, len(omega) + 1)),
        filtered=tuple(filtered),
        mover_centres=crowd.centres,
        mover_velocities=crowd.velocities,
        headings=() if headings is None else tuple(headings.tolist()),
    )
