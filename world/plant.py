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

from dataclasses import dataclass
from typing import Any, Protocol

from shoal.geometry.vectors import FloatArray
from shoal.world.kinematics import move


class PlantError(RuntimeError):
    """The robots cannot be driven (one never reported a pose, say), with what to check."""


@dataclass(frozen=True)
class Observed:
    """Where the agents are at a tick's start: ``positions`` (n, dim) of their points, m;
    ``headings`` (n,) rad for unicycles (None when every agent is holonomic); ``stale``: the
    agents (1-based) whose robot's last pose is older than the plant's limit; ``ages`` (n,) s:
    how old each robot's pose is now (None when the plant cannot tell)."""

    positions: FloatArray
    headings: FloatArray | None
    stale: frozenset[int]
    ages: FloatArray | None = None


class Plant(Protocol):
    def wait_ready(self, timeout: float) -> None:
        """Block until every robot has reported a pose; :class:`PlantError` naming those that
        did not within ``timeout`` s."""

    def observe(self) -> Observed:
        """Every agent's point now."""

    def send(self, velocities: FloatArray, headings: FloatArray | None) -> FloatArray | None:
        """Drive each agent's point at ``velocities`` (n, dim) m/s for a tick, from the
        ``headings`` last observed; what each robot was sent, (n, 3): linear x, linear y,
        angular z in its own frame (the log records it), or None for a simulated plant."""

    def stop(self) -> None:
        """A zero command to every robot."""

    def report(self) -> dict[str, Any]:
        """Summary entries: what was heard, dropped and sent."""


class Kinematics:
    """The world's own kinematics as a plant: single integrators, unicycles along their exact
    arcs, or a mix (world/unicycle.py), moved by exactly one tick of simulated time per
    :meth:`send`, whatever the wall clock does, so a lockstep run stays deterministic.
    ``lookaheads`` (n,) m: each unicycle's l (0 for a mixed formation's single integrators;
    None: every agent a single integrator); ``headings`` (n,) rad at the start."""

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

    def send(self, velocities: FloatArray, headings: FloatArray | None) -> None:
        self.positions, self.headings = move(
            self.positions, self.headings, velocities, self.lookaheads, self.dt
        )

    def stop(self) -> None:
        return None

    def report(self) -> dict[str, Any]:
        return {}
