"""The seam under the world and agent processes: the few bus operations their loops use.

:class:`Bus` is what :class:`~shoal.world.process.World` and
:class:`~shoal.agent.process.AgentNode` talk to: publish, subscribe, watch and declare presence
(liveliness), serve and ask queries. :class:`ZenohBus` is the real one, over a Zenoh session
(bus/links.py decides reliability and congestion); :class:`~shoal.bus.memory.MemoryBus` is an
in-process one for unit tests of the loops. Everything a loop declares comes back as a
:class:`Handle`, which it undeclares when it closes.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Protocol, Self

import zenoh

from shoal.bus.links import publisher, still_present, subscribe, watch_presence
from shoal.bus.runtime import Inbox


class Handle(Protocol):
    """Something declared on the bus."""

    def undeclare(self) -> None: ...


class Publisher(Handle, Protocol):
    def put(self, payload: bytes) -> None: ...


@dataclass(frozen=True)
class Answer:
    """One reply to a query: a payload on ``key``, or an ``error`` text (a refusal)."""

    key: str
    payload: bytes = b""
    error: str | None = None


# What a queryable does with a query on a (concrete) key: an answer, or None for silence.
Server = Callable[[str], Answer | None]


class Bus(Protocol):
    """The operations of the process loops; keys are Zenoh key expressions."""

    def publisher(self, key: str, *, lossy: bool = False) -> Publisher: ...

    def subscribe(self, key: str, inbox: Inbox) -> Handle:
        """Samples on ``key`` arrive in ``inbox`` as ``data``."""
        ...

    def watch(self, key: str, inbox: Inbox) -> Handle:
        """Liveliness tokens matching ``key`` arrive as ``up`` (those already there too) and
        ``down``."""
        ...

    def token(self, key: str) -> Handle:
        """Declare this process's liveliness token ``key``."""
        ...

    def present(self, key: str, timeout: float = 1.0) -> bool:
        """Whether a token on ``key`` answers a liveliness query now."""
        ...

    def serve(self, key: str, server: Server) -> Handle:
        """Answer queries on ``key`` (called on the bus's thread: read state, never write)."""
        ...

    def ask(self, keys: Sequence[str], timeout: float) -> list[Answer]:
        """Query every key of ``keys`` at once and return every answer within ``timeout`` s."""
        ...


class Declarations:
    """What a process loop declared on the bus, undeclared in order (its token last) when it
    closes; a context manager. World and AgentNode are both."""

    def __init__(self) -> None:
        self._held: list[Handle] = []

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *_exc: object) -> None:
        self.close()

    def close(self) -> None:
        held, self._held = self._held, []
        for entity in held:
            entity.undeclare()


class ZenohBus:
    """:class:`Bus` over a Zenoh session."""

    def __init__(self, session: zenoh.Session) -> None:
        self.session = session

    def publisher(self, key: str, *, lossy: bool = False) -> Publisher:
        return _ZenohPublisher(publisher(self.session, key, lossy=lossy))

    def subscribe(self, key: str, inbox: Inbox) -> Handle:
        return _Undeclare(subscribe(self.session, key, inbox))

    def watch(self, key: str, inbox: Inbox) -> Handle:
        return _Undeclare(watch_presence(self.session, key, inbox))

    def token(self, key: str) -> Handle:
        return _Undeclare(self.session.liveliness().declare_token(key))

    def present(self, key: str, timeout: float = 1.0) -> bool:
        return still_present(self.session, key, timeout=timeout)

    def serve(self, key: str, server: Server) -> Handle:
        def answer(query: zenoh.Query) -> None:
            with query:
                reply = server(str(query.key_expr))
                if reply is None:
                    return
                if reply.error is not None:
                    query.reply_err(reply.error)
                else:
                    query.reply(reply.key, reply.payload)

        return _Undeclare(self.session.declare_queryable(key, answer))

    def ask(self, keys: Sequence[str], timeout: float) -> list[Answer]:
        pending = [self.session.get(key, timeout=timeout) for key in keys]  # all in flight
        out = []
        for replies in pending:
            for reply in replies:
                if reply.ok is not None:
                    out.append(Answer(str(reply.ok.key_expr), reply.ok.payload.to_bytes()))
                elif reply.err is not None:
                    why = reply.err.payload.to_bytes().decode(errors="replace")
                    out.append(Answer("", error=why))
        return out


class _Undeclare:
    def __init__(self, entity: object) -> None:
        self._entity: object | None = entity

    def undeclare(self) -> None:
        entity, self._entity = self._entity, None
        if entity is not None:
            undeclare = getattr(entity, "undeclare", None)
            if undeclare is not None:
                undeclare()


class _ZenohPublisher(_Undeclare):
    def __init__(self, pub: zenoh.Publisher) -> None:
        super().__init__(pub)
        self._pub = pub

    def put(self, payload: bytes) -> None:
        self._pub.put(payload)
