"""tools/ros2/rmw.py: rmw_zenoh's wire as shoal writes it, checked against an rmw_zenoh client
shoal did not write (zenoh-ros2-sdk 0.1.8, offline: message definitions from a folder) and the
facts in ../shared/notes/ecosystem.md; a Twist shoal publishes reaches that client's subscriber
through a real router, and one it publishes is read back by shoal."""

from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest
import zenoh
from conftest import client

from shoal.tools.procs.launch import free_port
from shoal.tools.procs.swarm import Swarm
from shoal.tools.ros2 import rmw
from shoal.world.loader import load_scenario

TWIST_HASH = "RIHS01_9c45bf16fe0983d80e3cfe750d6835843d265a9a6c46bd2e609fcddde6fb8d2a"
ODOMETRY_HASH = "RIHS01_3cc97dc7fb7502f8714462c526d369e35b603cfc34d946e3f2eda2766dfec6e0"
POSE_HASH = "RIHS01_10f3786d7d40fd2b54367835614bff85d4ad3b5dab62bf8bca0cc232d73b4cd8"
MSGS = {
    "geometry_msgs/msg/Vector3.msg": "float64 x\nfloat64 y\nfloat64 z\n",
    "geometry_msgs/msg/Twist.msg": "Vector3  linear\nVector3  angular\n",
    # nav_msgs/msg/Odometry and what it holds, as common_interfaces (Jazzy) defines them
    "builtin_interfaces/msg/Time.msg": "int32 sec\nuint32 nanosec\n",
    "std_msgs/msg/Header.msg": "builtin_interfaces/Time stamp\nstring frame_id\n",
    "geometry_msgs/msg/Point.msg": "float64 x\nfloat64 y\nfloat64 z\n",
    "geometry_msgs/msg/Quaternion.msg": "float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n",
    "geometry_msgs/msg/Pose.msg": "Point position\nQuaternion orientation\n",
    "geometry_msgs/msg/PoseWithCovariance.msg": "Pose pose\nfloat64[36] covariance\n",
    "geometry_msgs/msg/TwistWithCovariance.msg": "Twist twist\nfloat64[36] covariance\n",
    "nav_msgs/msg/Odometry.msg": "std_msgs/Header header\nstring child_frame_id\n"
    "geometry_msgs/PoseWithCovariance pose\ngeometry_msgs/TwistWithCovariance twist\n",
}


@pytest.fixture(scope="module")
def sdk(tmp_path_factory: pytest.TempPathFactory) -> Any:
    """zenoh_ros2_sdk, its message registry on a folder of .msg files (it would otherwise clone
    ros2/common_interfaces with git) and its cache in an empty folder."""
    root = tmp_path_factory.mktemp("ros2-sdk")
    for name, text in MSGS.items():
        path = root / "messages" / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    os.environ["ZENOH_ROS2_SDK_CACHE"] = str(root / "cache")
    import zenoh_ros2_sdk

    zenoh_ros2_sdk.get_registry(str(root / "messages"))
    return zenoh_ros2_sdk


NODE = rmw.Node(domain=7, zid="3bc2ccf15381966c4942e210dc3dc47e", nid=2, name="shoal_world",
                namespace="/swarm")  # fmt: skip
CMD = rmw.Endpoint(NODE, 5, "MP", "/robot1/cmd_vel", rmw.TWIST, qos=rmw.qos(depth=10))


def test_the_type_hashes_are_jazzys() -> None:
    assert rmw.type_hash(rmw.TWIST) == TWIST_HASH
    assert rmw.type_hash(rmw.ODOMETRY) == ODOMETRY_HASH
    assert rmw.type_hash(rmw.POSE_STAMPED) == POSE_HASH
    assert rmw.type_hash(rmw.TWIST, "humble") == "TypeHashNotSupported"
    assert rmw.dds_type(rmw.ODOMETRY) == "nav_msgs::msg::dds_::Odometry_"


def test_keys_tokens_and_qos_are_what_the_other_client_builds(sdk: Any) -> None:
    from zenoh_ros2_sdk.entity import EndpointEntity, EntityKind, NodeEntity
    from zenoh_ros2_sdk.keyexpr import (
        endpoint_liveliness_keyexpr,
        node_liveliness_keyexpr,
        topic_keyexpr,
    )
    from zenoh_ros2_sdk.qos import QosProfile, QosReliability

    node = NodeEntity(domain_id=7, session_id=NODE.zid, node_id=2, node_name="shoal_world",
                      namespace="/swarm")  # fmt: skip
    theirs = EndpointEntity(node=node, entity_id=5, kind=EntityKind.PUBLISHER,
                            name="/robot1/cmd_vel", dds_type_name=rmw.dds_type(rmw.TWIST),
                            type_hash=TWIST_HASH, qos=QosProfile().encode())  # fmt: skip
    assert CMD.key == topic_keyexpr(7, "/robot1/cmd_vel", rmw.dds_type(rmw.TWIST), TWIST_HASH)
    assert NODE.token() == node_liveliness_keyexpr(node)
    assert CMD.token() == endpoint_liveliness_keyexpr(theirs)
    assert rmw.qos() == QosProfile().encode() == "::,10:,:,:,,"
    best_effort = QosProfile(reliability=QosReliability.BEST_EFFORT, history_depth=5)
    assert rmw.qos(reliable=False, depth=5) == best_effort.encode() == "2::,5:,:,:,,"
    assert rmw.qos(depth=42) == "::,:,:,:,,"  # depth 42 is rmw_zenoh's default: left empty


def test_the_attachment_reads_back_in_the_other_client(sdk: Any) -> None:
    from zenoh_ros2_sdk.attachment import Attachment

    gid = CMD.gid()
    data = rmw.attachment(3, 1_700_000_000_123_456_789, gid)
    assert len(data) == 33 and rmw.read_attachment(data) == (3, 1_700_000_000_123_456_789, gid)
    theirs = Attachment.from_bytes(data)
    assert (theirs.sequence_id, theirs.timestamp_ns, bytes(theirs.gid)) == (
        3,
        1_700_000_000_123_456_789,
        gid,
    )
    assert rmw.read_attachment(Attachment(9, 42, gid).to_bytes()) == (9, 42, gid)


@pytest.mark.parametrize(
    ("call", "says"),
    [
        (lambda: rmw.dds_type("Twist"), "package/msg/Name"),
        (lambda: rmw.topic_key(0, "/", rmw.TWIST), "not a ROS 2 topic"),
        (lambda: rmw.topic_key(0, "/a/*/b", rmw.TWIST), "not a ROS 2 topic"),
        (lambda: rmw.type_hash(rmw.TWIST, "iron2"), "distro"),
        (lambda: rmw.qos(depth=0), "depth"),
        (lambda: rmw.attachment(1, 0, b"short"), "16 bytes"),
        (lambda: rmw.read_attachment(None), "no attachment"),
        (lambda: rmw.read_attachment(b"\x00" * 32), "33 bytes"),
        (lambda: rmw.read_attachment(b"\x00" * 16 + b"\x08" + b"\x00" * 16), "length is 16"),
        (lambda: rmw.read_twist(b"\x00\x01\x00\x00garbage"), "not a CDR"),
        (lambda: rmw.read_pose(rmw.twist((1.0, 0.0))), "not a CDR"),
        (lambda: rmw.read_pose(b"", rmw.TWIST), "a pose comes as"),
        (lambda: rmw.twist((math.nan, 0.0)), "finite"),
        (lambda: rmw.Endpoint(NODE, 1, "SS", "/a", rmw.TWIST), "an endpoint is MP"),
    ],
)  # fmt: skip
def test_what_rmw_zenoh_would_not_send_is_refused_with_a_reason(call: Any, says: str) -> None:
    with pytest.raises(rmw.RmwError, match=says):
        call()


def test_a_twist_is_52_bytes_of_cdr_and_reads_back() -> None:
    data = rmw.twist((0.2, -0.1), 1.5)
    assert len(data) == 52 and data[:4] == b"\x00\x01\x00\x00"
    assert rmw.read_twist(data) == (0.2, -0.1, 1.5)


def test_a_pose_is_read_from_odometry_and_pose_stamped() -> None:
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS2_JAZZY)
    t = ts.types
    yaw = 2.5
    q = t["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2))
    pose = t["geometry_msgs/msg/Pose"](position=t["geometry_msgs/msg/Point"](x=1.5, y=-2.0, z=0.0),
                                       orientation=q)  # fmt: skip
    header = t["std_msgs/msg/Header"](stamp=t["builtin_interfaces/msg/Time"](sec=1, nanosec=2),
                                      frame_id="odom")  # fmt: skip
    stamped = t[rmw.POSE_STAMPED](header=header, pose=pose)
    x, y, h = rmw.read_pose(bytes(ts.serialize_cdr(stamped, rmw.POSE_STAMPED)), rmw.POSE_STAMPED)
    assert (x, y) == (1.5, -2.0) and h == pytest.approx(yaw, abs=1e-12)
    vector = t["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0)
    odometry = t[rmw.ODOMETRY](
        header=header, child_frame_id="base_link",
        pose=t["geometry_msgs/msg/PoseWithCovariance"](pose=pose, covariance=np.zeros(36)),
        twist=t["geometry_msgs/msg/TwistWithCovariance"](
            twist=t[rmw.TWIST](linear=vector, angular=vector), covariance=np.zeros(36)),
    )  # fmt: skip
    x, y, h = rmw.read_pose(bytes(ts.serialize_cdr(odometry, rmw.ODOMETRY)))
    assert (x, y) == (1.5, -2.0) and h == pytest.approx(yaw, abs=1e-12)


def _until_token(session: zenoh.Session, pattern: str, timeout: float = 30.0) -> None:
    """Wait, on the bus, until a liveliness token matching ``pattern`` is up."""
    up = threading.Event()
    sub = session.liveliness().declare_subscriber(pattern, lambda _s: up.set(), history=True)
    try:
        assert up.wait(timeout), f"no token {pattern} within {timeout} s"
    finally:
        sub.undeclare()


@pytest.fixture(scope="module")
def ros_router() -> Iterator[str]:
    """One router for the module: the other client keeps one session per process, bound to
    the first router it meets, and loses its registered types when that session is closed."""
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    with Swarm() as swarm:
        child = swarm.spawn("router", "router", ["router", "--listen", endpoint], ready_pipe=True)
        swarm.wait_ready(child, 30.0)
        yield endpoint


@pytest.fixture(scope="module")
def partner(sdk: Any, ros_router: str) -> Iterator[tuple[Any, int]]:
    yield sdk, int(ros_router.rsplit(":", 1)[1])
    session = sdk.ZenohSession._instance
    if session is not None:
        session.close()


@pytest.mark.integration
def test_a_twist_shoal_publishes_reaches_an_rmw_zenoh_subscriber(
    partner: tuple[Any, int], ros_router: str
) -> None:
    """The other client subscribes to /robot1/cmd_vel as a ROS 2 node would (it computes the
    key and hash itself); shoal declares its node and publisher tokens, waits for the
    subscriber's token and publishes once, with its attachment: the message arrives whole."""
    sdk, port = partner
    got: list[Any] = []
    arrived = threading.Event()

    def heard(msg: Any) -> None:
        got.append(msg)
        arrived.set()

    subscriber = sdk.ROS2Subscriber("/robot1/cmd_vel", rmw.TWIST, heard, domain_id=0,
                                    router_port=port)  # fmt: skip
    try:
        with client(ros_router) as session:
            node = rmw.Node(domain=0, zid=str(session.zid()), nid=0, name="shoal_world")
            cmd = rmw.Endpoint(node, 1, "MP", "/robot1/cmd_vel", rmw.TWIST)
            tokens = [session.liveliness().declare_token(t) for t in (node.token(), cmd.token())]
            _until_token(session, "@ros2_lv/0/**/MS/**/%robot1%cmd_vel/**")
            publisher = session.declare_publisher(cmd.key)
            publisher.put(rmw.twist((0.15, 0.0), -0.75),
                          attachment=rmw.attachment(1, time.time_ns(), cmd.gid()))  # fmt: skip
            assert arrived.wait(30.0), "the Twist did not arrive"
            publisher.undeclare()
            for token in tokens:
                token.undeclare()
    finally:
        subscriber.close()
    (msg,) = got
    assert (msg.linear.x, msg.linear.y, msg.angular.z) == (0.15, 0.0, -0.75)


@pytest.mark.integration
def test_a_twist_an_rmw_zenoh_publisher_sends_is_read_by_shoal(
    partner: tuple[Any, int], ros_router: str
) -> None:
    """The other client publishes on /robot2/cmd_vel; shoal subscribes to the key it computes
    itself and reads the attachment and the CDR."""
    sdk, port = partner
    samples: list[zenoh.Sample] = []
    arrived = threading.Event()
    publisher = sdk.ROS2Publisher("/robot2/cmd_vel", rmw.TWIST, domain_id=0, router_port=port)
    try:
        with client(ros_router) as session:
            key = rmw.topic_key(0, "/robot2/cmd_vel", rmw.TWIST)
            sub = session.declare_subscriber(key, lambda s: (samples.append(s), arrived.set()))
            _until_token(session, "@ros2_lv/0/**/MP/**/%robot2%cmd_vel/**")
            vector = sdk.get_message_class("geometry_msgs/msg/Vector3")
            while not arrived.is_set():  # until the router routes to our subscription
                publisher.publish(linear=vector(x=0.3, y=0.0, z=0.0),
                                  angular=vector(x=0.0, y=0.0, z=0.2))  # fmt: skip
                arrived.wait(0.2)
            sub.undeclare()
    finally:
        publisher.close()
    sample = samples[0]
    attached = sample.attachment
    sequence, stamp, gid = rmw.read_attachment(None if attached is None else attached.to_bytes())
    assert sequence >= 0 and stamp > 0 and len(gid) == 16
    assert rmw.read_twist(sample.payload.to_bytes()) == (0.3, 0.0, 0.2)


@pytest.mark.integration
def test_simulated_robots_obey_and_report_to_an_rmw_zenoh_client(
    partner: tuple[Any, int], ros_router: str
) -> None:
    """``shoal robots`` (two holonomic robots of `default`, as clients of the module's router,
    domain 5, namespaces /bot1 and /bot2) as the other client sees them: it hears their
    odometry (decoding the CDR itself, from the .msg definitions above) at agent 2's start,
    and a Twist it publishes on /bot1/cmd_vel moves robot 1 along x, and only along x."""
    sdk, port = partner
    starts = load_scenario("default").initial_positions
    poses: dict[int, list[Any]] = {1: [], 2: []}
    heard = threading.Condition()

    def listener(i: int) -> Any:
        def got(msg: Any) -> None:
            with heard:
                poses[i].append(msg)
                heard.notify_all()

        return got

    proc = subprocess.Popen(
        [sys.executable, "-m", "shoal.tools", "robots", "default", "-n", "2", "--connect",
         ros_router, "--domain", "5", "--prefix", "bot", "--rate", "40"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    subscribers, publisher = [], None
    try:
        assert proc.stdout is not None and proc.stdout.readline().startswith("ready robots 2")
        for i in (1, 2):
            subscribers.append(sdk.ROS2Subscriber(f"/bot{i}/odom", rmw.ODOMETRY, listener(i),
                                                  domain_id=5, router_port=port))  # fmt: skip
        with heard:
            assert heard.wait_for(lambda: len(poses[1]) >= 2 and len(poses[2]) >= 2, 30.0)
        first = poses[1][-1].pose.pose.position
        second = poses[2][-1].pose.pose.position
        assert (first.x, first.y) == (starts[0][0], starts[0][1])
        assert (second.x, second.y) == (starts[1][0], starts[1][1])
        assert poses[2][-1].child_frame_id == "base_link"
        publisher = sdk.ROS2Publisher("/bot1/cmd_vel", rmw.TWIST, domain_id=5, router_port=port)
        vector = sdk.get_message_class("geometry_msgs/msg/Vector3")

        def gone(distance: float) -> bool:
            return poses[1][-1].pose.pose.position.x >= first.x + distance

        while True:
            publisher.publish(linear=vector(x=0.4, y=0.0, z=0.0),
                              angular=vector(x=0.0, y=0.0, z=0.0))  # fmt: skip
            with heard:
                if heard.wait_for(lambda: gone(0.1), 0.1):  # pacing: a command every 0.1 s
                    break
        now = poses[1][-1]
        assert now.pose.pose.position.y == first.y and now.pose.pose.orientation.z == 0.0
        assert now.twist.twist.linear.x == 0.4
    finally:
        if publisher is not None:
            publisher.close()
        for sub in subscribers:
            sub.close()
        proc.send_signal(signal.SIGINT)
        _out, err = proc.communicate(timeout=20.0)
    assert "0 malformed dropped" in err, err


class PartnerFleet:
    """Holonomic robots written with the other client alone: robot i hears /p<i>/cmd_vel and
    publishes /p<i>/odom every 10 ms, having moved by what it last heard (world frame: every
    robot faces +x), as a ROS 2 driver would."""

    def __init__(self, sdk: Any, port: int, starts: Any, domain: int) -> None:
        self.n = len(starts)
        self.positions = [[float(x), float(y)] for x, y in starts]
        self.commands = [(0.0, 0.0)] * self.n
        self.heard: list[list[tuple[float, float, float]]] = [[] for _ in range(self.n)]
        self.lock = threading.Lock()
        self.stop = threading.Event()
        self.subscribers = [
            sdk.ROS2Subscriber(f"/p{i + 1}/cmd_vel", rmw.TWIST, self._heard(i), domain_id=domain,
                               router_port=port)
            for i in range(self.n)
        ]  # fmt: skip
        self.publishers = [
            sdk.ROS2Publisher(f"/p{i + 1}/odom", rmw.ODOMETRY, domain_id=domain, router_port=port)
            for i in range(self.n)
        ]
        # The classes after the endpoints: those register the types with the client's store.
        self.classes = {name.rsplit("/", 1)[-1]: sdk.get_message_class(name) for name in (
            "builtin_interfaces/msg/Time", "std_msgs/msg/Header", "geometry_msgs/msg/Point",
            "geometry_msgs/msg/Quaternion", "geometry_msgs/msg/Pose",
            "geometry_msgs/msg/PoseWithCovariance", "geometry_msgs/msg/Vector3",
            "geometry_msgs/msg/Twist", "geometry_msgs/msg/TwistWithCovariance")}  # fmt: skip
        self.thread = threading.Thread(target=self._drive, daemon=True)
        self.thread.start()

    def _heard(self, i: int) -> Any:
        def heard(msg: Any) -> None:
            with self.lock:
                self.commands[i] = (float(msg.linear.x), float(msg.linear.y))
                self.heard[i].append((msg.linear.x, msg.linear.y, msg.angular.z))

        return heard

    def _drive(self) -> None:
        c = self.classes
        last = time.monotonic()
        while not self.stop.wait(0.01):
            now = time.monotonic()
            with self.lock:
                for p, (vx, vy) in zip(self.positions, self.commands, strict=True):
                    p[0] += (now - last) * vx
                    p[1] += (now - last) * vy
                poses = [tuple(p) for p in self.positions]
            last = now
            stamp = time.time_ns()
            for (x, y), publisher in zip(poses, self.publishers, strict=True):
                zero = c["Vector3"](x=0.0, y=0.0, z=0.0)
                publisher.publish(
                    header=c["Header"](stamp=c["Time"](sec=stamp // 10**9,
                                                       nanosec=stamp % 10**9),
                                       frame_id="odom"),
                    child_frame_id="base_link",
                    pose=c["PoseWithCovariance"](
                        pose=c["Pose"](position=c["Point"](x=x, y=y, z=0.0),
                                       orientation=c["Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0)),
                        covariance=np.zeros(36)),
                    twist=c["TwistWithCovariance"](twist=c["Twist"](linear=zero, angular=zero),
                                                   covariance=np.zeros(36)),
                )  # fmt: skip

    def close(self) -> None:
        self.stop.set()
        self.thread.join(timeout=10.0)
        for endpoint in (*self.publishers, *self.subscribers):
            endpoint.close()


@pytest.mark.integration
def test_a_formation_of_robots_shoal_did_not_write_reaches_its_goal(
    partner: tuple[Any, int], ros_router: str, tmp_path: Any
) -> None:
    """Five holonomic robots of the other client (domain 6, namespaces /p1…/p5) and
    ``shoal run --robots ros2``: the world takes their odometry, sends their Twists, and the
    formation arrives with 0 collisions, every guard and separation kept; every robot's last
    command is a zero Twist; nothing the world heard was dropped. The route turns a corner
    at its goal (2 m more, square to it): a leader that must land within 1 nm, seen through
    late poses, stalled at such a corner for good."""
    import yaml

    from shoal.tools.campaign.fields import FieldOptions, make_field
    from shoal.world.loader import scenario_from_dict

    sdk, port = partner
    opts = FieldOptions(length=8.0, tail=3.0, speed_limit=4.0)
    drawn = yaml.safe_load(make_field(load_scenario("obstacles"), 5, options=opts).source)
    points, speed = drawn["leader"]["waypoints"], drawn["leader"]["speed"]
    (x0, y0), (x1, y1) = points[-2], points[-1]
    leg = math.hypot(x1 - x0, y1 - y0)
    points.append([x1 - 2.0 * (y1 - y0) / leg, y1 + 2.0 * (x1 - x0) / leg])
    drawn["duration"] += 2.0 / speed
    field = scenario_from_dict(drawn)
    path = tmp_path / "field.yaml"
    path.write_text(yaml.safe_dump(drawn), encoding="utf-8")
    robots = PartnerFleet(sdk, port, field.initial_positions, domain=6)
    try:
        proc = subprocess.run(
            [sys.executable, "-m", "shoal.tools", "run", str(path), "--clock", "realtime",
             "--robots", "ros2", "--ros-connect", ros_router, "--ros-domain", "6",
             "--ros-prefix", "p", "--json", "--no-foxglove", "--out", str(tmp_path / "r.mcap")],
            capture_output=True, text=True, timeout=300,
        )  # fmt: skip
    finally:
        robots.close()
    assert proc.returncode == 0, proc.stderr
    summary = json.loads(proc.stdout)
    assert summary["collisions"] == 0 and summary["arrived"] is True, summary
    # The world certifies each step from the pose a robot last reported (up to pose_age_max
    # old) and the robot starts it a tick later, at the tick's end, plus the link: it can be
    # v_max × (age + 2 dt) off the step certified (docs/ros2.md, measured, not proven). Within:
    late = field.speed_limit * (summary["pose_age_max_ms"] / 1e3 + 2 * field.dt)
    assert summary["min_clearance"] >= field.control.safety_margin - late
    assert summary["min_interagent_distance"] >= field.separation - 2 * late
    assert summary["robot_poses_dropped"] == 0 and summary["robot_poses"] > 0
    assert summary["robot_commands"] >= 5 * field.steps
    assert all(heard and heard[-1] == (0.0, 0.0, 0.0) for heard in robots.heard)
    # the log records each tick what the robots were sent, as they heard it, and their poses' age
    from shoal.bus import codec
    from shoal.tools.log.reader import iter_channel

    logged = [codec.decode_robots(d) for _t, d, _ns in iter_channel(tmp_path / "r.mcap",
                                                                    "/world/robots")]  # fmt: skip
    assert [r.tick for r in logged] == list(range(len(logged))) and len(logged) >= field.steps
    for i, heard in enumerate(robots.heard):
        sent = np.array([r.twists[i] for r in logged])
        assert np.allclose(np.array(heard[: len(sent)]), sent, rtol=0.0, atol=1e-12)
    ages_ms = [1e3 * max(r.ages) for r in logged]
    assert 0.0 < max(ages_ms) <= summary["pose_age_max_ms"] + 1e-9  # the last look is after
    print(f"\npartner robots: {summary['robot_poses']} poses heard, arrived at "
          f"{summary['arrival_time']} s, clearance {summary['min_clearance']:.4f} m, "
          f"separation {summary['min_interagent_distance']:.4f} m, pose age p99 "
          f"{summary['pose_age_p99_ms']:.1f} ms, max {summary['pose_age_max_ms']:.1f} ms, "
          f"pose holds {summary['pose_holds']}")  # fmt: skip
