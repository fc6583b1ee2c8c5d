"""Real robots in place of the world's kinematics (issue 33; docs/ros2.md): what the world needs
of them, as a protocol, so that the world's loop stays the same whether it integrates its own
kinematics or drives robots (tools/ros2/bridge.py drives ROS 2 robots over rmw_zenoh).

Each tick the world asks a :class:`Plant` where every agent's point is (a unicycle's is l ahead of
its axle) and which robots' poses are too old to trust (those are held still, as a robot whose
command is stale is); after the safety layer, it hands the plant the tick's velocities (the log
records each tick what the robots reported and what they were sent); at the end of the run, on
Ctrl-C and when the leader is lost, it stops every robot.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Protocol

from shoal.bus.geometry import FloatArray


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

    def send(self, velocities: FloatArray, headings: FloatArray | None) -> FloatArray:
        """Drive each agent's point at ``velocities`` (n, dim) m/s for a tick, from the
        ``headings`` last observed; what each robot was sent, (n, 3): linear x, linear y,
        angular z in its own frame (the log records it)."""

    def stop(self) -> None:
        """A zero command to every robot."""

    def report(self) -> dict[str, Any]:
        """Summary entries: what was heard, dropped and sent."""
