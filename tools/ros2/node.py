"""ROS 2 nodes, publishers and subscribers on a Zenoh session, as rmw_zenoh announces and frames
them (tools/ros2/rmw.py holds the formats; this holds the session's declarations): a node's and
each endpoint's liveliness token, every sample's attachment with its sequence number, and a
subscription that hands its callback the payload and the attachment as bytes.

Entity ids are unique within a session, nodes and endpoints alike, as rmw_zenoh numbers them.
Nothing here decodes a payload: a subscriber's callback does, and counts what it refuses.
"""

from __future__ import annotations

import contextlib
import itertools
import threading
import time
from collections.abc import Callable
from typing import Any

import zenoh

from shoal.tools.ros2 import rmw

RMW_ZENOHD = "tcp/127.0.0.1:7447"  # where rmw_zenoh's nodes look for their router by default
Heard = Callable[[bytes, bytes | None], None]  # (payload, attachment or None)


class RosSession:
    """A Zenoh session seen as a ROS 2 context: domain ``domain``, type hashes of ``distro``."""

    def __init__(self, session: zenoh.Session, domain: int = 0, distro: str = "jazzy") -> None:
        if not 0 <= domain <= 232:
            raise rmw.RmwError(f"a ROS 2 domain id is 0–232, got {domain}")
        rmw.type_hash(rmw.TWIST, distro)  # refuses an unknown distribution now, by name
        self.session = session
        self.domain = domain
        self.distro = distro
        self._ids = itertools.count()
        self._lock = threading.Lock()

    def next_id(self) -> int:
        with self._lock:
            return next(self._ids)

    def node(self, name: str, namespace: str = "") -> RosNode:
        return RosNode(self, name, namespace)


class RosNode:
    """One node: its token is up while it lives; :meth:`close` takes it and its endpoints down."""

    def __init__(self, ros: RosSession, name: str, namespace: str = "") -> None:
        self.ros = ros
        zid = str(ros.session.zid())
        self.info = rmw.Node(ros.domain, zid, ros.next_id(), name, namespace)
        self._held: list[Any] = [ros.session.liveliness().declare_token(self.info.token())]

    def _endpoint(self, kind: str, topic: str, type_name: str, depth: int) -> rmw.Endpoint:
        return rmw.Endpoint(
            self.info, self.ros.next_id(), kind, topic, type_name, self.ros.distro,
            rmw.qos(depth=depth),
        )  # fmt: skip

    def publisher(self, topic: str, type_name: str, depth: int = 10) -> RosPublisher:
        endpoint = self._endpoint("MP", topic, type_name, depth)
        session = self.ros.session
        publisher = session.declare_publisher(endpoint.key)
        token = session.liveliness().declare_token(endpoint.token())
        self._held += [publisher, token]
        return RosPublisher(endpoint, publisher)

    def subscriber(self, topic: str, type_name: str, heard: Heard, depth: int = 10) -> rmw.Endpoint:
        endpoint = self._endpoint("MS", topic, type_name, depth)
        session = self.ros.session

        def handler(sample: zenoh.Sample) -> None:
            attached = sample.attachment
            heard(sample.payload.to_bytes(), None if attached is None else attached.to_bytes())

        self._held.append(session.declare_subscriber(endpoint.key, handler))
        self._held.append(session.liveliness().declare_token(endpoint.token()))
        return endpoint

    def close(self) -> None:
        while self._held:
            # A closed session has taken its declarations down with it already.
            with contextlib.suppress(Exception):
                self._held.pop().undeclare()


class RosPublisher:
    """Puts each payload with the attachment rmw_zenoh's subscribers require (sequence from 1,
    source time now)."""

    def __init__(self, endpoint: rmw.Endpoint, publisher: zenoh.Publisher) -> None:
        self.endpoint = endpoint
        self._publisher = publisher
        self._gid = endpoint.gid()
        self._sequence = itertools.count(1)
        self._lock = threading.Lock()

    def put(self, payload: bytes) -> None:
        with self._lock:  # a sequence number per sample, in the order they leave
            attachment = rmw.attachment(next(self._sequence), time.time_ns(), self._gid)
            self._publisher.put(payload, attachment=attachment)
