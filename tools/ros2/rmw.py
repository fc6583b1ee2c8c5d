"""rmw_zenoh's wire, as pure functions: what a ROS 2 node on Zenoh (ROS 2 Jazzy and later, with
``RMW_IMPLEMENTATION=rmw_zenoh_cpp``) expects of a publisher or a subscriber it has never heard
of, so that shoal can talk to ROS 2 robots with no ROS install (docs/ros2.md).

What is checked, and where (rmw_zenoh's docs/design.md and ``liveliness_utils.cpp``, ``qos.cpp``,
``attachment_helpers.cpp``; ../shared/notes/ecosystem.md, "ROS 2 over rmw_zenoh"):

- a topic's data is put on ``<domain>/<name without its outer slashes>/<DDS type>/<type hash>``,
  the DDS type spelled ``geometry_msgs::msg::dds_::Twist_`` and the hash ``RIHS01_<64 hex>``
  (Humble: the literal ``TypeHashNotSupported``);
- every node, publisher and subscriber declares a liveliness token
  ``@ros2_lv/<domain>/<zid>/<nid>/<eid>/<NN|MP|MS>/<enclave>/<namespace>/<node>[/<topic>/<type>/
  <hash>/<qos>]``, each ``/`` inside a name written ``%`` and an empty name ``%``; a node's
  token repeats its id where an entity's id goes;
- the QoS field ``<reliability>:<durability>:<history>,<depth>:<deadline s>,<ns>:<lifespan s>,
  <ns>:<liveliness>,<s>,<ns>`` leaves every value at rmw_zenoh's default empty (reliable,
  volatile, keep-last, depth 42, infinite, automatic);
- every sample carries a 33-byte attachment, little-endian: int64 sequence number (from 1),
  int64 source timestamp in ns, a length byte 16 and a 16-byte GID; rmw_zenoh's subscribers drop
  a sample without one (rmw_zenoh #479);
- the payload is CDR, little-endian (rosbags serialises it, and gives the type hashes).

rmw_zenoh makes the GID an XXH3-128 of the entity's token; receivers treat it as opaque bytes
that name the sender, so shoal uses a BLAKE2b-128 of the token (hashlib: no new dependency).
"""

from __future__ import annotations

import functools
import hashlib
import math
import struct
from dataclasses import dataclass
from typing import Any

import numpy as np

ADMIN = "@ros2_lv"
DISTROS = ("humble", "jazzy", "kilted", "rolling")
TWIST = "geometry_msgs/msg/Twist"
ODOMETRY = "nav_msgs/msg/Odometry"
POSE_STAMPED = "geometry_msgs/msg/PoseStamped"
ATTACHMENT_BYTES = 33
_ATTACHMENT = struct.Struct("<qqB16s")


class RmwError(ValueError):
    """Bytes that are not what rmw_zenoh sends, or a name it cannot carry."""


@functools.cache
def _typestore() -> Any:
    from rosbags.typesys import Stores, get_typestore  # the ros2 extra: imported when used

    return get_typestore(Stores.ROS2_JAZZY)


def dds_type(name: str) -> str:
    """``geometry_msgs/msg/Twist`` as rmw_zenoh spells it in keys and tokens:
    ``geometry_msgs::msg::dds_::Twist_``."""
    package, kind, message = _split(name)
    return f"{package}::{kind}::dds_::{message}_"


def type_hash(name: str, distro: str = "jazzy") -> str:
    """The type's RIHS01 hash (Jazzy's definitions; Kilted and Rolling keep these messages'),
    or Humble's ``TypeHashNotSupported``."""
    if distro not in DISTROS:
        raise RmwError(f"distro must be one of {', '.join(DISTROS)}, got {distro!r}")
    _split(name)
    if distro == "humble":
        return "TypeHashNotSupported"
    return str(_typestore().hash_rihs01(name))


def _split(name: str) -> tuple[str, str, str]:
    parts = name.split("/")
    if len(parts) != 3 or not all(parts) or parts[1] not in ("msg", "srv"):
        raise RmwError(f"a ROS 2 type is package/msg/Name, got {name!r}")
    return parts[0], parts[1], parts[2]


def mangle(name: str) -> str:
    """A name inside a token: ``/`` written ``%``; an empty name (or the root) is ``%``."""
    return "%" if name in ("", "/") else name.replace("/", "%")


def topic_key(domain: int, topic: str, name: str, distro: str = "jazzy") -> str:
    """Where a topic's samples travel: ``<domain>/<topic>/<DDS type>/<hash>``."""
    return f"{domain}/{_topic(topic)}/{dds_type(name)}/{type_hash(name, distro)}"


def _topic(topic: str) -> str:
    inner = topic.strip("/")
    if not inner or "//" in inner or any(c in inner for c in "*$?#"):
        raise RmwError(f"not a ROS 2 topic name: {topic!r}")
    return inner


def qos(*, reliable: bool = True, depth: int = 10, transient_local: bool = False) -> str:
    """The QoS field of an endpoint's token, keep-last ``depth``, with rmw_zenoh's defaults left
    empty: reliable volatile depth 10 is ``::,10:,:,:,,``."""
    if not 1 <= depth <= 2**31 - 1:
        raise RmwError(f"history depth must be positive, got {depth}")
    reliability = "" if reliable else "2"
    durability = "1" if transient_local else ""
    history = "" if depth == 42 else str(depth)
    return f"{reliability}:{durability}:,{history}:,:,:,,"


@dataclass(frozen=True)
class Node:
    """A ROS 2 node as rmw_zenoh announces it: its Zenoh session id ``zid`` (as zenoh-python
    prints it), its id ``nid`` in that session, the domain, namespace and name."""

    domain: int
    zid: str
    nid: int
    name: str
    namespace: str = ""
    enclave: str = "%"

    def token(self) -> str:
        return (
            f"{ADMIN}/{self.domain}/{self.zid}/{self.nid}/{self.nid}/NN/{self.enclave}/"
            f"{mangle(self.namespace)}/{mangle(self.name)}"
        )


@dataclass(frozen=True)
class Endpoint:
    """A publisher (``MP``) or subscriber (``MS``) of ``node`` on ``topic``, entity id ``eid``."""

    node: Node
    eid: int
    kind: str
    topic: str
    type_name: str
    distro: str = "jazzy"
    qos: str = qos()

    def __post_init__(self) -> None:
        if self.kind not in ("MP", "MS"):
            raise RmwError(f"an endpoint is MP (publisher) or MS (subscriber), got {self.kind!r}")

    @property
    def key(self) -> str:
        return topic_key(self.node.domain, self.topic, self.type_name, self.distro)

    def token(self) -> str:
        n = self.node
        name = "/" + _topic(self.topic)
        return (
            f"{ADMIN}/{n.domain}/{n.zid}/{n.nid}/{self.eid}/{self.kind}/{n.enclave}/"
            f"{mangle(n.namespace)}/{mangle(n.name)}/{mangle(name)}/{dds_type(self.type_name)}/"
            f"{type_hash(self.type_name, self.distro)}/{self.qos}"
        )

    def gid(self) -> bytes:
        """16 bytes naming this endpoint in its samples' attachments."""
        return hashlib.blake2b(self.token().encode(), digest_size=16).digest()


def attachment(sequence: int, stamp_ns: int, gid: bytes) -> bytes:
    """A sample's attachment: sequence number, source time (ns), 16, the GID."""
    if len(gid) != 16:
        raise RmwError(f"a GID is 16 bytes, got {len(gid)}")
    return _ATTACHMENT.pack(sequence, stamp_ns, 16, gid)


def read_attachment(data: bytes | None) -> tuple[int, int, bytes]:
    """(sequence, stamp_ns, gid) of a sample's attachment; :class:`RmwError` if it is not one."""
    if data is None:
        raise RmwError("no attachment: rmw_zenoh always sends one")
    if len(data) != ATTACHMENT_BYTES:
        raise RmwError(f"an attachment is {ATTACHMENT_BYTES} bytes, got {len(data)}")
    sequence, stamp, length, gid = _ATTACHMENT.unpack(data)
    if length != 16:
        raise RmwError(f"an attachment's GID length is 16, got {length}")
    return sequence, stamp, gid


def twist(linear: tuple[float, float], angular_z: float = 0.0) -> bytes:
    """A ``geometry_msgs/msg/Twist`` in CDR: a unicycle's (v, 0) and ω, or a holonomic robot's
    (v_x, v_y) and 0 — in the robot's own frame, as ``cmd_vel`` takes it."""
    values = (*linear, angular_z)
    if not all(math.isfinite(x) for x in values):
        raise RmwError(f"a command must be finite, got {values}")
    ts = _typestore()
    vector = ts.types["geometry_msgs/msg/Vector3"]
    message = ts.types[TWIST](
        linear=vector(x=float(linear[0]), y=float(linear[1]), z=0.0),
        angular=vector(x=0.0, y=0.0, z=float(angular_z)),
    )
    return bytes(ts.serialize_cdr(message, TWIST))


def odometry(
    pose: tuple[float, float, float],
    stamp_ns: int,
    *,
    frame_id: str = "odom",
    child_frame_id: str = "base_link",
    speed: tuple[float, float, float] = (0.0, 0.0, 0.0),
) -> bytes:
    """A ``nav_msgs/msg/Odometry`` in CDR, as a ground robot's driver publishes it: ``pose``
    (x, y, yaw) in ``frame_id`` at ``stamp_ns`` (ns since the epoch), and ``speed`` (linear x,
    linear y, angular z) in ``child_frame_id``, covariances zero (unknown)."""
    x, y, yaw = pose
    if not all(math.isfinite(v) for v in (*pose, *speed)) or stamp_ns < 0:
        raise RmwError(f"an odometry must be finite and stamped, got {pose}, {speed}, {stamp_ns}")
    ts = _typestore()
    t = ts.types
    vector = t["geometry_msgs/msg/Vector3"]
    header = t["std_msgs/msg/Header"](
        stamp=t["builtin_interfaces/msg/Time"](
            sec=int(stamp_ns // 1_000_000_000), nanosec=int(stamp_ns % 1_000_000_000)
        ),
        frame_id=frame_id,
    )
    orientation = t["geometry_msgs/msg/Quaternion"](
        x=0.0, y=0.0, z=math.sin(yaw / 2.0), w=math.cos(yaw / 2.0)
    )
    position = t["geometry_msgs/msg/Point"](x=float(x), y=float(y), z=0.0)
    zeros = np.zeros(36, dtype=np.float64)
    message = t[ODOMETRY](
        header=header,
        child_frame_id=child_frame_id,
        pose=t["geometry_msgs/msg/PoseWithCovariance"](
            pose=t["geometry_msgs/msg/Pose"](position=position, orientation=orientation),
            covariance=zeros,
        ),
        twist=t["geometry_msgs/msg/TwistWithCovariance"](
            twist=t[TWIST](
                linear=vector(x=float(speed[0]), y=float(speed[1]), z=0.0),
                angular=vector(x=0.0, y=0.0, z=float(speed[2])),
            ),
            covariance=zeros,
        ),
    )
    return bytes(ts.serialize_cdr(message, ODOMETRY))


def read_twist(payload: bytes) -> tuple[float, float, float]:
    """(linear x, linear y, angular z) of a CDR Twist."""
    m = _decode(payload, TWIST)
    return float(m.linear.x), float(m.linear.y), float(m.angular.z)


def read_pose(payload: bytes, type_name: str = ODOMETRY) -> tuple[float, float, float]:
    """(x, y, yaw) of a robot from a CDR ``nav_msgs/msg/Odometry`` or
    ``geometry_msgs/msg/PoseStamped``: the pose's position and the heading of its orientation."""
    if type_name not in (ODOMETRY, POSE_STAMPED):
        raise RmwError(f"a pose comes as {ODOMETRY} or {POSE_STAMPED}, not {type_name}")
    m = _decode(payload, type_name)
    pose = m.pose.pose if type_name == ODOMETRY else m.pose
    q = pose.orientation
    yaw = math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))
    x, y = float(pose.position.x), float(pose.position.y)
    if not all(math.isfinite(v) for v in (x, y, yaw)):
        raise RmwError(f"a pose must be finite, got ({x}, {y}, {yaw})")
    return x, y, yaw


def _decode(payload: bytes, type_name: str) -> Any:
    try:
        return _typestore().deserialize_cdr(payload, type_name)
    except Exception as exc:  # rosbags raises several kinds on truncated or foreign bytes
        raise RmwError(f"not a CDR {type_name}: {exc}") from None
