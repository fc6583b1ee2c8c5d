"""tools/ros2/rmw.py: rmw_zenoh's wire as shoal writes it, checked against an rmw_zenoh client
shoal did not write (zenoh-ros2-sdk 0.1.8, offline: message definitions from a folder) and the
facts in ../shared/notes/ecosystem.md; a Twist shoal publishes reaches that client's subscriber
through a real router, and one it publishes is read back by shoal."""

from __future__ import annotations

import math
import os
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

TWIST_HASH = "RIHS01_9c45bf16fe0983d80e3cfe750d6835843d265a9a6c46bd2e609fcddde6fb8d2a"
ODOMETRY_HASH = "RIHS01_3cc97dc7fb7502f8714462c526d369e35b603cfc34d946e3f2eda2766dfec6e0"
POSE_HASH = "RIHS01_10f3786d7d40fd2b54367835614bff85d4ad3b5dab62bf8bca0cc232d73b4cd8"
MSGS = {
    "geometry_msgs/msg/Vector3.msg": "float64 x\nfloat64 y\nfloat64 z\n",
    "geometry_msgs/msg/Twist.msg": "Vector3  linear\nVector3  angular\n",
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
