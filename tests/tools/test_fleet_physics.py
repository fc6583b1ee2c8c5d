"""``shoal robots --plant mujoco``: simulated ROS 2 robots with mass, moved by MuJoCo on the
wall clock. A robot driven over a real router by rmw_zenoh's protocol moves as a body does (it
accelerates, its odometry reports the speed it measured, not the one commanded), stops by its
own timeout, and the fleet ends with what the engine judged."""

from __future__ import annotations

import signal
import subprocess
import time
from collections.abc import Iterator

import pytest
from conftest import client
from fleets import robots_process
from test_fleet import Odometry

from shoal.tools.ros2 import rmw
from shoal.tools.ros2.node import RosSession
from shoal.world.loader import load_scenario
from shoal.world.unicycle import body_centres

pytest.importorskip("mujoco", reason="the physics extra: pip install 'shoal[physics]'")


@pytest.fixture
def fleet() -> Iterator[tuple[str, subprocess.Popen[str]]]:
    """``shoal robots robotarium -n 2 --plant mujoco`` as its own router, until it is ready."""
    args = ["robotarium", "-n", "2", "--rate", "40", "--cmd-timeout", "0.3", "--domain", "4",
            "--plant", "mujoco"]  # fmt: skip
    with robots_process(args, "ready robots 2 unicycles") as up:
        yield up


def test_a_robot_with_mass_drives_measures_its_speed_and_stops_on_its_own(
    fleet: tuple[str, subprocess.Popen[str]],
) -> None:
    endpoint, proc = fleet
    scn = load_scenario("robotarium")
    bodies = body_centres(scn.initial_positions, scn.initial_headings, scn.lookaheads)
    odom = Odometry()
    with client(endpoint) as session:
        node = RosSession(session, domain=4).node("test_driver")
        for i in (1, 2):
            node.subscriber(f"/robot{i}/odom", rmw.ODOMETRY, odom.listener(i))
        cmd = node.publisher("/robot1/cmd_vel", rmw.TWIST)
        odom.until(lambda o: o.count(1) >= 3 and o.count(2) >= 3)
        x0, y0, _ = odom.pose(1)
        assert (x0, y0) == pytest.approx(tuple(bodies[0]), abs=1e-3)  # settled on its wheels
        while odom.pose(1)[0] < x0 + 0.1:
            cmd.put(rmw.twist((0.15, 0.0), 0.0))
            time.sleep(0.05)  # pacing: a 20 Hz command stream, as a controller sends it
        with odom.arrived:
            speeds = [e[1] for e in odom.heard[1]]
        # a body: it starts from rest and reports the speed it measured, near the command
        assert speeds[0] == pytest.approx(0.0, abs=1e-3)
        assert 0.13 < max(speeds) < 0.17 and len(set(speeds)) > 5
        odom.until(lambda o: abs(o.heard[1][-1][1]) < 1e-3)  # its own timeout stopped it
        seen = odom.count(1)
        odom.until(lambda o: o.count(1) >= seen + 12)  # 0.3 s more of odometry
        with odom.arrived:
            rest = [e[0] for e in odom.heard[1][seen:]]
        assert max(abs(p[0] - rest[0][0]) for p in rest) < 1e-3
        x2, y2, _ = odom.pose(2)
        assert (x2, y2) == pytest.approx(tuple(bodies[1]), abs=1e-3)  # never commanded
        node.close()
    proc.send_signal(signal.SIGINT)
    _out, err = proc.communicate(timeout=20.0)
    assert "robots: mujoco (gritsbot)" in err and "engine contacts 0" in err, err
