"""What moves the agents' bodies, as a protocol, so that one tick (world/step.py) serves whether
the world integrates its own kinematics (:class:`Kinematics`) or drives real robots
(tools/ros2/bridge.py drives ROS 2 robots over rmw_zenoh; docs/ros2.md).

Each tick the world asks a :class:`Plant` where every agent's point is (a unicycle's is l ahead of
its axle) and which robots' poses are too old to trust (those are held still, as a robot whose
command is stale is); after the safety layer, it hands the plant the tick's velocities (the log
records each tick what the robots reported and what they were sent); at the end of the run, on
Ctrl-C and when the leader is lost, it stops every robot.
"""

from __future__ import annotations

import importlib.util
from dataclasses import dataclass, replace
from typing import Any, Protocol

from shoal.bus.messages import PlantRecord
from shoal.bus.types import AgentConfig, Vector, Waypoints
from shoal.geometry.vectors import FloatArray
from shoal.world.kinematics import move
from shoal.world.scenario import Scenario

KINEMATICS, MUJOCO = "kinematics", "mujoco"
PLANTS = (KINEMATICS, MUJOCO)  # what --plant chooses from: simulated plants, owning their time

# The moving obstacles' centres at a tick's start and at its end, in scenario order: a plant
# with bodies in it (world/physics/) walks them along the straight step between.
Movers = tuple[tuple[Vector, ...], tuple[Vector, ...]]


class PlantError(RuntimeError):
    """The robots cannot be driven (one never reported a pose, say), with what to check."""


@dataclass(frozen=True)
class Observed:
    """Where the agents are at a tick's start: ``positions`` (n, dim) of their points, m;
    ``headings`` (n,) rad for unicycles (None when every agent is holonomic); ``stale``: the
    agents (1-based) whose robot's last pose is older than the plant's limit; ``ages`` (n,) s:
    how old each robot's pose is now (None when the plant cannot tell); ``velocities`` (n, dim)
    m/s: each point's velocity measured with its pose (None when the plant does not say)."""

    positions: FloatArray
    headings: FloatArray | None
    stale: frozenset[int]
    ages: FloatArray | None = None
    velocities: FloatArray | None = None


class Plant(Protocol):
    # True: the plant owns simulated time (one tick per send, whatever the wall clock does), so
    # it serves a lockstep run; False: robots that move on the wall clock.
    simulated: bool

    def wait_ready(self, timeout: float) -> None:
        """Block until every robot has reported a pose; :class:`PlantError` naming those that
        did not within ``timeout`` s."""

    def observe(self) -> Observed:
        """Every agent's point now."""

    def send(
        self, velocities: FloatArray, headings: FloatArray | None, movers: Movers | None = None
    ) -> FloatArray | None:
        """Drive each agent's point at ``velocities`` (n, dim) m/s for a tick, from the
        ``headings`` last observed, while the people walk ``movers``; what each robot was sent,
        (n, 3): linear x, linear y, angular z in its own frame (the log records it), or None
        for a simulated plant."""

    def stop(self) -> None:
        """A zero command to every robot."""

    def report(self) -> dict[str, Any]:
        """Summary entries: what was heard, dropped and sent."""

    def record(self, tick: int) -> PlantRecord | None:
        """What the plant's bodies did over tick ``tick`` (just sent), for the log: a physics
        plant's bodies, motors and contacts; None for the others."""


def bodily(config: AgentConfig) -> AgentConfig:
    """Agent ``config`` for a run whose plant moves bodies (robots, or a physics engine): its
    leader counts a waypoint as visited within a tick's travel at the path's speed, the finest
    that commands held for a tick place a body. Within 1 nm, as the kinematics place it, late
    poses made the leader overshoot its first corner and be sent back for the rest of the run
    (tests/agent/test_leader.py), and a base with mass circles it for good: commands it can
    follow at its braking overshoot by v²/2a and come back (docs/physics.md)."""
    path = config.path
    if not isinstance(path, Waypoints):
        return config
    return replace(config, path=replace(path, reach=path.speed * config.dt))


class Kinematics:
    """The world's own kinematics as a plant: single integrators, unicycles along their exact
    arcs, or a mix (world/unicycle.py), moved by exactly one tick of simulated time per
    :meth:`send`, whatever the wall clock does, so a lockstep run stays deterministic.
    ``lookaheads`` (n,) m: each unicycle's l (0 for a mixed formation's single integrators;
    None: every agent a single integrator); ``headings`` (n,) rad at the start."""

    simulated = True

    def __init__(
        self,
        positions: FloatArray,
        headings: FloatArray | None,
        lookaheads: FloatArray | None,
        dt: float,
    ) -> None:
        self.positions = positions
        self.headings = headings if lookaheads is not None else None
        self.lookaheads = lookaheads
        self.dt = dt

    def wait_ready(self, timeout: float) -> None:
        return None

    def observe(self) -> Observed:
        return Observed(self.positions, self.headings, frozenset())

    def send(
        self, velocities: FloatArray, headings: FloatArray | None, movers: Movers | None = None
    ) -> None:
        self.positions, self.headings = move(
            self.positions, self.headings, velocities, self.lookaheads, self.dt
        )

    def stop(self) -> None:
        return None

    def report(self) -> dict[str, Any]:
        return {}

    def record(self, tick: int) -> None:
        return None


def simulated(scenario: Scenario, plant: str = KINEMATICS, dynamics: str | None = None) -> Plant:
    """The simulated plant called ``plant`` for ``scenario``: the world's own kinematics, or
    MuJoCo moving robots with mass (world/physics/, the ``physics`` extra) as the scenario's
    ``dynamics:`` section says, its preset replaced by ``dynamics`` if given."""
    if plant == KINEMATICS:
        if dynamics is not None:
            raise PlantError("--dynamics is for robots with mass: add --plant mujoco")
        s = scenario
        return Kinematics(s.initial_positions, s.initial_headings, s.lookaheads, s.dt)
    if plant != MUJOCO:
        raise PlantError(f"unknown plant {plant!r}: one of {', '.join(PLANTS)}")
    if importlib.util.find_spec("mujoco") is None:
        raise PlantError("--plant mujoco needs MuJoCo: pip install 'shoal[physics]'")
    from shoal.world.physics.engine import Engine

    return Engine(scenario, scenario.robot_dynamics(dynamics))
