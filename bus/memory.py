"""An in-process :class:`~shoal.bus.seam.Bus`, for unit tests of the process loops.

Every operation is delivered at once, in the caller's thread, to the inboxes (thread-safe
queues) of whoever matches: a world and its agents can run as threads of one test, with no
router, no ports and no timing. Key expressions match chunk by chunk, ``*`` one chunk and
``**`` any number of them, as in Zenoh; a put or a query is always on a concrete key here.
Nothing is lost, nothing is late: what a test of a loop wants, not what a network does.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Sequence
from typing import TypeVar

from shoal.bus.runtime import Arrival, ArrivalKind, Inbox
from shoal.bus.seam import Answer, Handle, Publisher, Server

_T = TypeVar("_T")


def matches(pattern: str, key: str) -> bool:
    """Whether the concrete ``key`` is one of the key expression ``pattern``'s keys."""
    return _match(pattern.split("/"), key.split("/"))


def _match(p: list[str], k: list[str]) -> bool:
    if not p:
        return not k
    if p[0] == "**":
        return any(_match(p[1:], k[i:]) for i in range(len(k) + 1))
    if not k:
        return False
    return (p[0] == "*" or p[0] == k[0]) and _match(p[1:], k[1:])


class _Entry:
    def __init__(self, remove: Callable[[], None]) -> None:
        self._remove: Callable[[], None] | None = remove

    def undeclare(self) -> None:
        remove, self._remove = self._remove, None
        if remove is not None:
            remove()


class _Pub(_Entry):
    def __init__(self, bus: MemoryBus, key: str) -> None:
        super().__init__(lambda: None)
        self._bus, self._key = bus, key

    def put(self, payload: bytes) -> None:
        self._bus.put(self._key, payload)


class MemoryBus:
    """A hub shared by every process loop of one test."""

    def __init__(self) -> None:
        self._lock = threading.RLock()
        self._subscribers: list[tuple[str, Inbox]] = []
        self._watchers: list[tuple[str, Inbox]] = []
        self._tokens: list[str] = []
        self._servers: list[tuple[str, Server]] = []
        self.published: list[tuple[str, bytes]] = []  # every put, in order (for assertions)

    # -- the Bus protocol -----------------------------------------------------------------------

    def publisher(self, key: str, *, lossy: bool = False) -> Publisher:
        return _Pub(self, key)

    def subscribe(self, key: str, inbox: Inbox) -> Handle:
        return self._add(self._subscribers, (key, inbox))

    def watch(self, key: str, inbox: Inbox) -> Handle:
        with self._lock:
            for token in self._tokens:
                if matches(key, token):
                    inbox.put(Arrival(ArrivalKind.UP, token))
            return self._add(self._watchers, (key, inbox))

    def token(self, key: str) -> Handle:
        with self._lock:
            self._tokens.append(key)
            self._tell(key, ArrivalKind.UP)

        def remove() -> None:
            with self._lock:
                self._tokens.remove(key)
                self._tell(key, ArrivalKind.DOWN)

        return _Entry(remove)

    def present(self, key: str, timeout: float = 1.0) -> bool:
        with self._lock:
            return any(matches(key, t) for t in self._tokens)

    def serve(self, key: str, server: Server) -> Handle:
        return self._add(self._servers, (key, server))

    def ask(self, keys: Sequence[str], timeout: float) -> list[Answer]:
        with self._lock:
            servers = list(self._servers)
        out = []
        for key in keys:
            for pattern, server in servers:
                if matches(pattern, key):
                    answer = server(key)
                    if answer is not None:
                        out.append(answer)
        return out

    # -- what the publishers do -----------------------------------------------------------------

    def put(self, key: str, payload: bytes) -> None:
        """Deliver ``payload`` on ``key`` to every matching subscriber; anyone may call it (a
        test injecting a malformed message, say)."""
        with self._lock:
            self.published.append((key, payload))
            inboxes = [inbox for pattern, inbox in self._subscribers if matches(pattern, key)]
        now = time.time_ns()
        for inbox in inboxes:
            inbox.put(Arrival(ArrivalKind.DATA, key, payload, now))

    @property
    def declared(self) -> int:
        """Subscribers, watchers, tokens and queryables still declared (0 once all closed)."""
        with self._lock:
            return (
                len(self._subscribers) + len(self._watchers) + len(self._tokens)
                + len(self._servers)
            )  # fmt: skip

    def _tell(self, token: str, kind: ArrivalKind) -> None:
        for pattern, inbox in self._watchers:
            if matches(pattern, token):
                inbox.put(Arrival(kind, token))

    def _add(self, where: list[_T], entry: _T) -> Handle:
        with self._lock:
            where.append(entry)

        def remove() -> None:
            with self._lock:
                where.remove(entry)

        return _Entry(remove)
