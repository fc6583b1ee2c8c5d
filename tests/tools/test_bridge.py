"""tools/ros2/bridge.py: ROS 2 robots as the world's plant. Poses are read from rmw_zenoh samples
(a unicycle's point l ahead of its axle), each robot is sent the Twist that moves its agent's
point as the tick's velocity says, malformed samples are counted and dropped, a silent robot is
named and an old pose marks its robot stale. On one Zenoh session of this process, samples put
on it reaching its own subscribers (the wire itself: tests/tools/test_rmw.py, test_fleet.py)."""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest
import zenoh

from shoal.bus.zconfig import zenoh_config
from shoal.tools.ros2 import rmw
from shoal.tools.ros2.bridge import Ros2Robots
from shoal.tools.ros2.node import RosSession
from shoal.world.plant import PlantError
from shoal.world.unicycle import wheel_command

DT = 0.02


@pytest.fixture
def ros() -> Iterator[RosSession]:
    with zenoh.open(zenoh_config(mode="peer")) as session:
        yield RosSession(session, domain=9)


class Robots:
    """A fake fleet on the same session: publishes odometry as robot i, hears cmd_vel."""

    def __init__(self, ros: RosSession, n: int) -> None:
        self.node = ros.node("fake_robots")
        self.odom = [self.node.publisher(f"/robot{i}/odom", rmw.ODOMETRY) for i in range(1, n + 1)]
        self.commands: dict[int, list[tuple[float, float, float]]] = {}
        self.arrived = threading.Condition()
        for i in range(1, n + 1):
            self.node.subscriber(f"/robot{i}/cmd_vel", rmw.TWIST, self._heard(i))

    def _heard(self, i: int) -> Any:
        def heard(payload: bytes, attachment: bytes | None) -> None:
            rmw.read_attachment(attachment)
            with self.arrived:
                self.commands.setdefault(i, []).append(rmw.read_twist(payload))
                self.arrived.notify_all()

        return heard

    def report(self, i: int, x: float, y: float, yaw: float) -> None:
        self.odom[i - 1].put(rmw.odometry((x, y, yaw), time.time_ns()))


def test_unicycles_report_their_axle_and_are_sent_the_arc_to_the_point(ros: RosSession) -> None:
    fake = Robots(ros, 2)
    ell = np.array([0.1, 0.1])
    bridge = Ros2Robots(ros, ["/robot1", "/robot2"], ell, DT)
    fake.report(1, 1.0, 2.0, 0.5)
    fake.report(2, -1.0, 0.0, -2.0)
    bridge.wait_ready(10.0)
    seen = bridge.observe()
    assert seen.headings is not None and list(seen.headings) == [0.5, -2.0]
    assert seen.positions[0] == pytest.approx(
        [1.0 + 0.1 * math.cos(0.5), 2.0 + 0.1 * math.sin(0.5)]
    )
    assert seen.stale == frozenset()
    assert seen.ages is not None and all(0.0 <= a < 10.0 for a in seen.ages)
    u = np.array([[0.3, -0.1], [0.0, 0.2]])
    twists = bridge.send(u, seen.headings)
    with fake.arrived:
        assert fake.arrived.wait_for(lambda: len(fake.commands) == 2, 10.0)
    v, omega = wheel_command(u, seen.headings, 0.1, DT)
    for i in (1, 2):
        assert fake.commands[i] == [(v[i - 1], 0.0, omega[i - 1])]
        assert tuple(twists[i - 1]) == fake.commands[i][0]  # what the log records: what went
    bridge.stop()
    with fake.arrived:
        assert fake.arrived.wait_for(lambda: all(len(c) == 2 for c in fake.commands.values()))
    assert all(c[-1] == (0.0, 0.0, 0.0) for c in fake.commands.values())
    report = bridge.report()
    assert (report["robot_poses"], report["robot_poses_dropped"], report["robot_commands"]) == (
        2, 0, 4,
    )  # fmt: skip
    assert 0.0 <= report["pose_age_p99_ms"] <= report["pose_age_max_ms"] < 10_000.0
    bridge.close()


def test_holonomic_robots_are_sent_the_velocity_in_their_own_frame(ros: RosSession) -> None:
    fake = Robots(ros, 1)
    bridge = Ros2Robots(ros, ["/robot1"], None, DT)
    fake.report(1, 0.0, 0.0, math.pi / 2)  # facing +y
    bridge.wait_ready(10.0)
    seen = bridge.observe()
    assert seen.headings is None and list(seen.positions[0]) == [0.0, 0.0]
    (ahead,) = bridge.twists(np.array([[0.0, 0.4]]), None)
    assert tuple(ahead) == pytest.approx((0.4, 0.0, 0.0), abs=1e-15)
    (right,) = bridge.twists(np.array([[0.3, 0.0]]), None)  # +x is the robot's right
    assert tuple(right) == pytest.approx((0.0, -0.3, 0.0), abs=1e-15)
    bridge.close()


def test_bad_samples_are_dropped_a_silent_robot_named_and_an_old_pose_stale(
    ros: RosSession,
) -> None:
    fake = Robots(ros, 2)
    bridge = Ros2Robots(ros, ["/robot1", "/robot2"], None, DT, pose_timeout=0.2)
    key = rmw.topic_key(9, "/robot1/odom", rmw.ODOMETRY)
    ros.session.put(key, rmw.odometry((1.0, 1.0, 0.0), 1))  # no attachment
    ros.session.put(key, b"\x00\x01\x00\x00junk", attachment=b"\x00" * 33)
    fake.report(1, 1.0, 1.0, 0.0)
    with pytest.raises(PlantError, match=r"no pose within 0.5 s from /robot2 \(domain 9"):
        bridge.wait_ready(0.5)
    assert bridge.dropped == 2 and bridge.heard == 1
    fake.report(2, 3.0, 0.0, 0.0)
    bridge.wait_ready(10.0)
    bridge.heard_at[0] -= 1.0  # robot 1's pose as if it came a second ago
    assert bridge.observe().stale == frozenset({1})
    bridge.close()
