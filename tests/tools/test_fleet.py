"""tools/ros2/fleet.py and ``shoal robots``: simulated ROS 2 robots. The driver's motion is
checked in numbers (the arc, the holonomic frame, the cmd_vel timeout, the clamps); the odometry's
CDR is decoded by a decoder shoal did not write (mcap-ros2-support's, from the message
definitions); and a fleet process is driven over a real router by an rmw_zenoh client shoal did
not write (zenoh-ros2-sdk) and by shoal's own, malformed samples counted and dropped."""

from __future__ import annotations

import dataclasses
import json
import math
import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import yaml
from conftest import client, processes_mentioning, shoal_run, unique
from fleets import robots_process

from shoal.tools.campaign.fields import FieldOptions, make_field
from shoal.tools.procs.launch import free_port
from shoal.tools.ros2 import rmw
from shoal.tools.ros2.bridge import zero
from shoal.tools.ros2.fleet import Driver, Limits, Pose, drivers_for
from shoal.tools.ros2.node import RosSession
from shoal.world.loader import load_scenario
from shoal.world.unicycle import drive


def test_a_unicycle_drives_the_exact_arc_and_stops_at_its_timeout() -> None:
    d = Driver(Pose(1.0, 2.0, 0.3), holonomic=False, timeout=0.5)
    d.advance(10.0)
    d.hear((0.2, 0.7, 1.0), 10.0)  # linear y: a unicycle cannot, and drops it
    assert d.command == (0.2, 0.0, 1.0)
    at = d.advance(10.25)
    import numpy as np

    want, heading = drive(np.array([[1.0, 2.0]]), np.array([0.3]), np.array([0.2]),
                          np.array([1.0]), 0.0, 0.25)  # fmt: skip
    assert (at.x, at.y) == pytest.approx(tuple(want[0]), abs=1e-12)
    assert at.yaw == pytest.approx(0.55, abs=1e-12)
    later = d.advance(30.0)  # the command held 0.5 s, then the robot stood
    want, heading = drive(np.array([[1.0, 2.0]]), np.array([0.3]), np.array([0.2]),
                          np.array([1.0]), 0.0, 0.5)  # fmt: skip
    assert (later.x, later.y) == pytest.approx(tuple(want[0]), abs=1e-12)
    assert later.yaw == pytest.approx(float(heading[0]), abs=1e-12)
    assert d.moving(30.0) == (0.0, 0.0, 0.0) and d.moving(10.4) == (0.2, 0.0, 1.0)


def test_a_holonomic_robot_moves_in_its_own_frame() -> None:
    d = Driver(Pose(0.0, 0.0, math.pi / 2), holonomic=True, timeout=1.0)
    d.hear((1.0, 0.5, 0.0), 0.0)
    at = d.advance(0.4)
    assert (at.x, at.y, at.yaw) == pytest.approx((-0.2, 0.4, math.pi / 2), abs=1e-12)


def test_a_driver_clamps_to_its_limits_and_counts_it() -> None:
    d = Driver(Pose(0.0, 0.0, 0.0), holonomic=False, timeout=1.0, limits=Limits(0.2, 2.0))
    d.hear((0.5, 0.0, -3.0), 0.0)
    assert d.command == (0.2, 0.0, -2.0) and d.clamped == 1
    d.hear((0.1, 0.0, 1.0), 0.1)
    assert d.command == (0.1, 0.0, 1.0) and d.clamped == 1


def test_robots_start_where_the_agents_do() -> None:
    scn = load_scenario("robotarium")
    drivers = drivers_for(scn)
    ell = scn.lookahead
    assert ell is not None and len(drivers) == scn.n
    for d, p, h in zip(drivers, scn.initial_positions, scn.initial_headings, strict=True):
        assert not d.holonomic and d.pose.yaw == h
        assert d.pose.x + ell * math.cos(h) == pytest.approx(p[0], abs=1e-15)
        assert d.pose.y + ell * math.sin(h) == pytest.approx(p[1], abs=1e-15)
        assert d.limits == Limits(0.2, scn.unicycle.max_turn_rate)  # type: ignore[union-attr]
    plain = drivers_for(load_scenario("default"), 3)
    assert len(plain) == 3 and all(d.holonomic and d.pose.yaw == 0.0 for d in plain)
    with pytest.raises(ValueError, match="has 5 agents"):
        drivers_for(scn, 6)
    with pytest.raises(ValueError, match="in the plane"):
        drivers_for(dataclasses.replace(scn, dim=3))


def test_odometry_cdr_reads_back_in_a_decoder_shoal_did_not_write() -> None:
    """mcap-ros2-support builds its decoder from the message definition text (here rosbags'
    concatenated .msg, as a bag's schema carries it) and decodes the CDR itself."""
    from mcap_ros2._dynamic import generate_dynamic
    from rosbags.typesys import Stores, get_typestore

    text, _md5 = get_typestore(Stores.ROS2_JAZZY).generate_msgdef(rmw.ODOMETRY, ros_version=2)
    decode = generate_dynamic(rmw.ODOMETRY, text)[rmw.ODOMETRY]
    stamp = 1_700_000_123_456_789_012
    data = rmw.odometry((1.25, -0.5, 2.0), stamp, frame_id="map", child_frame_id="robot3",
                        speed=(0.1, 0.0, -0.4))  # fmt: skip
    m = decode(data)
    assert (m.header.stamp.sec, m.header.stamp.nanosec) == (1_700_000_123, 456_789_012)
    assert (m.header.frame_id, m.child_frame_id) == ("map", "robot3")
    p, q = m.pose.pose.position, m.pose.pose.orientation
    assert (p.x, p.y, p.z) == (1.25, -0.5, 0.0)
    assert (q.x, q.y, q.z, q.w) == (0.0, 0.0, math.sin(1.0), math.cos(1.0))
    assert (m.twist.twist.linear.x, m.twist.twist.angular.z) == (0.1, -0.4)
    assert list(m.pose.covariance) == [0.0] * 36
    x, y, yaw = rmw.read_pose(data)
    assert (x, y) == (1.25, -0.5) and yaw == pytest.approx(2.0, abs=1e-15)
    with pytest.raises(rmw.RmwError, match="finite"):
        rmw.odometry((math.inf, 0.0, 0.0), 0)


@dataclasses.dataclass
class Odometry:
    """What a test's shoal-side node hears on the robots' odom topics: per robot, every
    (pose, linear x, angular z) in arrival order."""

    heard: dict[int, list[tuple[tuple[float, float, float], float, float]]] = dataclasses.field(
        default_factory=dict
    )
    arrived: threading.Condition = dataclasses.field(default_factory=threading.Condition)

    def listener(self, i: int) -> Any:
        def heard(payload: bytes, attachment: bytes | None) -> None:
            rmw.read_attachment(attachment)  # a fleet's samples carry rmw_zenoh's attachment
            m = rmw._decode(payload, rmw.ODOMETRY)
            entry = (rmw.read_pose(payload), float(m.twist.twist.linear.x),
                     float(m.twist.twist.angular.z))  # fmt: skip
            with self.arrived:
                self.heard.setdefault(i, []).append(entry)
                self.arrived.notify_all()

        return heard

    def count(self, i: int) -> int:
        return len(self.heard.get(i, []))

    def pose(self, i: int) -> tuple[float, float, float]:
        with self.arrived:
            return self.heard[i][-1][0]

    def until(self, done: Any, timeout: float = 30.0) -> None:
        with self.arrived:
            assert self.arrived.wait_for(lambda: done(self), timeout), self.heard.keys()


@pytest.fixture
def fleet() -> Iterator[tuple[str, subprocess.Popen[str]]]:
    """``shoal robots default -n 2`` as its own router on a free port, until it is ready."""
    args = ["default", "-n", "2", "--rate", "40", "--cmd-timeout", "0.3", "--domain", "3"]
    with robots_process(args, "ready robots 2 holonomic robots /robot1…/robot2 domain 3") as up:
        yield up


@pytest.mark.integration
def test_a_fleet_drives_as_commanded_stops_on_its_own_and_drops_garbage(
    fleet: tuple[str, subprocess.Popen[str]],
) -> None:
    """Robot 1 is sent 0.5 m/s along x at 20 Hz until it has gone 0.3 m, then nothing: it
    moves that way, reports its speed, and stops no sooner than its 0.3 s cmd_vel timeout
    after the last command, for good; robot 2, sent nothing, stays where agent 2 starts.
    Samples with no attachment and foreign bytes are counted and dropped (the fleet says so
    on its way out)."""
    endpoint, proc = fleet
    starts = load_scenario("default").initial_positions
    odom = Odometry()
    with client(endpoint) as session:
        ros = RosSession(session, domain=3)
        node = ros.node("test_driver")
        for i in (1, 2):
            node.subscriber(f"/robot{i}/odom", rmw.ODOMETRY, odom.listener(i))
        cmd = node.publisher("/robot1/cmd_vel", rmw.TWIST)
        odom.until(lambda o: o.count(1) >= 3 and o.count(2) >= 3)
        x0, y0, _ = odom.pose(1)
        assert (x0, y0) == pytest.approx(tuple(starts[0]), abs=1e-12)
        key = rmw.topic_key(3, "/robot1/cmd_vel", rmw.TWIST)
        session.put(key, rmw.twist((9.0, 0.0), 0.0))  # no attachment: rmw_zenoh drops it
        session.put(key, b"\x00\x01\x00\x00junk", attachment=b"\x00" * 33)  # foreign bytes
        sent = 0
        while odom.pose(1)[0] < x0 + 0.3:
            cmd.put(rmw.twist((0.5, 0.0), 0.0))
            last_sent = time.monotonic()
            sent += 1
            assert sent < 2000, f"robot 1 did not move: {odom.pose(1)}"
            time.sleep(0.05)  # pacing: a 20 Hz command stream, as a controller sends it
        seen = odom.count(1)
        odom.until(lambda o: o.heard[1][-1][1] == 0.0 and o.count(1) > seen)
        assert time.monotonic() - last_sent >= 0.3  # never before its timeout
        with odom.arrived:
            stopped_at = odom.count(1)
            stopped = odom.heard[1][-1][0]
        moving = [e for e in odom.heard[1][:stopped_at] if e[1] != 0.0]
        assert moving and all(e[1] == 0.5 and e[2] == 0.0 for e in moving)
        odom.until(lambda o: o.count(1) >= stopped_at + 12)  # 0.3 s more of odometry
        with odom.arrived:
            after = [e[0] for e in odom.heard[1][stopped_at - 1 :]]
        assert all(p == stopped for p in after), "the robot moved after its cmd_vel timeout"
        assert stopped[0] >= x0 + 0.3 and stopped[1] == y0 and stopped[2] == 0.0
        x2, y2, _ = odom.pose(2)
        assert (x2, y2) == pytest.approx(tuple(starts[1]), abs=1e-12)
        node.close()
    proc.send_signal(signal.SIGINT)
    _out, err = proc.communicate(timeout=20.0)
    assert "2 malformed dropped" in err, err


def _cmdline(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode()
    except OSError:
        return ""


def _patient_fleet(tmp_path: Path) -> tuple[Path, list[str], str, subprocess.Popen[str]]:
    """Five ROS 2 robots of ``shoal robots`` on a campaign field of ``obstacles``, whose own
    driver keeps a command for 60 s (only shoal can stop them), on a router of their own: the
    field's file (with its ``robots:`` section), their namespaces, that router's endpoint and
    the fleet's process."""
    field = make_field(load_scenario("obstacles"), 3, options=FieldOptions(length=8.0, tail=2.0))
    ros_endpoint = f"tcp/127.0.0.1:{free_port()}"
    names = [f"/lab/tb_{c}" for c in "abcde"]
    section = {"namespaces": names, "domain": 4, "connect": [ros_endpoint]}
    path = tmp_path / "field.yaml"
    path.write_text(field.source + yaml.safe_dump({"robots": section}), encoding="utf-8")
    fleet = subprocess.Popen(
        [sys.executable, "-m", "shoal.tools", "robots", str(path), "--listen", ros_endpoint,
         "--cmd-timeout", "60"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    return path, names, ros_endpoint, fleet


@pytest.mark.integration
def test_robots_stop_within_a_second_when_the_world_is_killed(router: str, tmp_path: Path) -> None:
    """``shoal run --robots ros2`` drives five simulated robots whose own driver would keep a
    command for 60 s; the world is SIGKILLed while they move, so it sends nothing. The guard
    `shoal run` started beside it sends every robot a zero Twist (when the world's token
    vanishes, or when `shoal run`, seeing the world gone, stops it, whichever is first): all
    report standing within 1 s (measured, printed: 16–34 ms on an unloaded machine).
    The robots are named by the scenario's ``robots:`` section alone (namespaces, domain,
    router): the world, the guard and ``shoal robots`` all find them from it."""
    path, names, ros_endpoint, fleet = _patient_fleet(tmp_path)
    run = unique("guard")
    proc = None
    try:
        assert fleet.stdout is not None and fleet.stdout.readline().startswith("ready robots 5")
        odom = Odometry()
        with client(ros_endpoint) as session:
            node = RosSession(session, domain=4).node("test_watch")
            for i, name in enumerate(names, start=1):
                node.subscriber(f"{name}/odom", rmw.ODOMETRY, odom.listener(i))
            proc = shoal_run(path, router, tmp_path / "run.mcap", "--clock", "realtime",
                             "--robots", "ros2", "--json", "--no-foxglove", run=run)  # fmt: skip

            def moving(o: Odometry) -> bool:
                return any(o.heard.get(i) and o.heard[i][-1][1] != 0.0 for i in range(1, 6))

            odom.until(moving, timeout=90.0)
            (world,) = [p for p in processes_mentioning(run) if " world " in _cmdline(p)]
            os.kill(world, signal.SIGKILL)
            killed = time.monotonic()
            with odom.arrived:
                counts = {i: odom.count(i) for i in range(1, 6)}

            def standing(o: Odometry) -> bool:
                return all(
                    o.count(i) > counts[i] and o.heard[i][-1][1:] == (0.0, 0.0) for i in range(1, 6)
                )

            odom.until(standing, timeout=30.0)
            took = time.monotonic() - killed
            node.close()
        print(f"\nworld SIGKILLed: every robot standing {1e3 * took:.0f} ms later")
        assert took < 1.0
        _out, err = proc.communicate(timeout=60.0)
        assert proc.returncode != 0 and "world" in err
    finally:
        if proc is not None and proc.poll() is None:
            proc.kill()
        fleet.send_signal(signal.SIGINT)
        fleet.communicate(timeout=20.0)


def _moving_after_a_zero(told: dict[int, list[tuple[float, bytes]]], since: float) -> int:
    """How many non-zero Twists each robot heard after the first zero it heard after ``since``,
    summed over the robots."""
    out = 0
    for heard in told.values():
        stopped = False
        for t, payload in heard:
            if t <= since:
                continue
            if payload == zero():
                stopped = True
            elif stopped:
                out += 1
    return out


@pytest.mark.integration
def test_the_guards_zero_is_the_last_command_when_the_router_is_killed(
    router: str, tmp_path: Path
) -> None:
    """The router dies under a realtime run of ROS 2 robots: the guard sees the world's token
    vanish and stops every robot, while the world, cut off from its agents but alive, may
    still send the commands it had for a few ticks. No robot hears a non-zero Twist after a
    zero, and the last one each hears is a zero: the world holds an agent's robot the moment
    its token goes down (world/process.py), and the guard holds its zero for a second
    (tools/commands/guard.py). Before: 5 non-zero Twists after the zeros in 1 of 2 runs."""
    path, names, ros_endpoint, fleet = _patient_fleet(tmp_path)
    run = unique("lastzero")
    proc = None
    told: dict[int, list[tuple[float, bytes]]] = {}
    lock = threading.Condition()

    def listener(i: int) -> Any:
        def heard(payload: bytes, attachment: bytes | None) -> None:
            with lock:
                told.setdefault(i, []).append((time.monotonic(), payload))
                lock.notify_all()

        return heard

    try:
        assert fleet.stdout is not None and fleet.stdout.readline().startswith("ready robots 5")
        odom = Odometry()
        with client(ros_endpoint) as session:
            node = RosSession(session, domain=4).node("test_watch")
            for i, name in enumerate(names, start=1):
                node.subscriber(f"{name}/odom", rmw.ODOMETRY, odom.listener(i))
                node.subscriber(f"{name}/cmd_vel", rmw.TWIST, listener(i))
            proc = shoal_run(path, router, tmp_path / "run.mcap", "--clock", "realtime",
                             "--robots", "ros2", "--json", "--no-foxglove", run=run)  # fmt: skip

            def moving(o: Odometry) -> bool:
                return any(o.heard.get(i) and o.heard[i][-1][1] != 0.0 for i in range(1, 6))

            odom.until(moving, timeout=90.0)
            routers = [p for p in processes_mentioning(router) if " router " in _cmdline(p)]
            assert len(routers) == 1, routers
            os.kill(routers[0], signal.SIGKILL)
            killed = time.monotonic()

            def quiet() -> bool:  # nobody has said anything to any robot for 2 s
                last = max(t for heard in told.values() for t, _ in heard)
                return time.monotonic() - last > 2.0 and last > killed

            with lock:
                while not quiet():  # re-checked at least every 0.1 s: quiet is the lack of news
                    assert time.monotonic() < killed + 60.0, "the robots were told things for 60 s"
                    lock.wait(timeout=0.1)
                lasts = {i: told[i][-1][1] for i in range(1, 6)}
                after = sum(1 for i in told for t, _ in told[i] if t > killed)
                late = _moving_after_a_zero(told, killed)
            node.close()
        assert all(last == zero() for last in lasts.values()), lasts
        assert late == 0, f"{late} non-zero Twists after a robot was told to stop"
        print(f"\nrouter SIGKILLed: {after} Twists after it, {late} of them non-zero after a "
              "zero; the last one a zero for every robot")  # fmt: skip
    finally:
        if proc is not None:  # its router gone, it may have ended by itself
            if proc.poll() is None:
                proc.kill()
            proc.communicate(timeout=30.0)
        fleet.send_signal(signal.SIGINT)
        fleet.communicate(timeout=20.0)


@pytest.mark.integration
def test_unicycle_robots_driven_through_ros2_turn_their_corner_and_arrive(
    router: str, tmp_path: Path
) -> None:
    """GRITSbot unicycles (the robotarium's constants, odometry at 50 Hz) as ROS 2 robots,
    the leader starting reversed, its route turning a corner: the world reads each robot's
    axle from its odometry, drives the point l ahead of it with (v, ω) Twists (linear y 0), and
    the formation arrives with 0 collisions; every guard is kept to within what a tick and the
    pose's age let a robot move (docs/ros2.md: measured, not proven)."""
    from importlib import resources

    from shoal.bus import codec
    from shoal.tools.log.reader import iter_channel

    data = yaml.safe_load(
        resources.files("shoal.world.scenarios").joinpath("robotarium.yaml").read_text()
    )
    data["leader"]["waypoints"] = [[-0.6, 0], [-0.2, 0], [-0.2, 0.3]]
    data["duration"] = 25.0
    data["agents"][0]["heading"] = math.pi
    ros_endpoint = f"tcp/127.0.0.1:{free_port()}"
    data["robots"] = {"domain": 5, "connect": [ros_endpoint]}
    path = tmp_path / "gritsbots.yaml"
    path.write_text(yaml.safe_dump(data), encoding="utf-8")
    scn = load_scenario(str(path))
    fleet = subprocess.Popen(
        [sys.executable, "-m", "shoal.tools", "robots", str(path), "--listen", ros_endpoint],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        assert fleet.stdout is not None
        assert fleet.stdout.readline().startswith("ready robots 5 unicycles")
        out = tmp_path / "run.mcap"
        proc = shoal_run(path, router, out, "--clock", "realtime", "--robots", "ros2", "--json",
                         "--no-foxglove")  # fmt: skip
        stdout, stderr = proc.communicate(timeout=180.0)
    finally:
        fleet.send_signal(signal.SIGINT)
        fleet.communicate(timeout=20.0)
    assert proc.returncode == 0, stderr
    summary = json.loads(stdout)
    assert summary["collisions"] == 0 and summary["arrived"] is True, summary
    late = scn.speed_limit * (summary["pose_age_max_ms"] / 1e3 + 2 * scn.dt)
    assert summary["min_clearance"] >= scn.control.safety_margin - late
    twists = [codec.decode_robots(d).twists for _t, d, _ns in iter_channel(out, "/world/robots")]
    assert len(twists) == scn.steps
    assert all(y == 0.0 for tick in twists for _x, y, _w in tick)  # unicycles: no sideways
    assert max(abs(w) for tick in twists for _x, _y, w in tick) > 0.5  # and they turned
    assert min(tick[0][0] for tick in twists) < 0.0  # the reversed leader backed away first
    print(f"\nGRITSbots through ROS 2: arrived at {summary['arrival_time']} s, clearance "
          f"{summary['min_clearance']:.4f} m (ρ {scn.control.safety_margin}), pose age max "
          f"{summary['pose_age_max_ms']:.1f} ms")  # fmt: skip
