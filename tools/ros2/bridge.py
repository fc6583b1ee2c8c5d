"""ROS 2 robots as the world's plant (world/plant.py; ``shoal run --robots ros2``):
agent i's robot, namespace ``/<prefix><i>``, reports its pose on ``/<ns>/odom``
(``nav_msgs/msg/Odometry``) or a motion-capture ``geometry_msgs/msg/PoseStamped``, and takes
``geometry_msgs/msg/Twist`` on ``/<ns>/cmd_vel``, over rmw_zenoh (tools/ros2/node.py).

A unicycle robot reports its axle; its agent's point is l ahead of it, and it is sent the (v, ω)
that puts that point where the tick's velocity would after a tick (world/unicycle.py's
``wheel_command``). A holonomic robot is sent the velocity in its own frame. A pose older than
``pose_timeout`` s makes the world hold that robot still. A sample that is not what rmw_zenoh
sends (no attachment, foreign bytes, a non-finite pose) is counted and dropped.
"""

from __future__ import annotations

import math
import threading
import time
from typing import Any

import numpy as np

from shoal.geometry.vectors import FloatArray
from shoal.tools.ros2 import rmw
from shoal.tools.ros2.node import Heard, RosSession
from shoal.world.plant import Movers, Observed, PlantError
from shoal.world.unicycle import wheel_command

POSE_TOPICS = {rmw.ODOMETRY: "odom", rmw.POSE_STAMPED: "pose"}


def zero() -> bytes:
    """A Twist that stops a robot, in CDR: made when sent, not at import (rosbags, which
    serialises it, is the ros2 extra, and ``shoal --help`` imports this module)."""
    return rmw.twist((0.0, 0.0), 0.0)


class Ros2Robots:
    """The robots of ``namespaces`` (agent i's is ``namespaces[i - 1]``) on ``ros``.
    ``lookaheads``: (n,) l per agent (0: holonomic), or None when every agent is."""

    simulated = False  # robots move on the wall clock

    def __init__(
        self,
        ros: RosSession,
        namespaces: list[str],
        lookaheads: FloatArray | None,
        dt: float,
        *,
        pose_type: str = rmw.ODOMETRY,
        pose_timeout: float = 0.5,
    ) -> None:
        if pose_type not in POSE_TOPICS:
            raise rmw.RmwError(f"a pose comes as {' or '.join(POSE_TOPICS)}, not {pose_type}")
        self.namespaces = namespaces
        self.n = len(namespaces)
        self.lookaheads = lookaheads
        self.dt = dt
        self.pose_timeout = pose_timeout
        self.poses: list[tuple[float, float, float] | None] = [None] * self.n
        self.heard_at = [-math.inf] * self.n
        self.yaw = np.zeros(self.n)  # rad: each robot's heading when last observed
        self.ages: list[float] = []  # s: the oldest pose at each observation
        self.heard = self.dropped = self.sent = 0
        self._arrived = threading.Condition()
        self._node = ros.node("shoal_world")
        topic = POSE_TOPICS[pose_type]
        self._cmd = []
        for i, ns in enumerate(namespaces):
            self._node.subscriber(f"{ns}/{topic}", pose_type, self._listener(i, pose_type))
            self._cmd.append(self._node.publisher(f"{ns}/cmd_vel", rmw.TWIST))
        shown = ", ".join(f"{ns}/{topic}" for ns in namespaces[:3]) + ("…" if self.n > 3 else "")
        self.where = f"domain {ros.domain}, {pose_type} on {shown}"

    def _listener(self, i: int, pose_type: str) -> Heard:
        def heard(payload: bytes, attachment: bytes | None) -> None:
            try:
                rmw.read_attachment(attachment)
                pose = rmw.read_pose(payload, pose_type)
            except rmw.RmwError:
                with self._arrived:
                    self.dropped += 1
                return
            with self._arrived:
                self.poses[i], self.heard_at[i] = pose, time.monotonic()
                self.heard += 1
                self._arrived.notify_all()

        return heard

    def wait_ready(self, timeout: float) -> None:
        with self._arrived:
            if not self._arrived.wait_for(lambda: None not in self.poses, timeout):
                missing = [self.namespaces[i] for i, p in enumerate(self.poses) if p is None]
                raise PlantError(
                    f"no pose within {timeout:g} s from {', '.join(missing)} ({self.where}): "
                    "are the robots (or `shoal robots`) up, on this domain and router?"
                )

    def observe(self) -> Observed:
        now = time.monotonic()
        with self._arrived:
            poses = list(self.poses)
            ages = np.array([now - t for t in self.heard_at])
        if any(p is None for p in poses):
            raise PlantError("observe() before every robot reported a pose")
        body = np.array([(p[0], p[1]) for p in poses if p is not None])
        yaw = np.array([p[2] for p in poses if p is not None])
        stale = frozenset(int(i) + 1 for i in np.flatnonzero(ages > self.pose_timeout))
        self.ages.append(float(ages.max()))
        self.yaw = yaw
        if self.lookaheads is None:
            return Observed(body, None, stale, ages)
        ell = self.lookaheads[:, None]
        points = body + ell * np.stack([np.cos(yaw), np.sin(yaw)], axis=-1)
        return Observed(points, yaw, stale, ages)

    def send(
        self, velocities: FloatArray, headings: FloatArray | None, movers: Movers | None = None
    ) -> FloatArray:
        twists = self.twists(velocities, headings)
        for i, (vx, vy, wz) in enumerate(twists.tolist()):
            self._cmd[i].put(rmw.twist((vx, vy), wz))
            self.sent += 1
        return twists

    def twists(self, velocities: FloatArray, headings: FloatArray | None) -> FloatArray:
        """(n, 3) each robot's Twist (linear x, linear y, angular z) for a tick of
        ``velocities`` (its agent's point): a unicycle's (v, ω) from its heading (world/
        unicycle.py's ``wheel_command``), a holonomic robot's velocity in its frame, from its
        last observed yaw."""
        u = np.asarray(velocities, dtype=np.float64)
        c, s = np.cos(self.yaw), np.sin(self.yaw)  # the robot's frame: R(−yaw)·u
        out = np.stack([c * u[:, 0] + s * u[:, 1], -s * u[:, 0] + c * u[:, 1], np.zeros_like(c)], 1)
        if self.lookaheads is not None:
            wheeled = self.lookaheads > 0.0
            if wheeled.any():
                assert headings is not None
                ell = self.lookaheads[wheeled]
                v, omega = wheel_command(u[wheeled], headings[wheeled], ell, self.dt)
                out[wheeled] = np.stack([v, np.zeros_like(v), omega], axis=1)
        return out

    def record(self, tick: int) -> None:
        return None  # what the robots did is their RobotsRecord, which the world makes

    def stop(self) -> None:
        stop = zero()
        for cmd in self._cmd:
            cmd.put(stop)
            self.sent += 1

    def report(self) -> dict[str, Any]:
        """What was heard, dropped and sent, and how old the poses were when the world used
        them (ms; with the robots' speed, what ``position_error`` must cover: docs/ros2.md)."""
        ages = np.asarray(self.ages) * 1e3
        return {
            "robot_poses": self.heard,
            "robot_poses_dropped": self.dropped,
            "robot_commands": self.sent,
            "pose_age_p99_ms": float(np.percentile(ages, 99)) if len(ages) else None,
            "pose_age_max_ms": float(ages.max()) if len(ages) else None,
        }

    def close(self) -> None:
        self._node.close()
