"""Declaring Zenoh entities the way every shoal process needs them.

Publishers block rather than drop under congestion: a lockstep protocol that lost a message
would wait for it forever (Zenoh's default is DROP). The exception is a realtime run's
per-tick traffic (sensing, states, commands), published ``lossy``: there a lost message is
already tolerated (agents act on the freshest data, the world's watchdog holds an agent whose
command is stale), while blocking would let one unreachable agent stall everyone (the router's
queue towards it fills within ~2 s of a partition and then holds up every sender until the
lease drops it, 10 s later). Subscribers and presence watchers feed one
:class:`~shoal.bus.runtime.Inbox`; the returned objects must be kept alive by the caller (Zenoh
undeclares an entity when its Python object is collected).
"""

from __future__ import annotations

import time
from collections import deque
from typing import Any

import zenoh

from shoal.bus.runtime import Arrival, ArrivalKind, Inbox


def publisher(session: zenoh.Session, key: str, *, lossy: bool = False) -> zenoh.Publisher:
    """A reliable publisher on ``key`` that blocks under congestion, or drops if ``lossy``."""
    cc = zenoh.CongestionControl.DROP if lossy else zenoh.CongestionControl.BLOCK
    return session.declare_publisher(
        key,
        congestion_control=cc,
        reliability=zenoh.Reliability.RELIABLE,
    )


def subscribe(session: zenoh.Session, key: str, inbox: Inbox) -> Any:
    def arrived(sample: zenoh.Sample) -> None:
        inbox.put(
            Arrival(
                ArrivalKind.DATA, str(sample.key_expr), sample.payload.to_bytes(), time.time_ns()
            )
        )

    return session.declare_subscriber(key, arrived)


def collect(session: zenoh.Session, key: str, sink: deque[tuple[str, bytes, int]]) -> Any:
    """Like :func:`subscribe`, but append (key, payload, arrival time in ns) to ``sink`` and wake
    nobody: for a consumer that drains in batches (the logger), which then costs no thread
    switch per message. ``deque.append`` is atomic, so the callback needs no lock."""

    def arrived(sample: zenoh.Sample) -> None:
        sink.append((str(sample.key_expr), sample.payload.to_bytes(), time.time_ns()))

    return session.declare_subscriber(key, arrived)


def watch_presence(session: zenoh.Session, key: str, inbox: Inbox) -> Any:
    """Report every liveliness token matching ``key`` as "up" (including those already there)
    and "down" when it vanishes (undeclared, session closed, or the process killed)."""

    def changed(sample: zenoh.Sample) -> None:
        kind = ArrivalKind.UP if sample.kind == zenoh.SampleKind.PUT else ArrivalKind.DOWN
        inbox.put(Arrival(kind, str(sample.key_expr)))

    return session.liveliness().declare_subscriber(key, changed, history=True)


def still_present(session: zenoh.Session, key: str, timeout: float = 1.0) -> bool:
    """Whether a liveliness token on ``key`` still answers a query: the second opinion a process
    takes before acting on a token's "down" (dropping an agent, ending a run). A real departure
    has already left the router's table, so the answer is no, one round trip later; a "down"
    delivered while the token lives on (seen once in CI, under load, while two other clients'
    leases expired) is not acted on."""
    return any(r.ok is not None for r in session.liveliness().get(key, timeout=timeout))
