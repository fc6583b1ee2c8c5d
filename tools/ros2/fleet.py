"""Simulated ROS 2 robots (``shoal robots``): each takes ``geometry_msgs/msg/Twist`` on
``/<ns>/cmd_vel`` and publishes ``nav_msgs/msg/Odometry`` on ``/<ns>/odom``, over rmw_zenoh's
protocol (tools/ros2/node.py), as a TurtleBot's driver does: for users without robots, and for
the tests of the world as a bridge.

A robot's driver, as here: it clamps a command to its limits, holds the latest one, and stops
when none has come for ``timeout`` s (a real driver's cmd_vel timeout; docs/ros2.md). A ground
robot (a unicycle) takes linear x and angular z and drives the exact arc (world/unicycle.py's
``drive``, about its axle); a holonomic one also takes linear y, in its own frame.

:class:`Driver` is pure (a clock is passed in); :class:`Fleet` is the I/O around it.
"""

from __future__ import annotations

import math
import threading
import time
from dataclasses import dataclass, field

import numpy as np

from shoal.agent.latency import Delayer
from shoal.tools.ros2 import rmw
from shoal.tools.ros2.node import Heard, RosNode, RosPublisher, RosSession
from shoal.world.scenario import Scenario
from shoal.world.unicycle import drive


@dataclass(frozen=True)
class Pose:
    """Where a robot's body is: x, y in m, heading yaw in rad (in (−π, π])."""

    x: float
    y: float
    yaw: float


@dataclass(frozen=True)
class Limits:
    """What a robot's driver lets through: |linear| ≤ ``speed`` m/s, |angular z| ≤ ``turn``
    rad/s (math.inf: no limit)."""

    speed: float = math.inf
    turn: float = math.inf


@dataclass
class Driver:
    """One simulated robot's driver: its pose, the command in force, and when it was heard."""

    pose: Pose
    holonomic: bool
    timeout: float
    limits: Limits = field(default_factory=Limits)
    command: tuple[float, float, float] = (0.0, 0.0, 0.0)
    heard: float = -math.inf
    time: float | None = None  # the clock when the pose was last advanced
    clamped: int = 0

    def hear(self, twist: tuple[float, float, float], now: float) -> None:
        """Take a command (linear x, linear y, angular z) heard at ``now``: clamped to the
        limits; a unicycle's linear y is dropped (it cannot move sideways)."""
        vx, vy, wz = twist
        if not self.holonomic:
            vy = 0.0
        speed = math.hypot(vx, vy)
        if speed > self.limits.speed:
            vx, vy = vx * self.limits.speed / speed, vy * self.limits.speed / speed
        if abs(wz) > self.limits.turn:
            wz = math.copysign(self.limits.turn, wz)
        if (vx, vy, wz) != twist:
            self.clamped += 1
        self.advance(now)  # the old command holds until now
        self.command, self.heard = (vx, vy, wz), now

    def moving(self, now: float) -> tuple[float, float, float]:
        """The command in force at ``now``: zero once ``timeout`` s have passed without one."""
        return self.command if now - self.heard <= self.timeout else (0.0, 0.0, 0.0)

    def advance(self, now: float) -> Pose:
        """The pose at ``now``, the command in force driven since the last call (up to its
        timeout, then standing)."""
        if self.time is None or now <= self.time:
            self.time = now if self.time is None else self.time
            return self.pose
        end = min(now, self.heard + self.timeout)
        if end > self.time:
            self.pose = _moved(self.pose, self.command, end - self.time, self.holonomic)
        self.time = now
        return self.pose


Twist = tuple[float, float, float]  # linear x, linear y, angular z


def _moved(pose: Pose, command: Twist, elapsed: float, holonomic: bool) -> Pose:
    vx, vy, wz = command
    if holonomic:
        c, s = math.cos(pose.yaw), math.sin(pose.yaw)
        x = pose.x + elapsed * (c * vx - s * vy)
        y = pose.y + elapsed * (s * vx + c * vy)
        return Pose(x, y, _wrap(pose.yaw + wz * elapsed))
    points, headings = drive(
        np.array([[pose.x, pose.y]]), np.array([pose.yaw]), np.array([vx]), np.array([wz]),
        0.0, elapsed,
    )  # fmt: skip
    return Pose(float(points[0, 0]), float(points[0, 1]), _wrap(float(headings[0])))


def _wrap(angle: float) -> float:
    return math.atan2(math.sin(angle), math.cos(angle))


def drivers_for(scn: Scenario, count: int | None = None, timeout: float = 0.5) -> list[Driver]:
    """One driver per agent of ``scn`` (the first ``count``), each body where its agent starts:
    a unicycle's axle l behind its point, at its heading, limited as the scenario's robots; a
    single integrator as a holonomic robot facing +x. Only plane scenarios: ROS 2 ground
    robots drive in the plane."""
    if scn.dim != 2:
        raise ValueError(f"simulated ROS 2 robots drive in the plane; {scn.name} is {scn.dim}-D")
    n = scn.n if count is None else count
    if not 1 <= n <= scn.n:
        raise ValueError(f"{scn.name} has {scn.n} agents; cannot start {n} robots for it")
    if timeout <= 0:
        raise ValueError(f"a cmd_vel timeout must be positive, got {timeout} s")
    ell = scn.lookaheads
    headings = scn.initial_headings
    out = []
    for i in range(n):
        x, y = (float(v) for v in scn.initial_positions[i])
        if ell is None or ell[i] == 0.0:
            out.append(Driver(Pose(x, y, 0.0), holonomic=True, timeout=timeout))
            continue
        yaw = float(headings[i])
        body = Pose(x - float(ell[i]) * math.cos(yaw), y - float(ell[i]) * math.sin(yaw), yaw)
        u = scn.unicycle
        assert u is not None
        limits = Limits(speed=u.max_speed, turn=u.max_turn_rate)
        out.append(Driver(body, holonomic=False, timeout=timeout, limits=limits))
    return out


class Fleet:
    """Robots ``namespaces[i]`` driven by ``drivers[i]`` on ``ros``: each a node subscribed to
    its cmd_vel and publishing its odometry every 1/``rate`` s, late by ``latency`` ±
    ``jitter`` s (seeded). A sample that is not a Twist rmw_zenoh would send (no attachment,
    bad CDR, a non-finite value) is counted in ``dropped`` and changes nothing."""

    def __init__(
        self,
        ros: RosSession,
        namespaces: list[str],
        drivers: list[Driver],
        *,
        rate: float = 50.0,
        latency: float = 0.0,
        jitter: float = 0.0,
        seed: int = 0,
    ) -> None:
        if len(namespaces) != len(drivers):
            raise ValueError("one namespace per robot")
        if not 0.0 < rate <= 1000.0:
            raise ValueError(f"an odometry rate is in (0, 1000] Hz, got {rate}")
        self.drivers = drivers
        self.period = 1.0 / rate
        self.dropped = 0
        self.heard = 0
        self.published = 0
        self._lock = threading.Lock()
        self._nodes: list[RosNode] = []
        self._odom: list[tuple[RosPublisher, Delayer]] = []
        for i, (ns, drv) in enumerate(zip(namespaces, drivers, strict=True)):
            node = ros.node("shoal_robot", ns)
            self._nodes.append(node)
            odom = node.publisher(f"{ns}/odom", rmw.ODOMETRY)
            self._odom.append((odom, Delayer(latency, jitter, seed, i + 1)))
            node.subscriber(f"{ns}/cmd_vel", rmw.TWIST, self._listener(drv))

    def _listener(self, drv: Driver) -> Heard:
        def heard(payload: bytes, attachment: bytes | None) -> None:
            try:
                rmw.read_attachment(attachment)
                twist = rmw.read_twist(payload)
                if not all(math.isfinite(v) for v in twist):
                    raise rmw.RmwError(f"a command must be finite, got {twist}")
            except rmw.RmwError:
                with self._lock:
                    self.dropped += 1
                return
            with self._lock:
                self.heard += 1
                drv.hear(twist, time.monotonic())

        return heard

    def tick(self) -> None:
        """Advance every robot to now and publish its odometry."""
        now, stamp = time.monotonic(), time.time_ns()
        with self._lock:
            out = [(d.advance(now), d.moving(now)) for d in self.drivers]
        for (pose, speed), (odom, late) in zip(out, self._odom, strict=True):
            late.put(odom, rmw.odometry((pose.x, pose.y, pose.yaw), stamp, speed=speed))
            self.published += 1

    def run(self, stop: threading.Event) -> None:
        """Tick every period until ``stop`` is set (a late tick is not made up: the next one
        comes a period after it)."""
        due = time.monotonic()
        while not stop.is_set():
            self.tick()
            due = max(due + self.period, time.monotonic())
            stop.wait(max(0.0, due - time.monotonic()))

    def close(self) -> None:
        for _odom, late in self._odom:
            late.close()
        for node in self._nodes:
            node.close()
