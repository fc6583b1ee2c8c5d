"""Simulated ROS 2 robots with mass (``shoal robots --plant mujoco``): the fleet's drivers
(tools/ros2/fleet.py) backed by one MuJoCo engine (world/physics/engine.py) stepped on the
wall clock, so a lab can try the whole ROS 2 path on robots with mass before its own.

Each robot's driver takes its Twist as the engine's robot does (:meth:`Engine.hold`: a wheeled
robot's wheel speeds, a base's velocity; the robot's own command timeout stops it), and reports
the body's pose and measured velocity for its odometry. The engine runs as many 1 ms physics
steps as the wall clock has advanced, every robot at once, judged at every step as in any
physics run; when the machine cannot keep up, at most :data:`CATCH_UP` s are made up at once
and the rest is counted as lost (``lagged_s``), never silently.
"""

from __future__ import annotations

import dataclasses

from shoal.tools.ros2.fleet import Pose, Twist
from shoal.world.physics.engine import Engine
from shoal.world.scenario import Scenario

CATCH_UP = 0.25  # s of physics made up at once after a stall; the rest is lost and counted


class EngineBodies:
    """One engine for the whole fleet, on the wall clock from the first call."""

    def __init__(self, scenario: Scenario, dynamics: str | None, timeout: float) -> None:
        robots = tuple(
            dataclasses.replace(r, command_timeout=timeout)
            for r in scenario.robot_dynamics(dynamics)
        )
        self.engine = Engine(scenario, robots)
        self.start: float | None = None
        self.lagged_s = 0.0

    def advance(self, now: float) -> None:
        """Step the engine to ``now`` (s, monotonic)."""
        e = self.engine
        if self.start is None:
            self.start = now
        due = int((now - self.start) / e.timestep) - e.step_count
        most = int(CATCH_UP / e.timestep)
        if due > most:
            self.lagged_s += (due - most) * e.timestep
            self.start += (due - most) * e.timestep
            due = most
        if due > 0:
            e.run(due)

    def driver(self, agent: int) -> EngineDriver:
        return EngineDriver(self, agent)


class EngineDriver:
    """Robot ``agent`` (0-based) of ``bodies``, with the interface of the fleet's kinematic
    :class:`~shoal.tools.ros2.fleet.Driver`."""

    clamped = 0  # the engine's motors limit a command; nothing is clamped before them

    def __init__(self, bodies: EngineBodies, agent: int) -> None:
        self.bodies, self.agent = bodies, agent
        self.holonomic = agent not in bodies.engine.wheeled.tolist()

    def hear(self, twist: Twist, now: float) -> None:
        vx, vy, wz = twist
        self.bodies.advance(now)  # the old command holds until now
        self.bodies.engine.hold(self.agent, (vx, 0.0 if not self.holonomic else vy, wz))

    def advance(self, now: float) -> Pose:
        self.bodies.advance(now)
        x, y, yaw = self.bodies.engine.body_poses()[self.agent].tolist()
        return Pose(x, y, yaw)

    def moving(self, now: float) -> Twist:
        vx, vy, wz = self.bodies.engine.body_twists()[self.agent].tolist()
        return (vx, vy, wz)
