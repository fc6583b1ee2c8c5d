"""Replaying a run's log: onto Zenoh, the raw msgpack channels on their original keys, and/or
to a live view (``TickSink``), the world's tick records and events; both with their original
timing (scaled by ``rate``), as ``ros2 bag play`` does for a bag."""

from __future__ import annotations

import re
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

import zenoh
from mcap.reader import make_reader

from shoal.bus.links import publisher

MATCH_WAIT_S = 1.0  # how long to wait for a subscriber per key before playing anyway
SINK_KINDS = ("tick", "event")  # the world's channels a live view is fed


class TickSink(Protocol):
    """Where a run's tick records and world events go as they arrive, with their arrival time
    (ns since the epoch): from a replayed log here, from a running swarm's monitor
    (tools/procs/launch.py); e.g. the live view (tools/foxglove/live.py). Both must return at
    once: the monitor also watches the processes."""

    def tick(self, ns: int, payload: bytes) -> None: ...

    def event(self, ns: int, payload: bytes) -> None: ...


@dataclass(frozen=True)
class Selection:
    """Which channels to play: exact topics (empty: all), then include / exclude regexes."""

    topics: tuple[str, ...] = ()
    include: str | None = None
    exclude: str | None = None

    def wants(self, topic: str) -> bool:
        if self.topics and topic not in self.topics:
            return False
        if self.include and not re.search(self.include, topic):
            return False
        return not (self.exclude and re.search(self.exclude, topic))


@dataclass(frozen=True, slots=True)
class Played:
    """One message of the replay: its Zenoh key, payload and log time (ns); ``bus``: put on
    the bus (it is selected); ``world``: "tick" or "event" for the world's records a live view
    is handed, else ""."""

    key: str
    data: bytes
    ns: int
    bus: bool
    world: str


def messages(path: Path, selection: Selection) -> Iterator[tuple[str, bytes, int]]:
    """(key, payload, log time) of the selected raw channels, in log-time order."""
    for m in played(path, selection, bus=True, world=False):
        yield m.key, m.data, m.ns


def played(path: Path, selection: Selection, *, bus: bool, world: bool) -> Iterator[Played]:
    """The messages of a replay, in log-time order: the selected ones if ``bus``, and with
    ``world`` the world's tick records and events whether selected or not."""
    with path.open("rb") as f:
        for _schema, channel, message in make_reader(f).iter_messages(log_time_order=True):
            if channel.message_encoding != "msgpack":
                continue
            parent, _, kind = channel.topic.rpartition("/")
            kind = kind if world and parent.endswith("/world") and kind in SINK_KINDS else ""
            put = bus and selection.wants(channel.topic)
            if put or kind:
                key = channel.metadata.get("zenoh_key", channel.topic)
                yield Played(key, message.data, message.log_time, put, kind)


def replay(
    session: zenoh.Session | None,
    path: Path,
    *,
    rate: float = 1.0,
    start_offset: float = 0.0,
    selection: Selection = Selection(),
    sink: TickSink | None = None,
    progress: Callable[[float, float], None] | None = None,
) -> int:
    """Play ``path`` once: the selected channels onto ``session`` (if any), and the world's
    tick records and events to ``sink`` (if any; at the wall-clock time each is due, as the
    monitor of a run hands them over as they arrive). Returns the number of messages played
    (published, or handed to the sink). ``progress(done_s, total_s)`` follows the log's time."""
    plan = list(played(path, selection, bus=session is not None, world=sink is not None))
    if not plan:
        return 0
    t0 = plan[0].ns + int(start_offset * 1e9)
    total = (plan[-1].ns - t0) / 1e9
    pubs = {}
    if session is not None:
        pubs = {key: publisher(session, key) for key in {m.key for m in plan if m.bus}}
    deadline = time.monotonic() + MATCH_WAIT_S
    while not all(p.matching_status for p in pubs.values()) and time.monotonic() < deadline:
        time.sleep(0.01)  # routes are declared asynchronously: give subscribers a moment
    start = time.monotonic()
    sent = 0
    for m in plan:
        if m.ns < t0:
            continue
        due = start + (m.ns - t0) / 1e9 / rate
        wait = due - time.monotonic()
        if wait > 0:
            time.sleep(wait)  # pacing to the log's clock, not synchronisation
        if m.bus:
            pubs[m.key].put(m.data)
        if sink is not None and m.world == "tick":
            sink.tick(time.time_ns(), m.data)
        elif sink is not None and m.world == "event":
            sink.event(time.time_ns(), m.data)
        sent += 1
        if progress is not None:
            progress((m.ns - t0) / 1e9, total)
    return sent
