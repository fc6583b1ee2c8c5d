"""Replaying a run's log onto Zenoh: the raw msgpack channels, on their original keys, with
their original timing (scaled by ``rate``), as ``ros2 bag play`` does for a bag."""

from __future__ import annotations

import re
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import zenoh
from mcap.reader import make_reader

from shoal.bus.links import publisher

MATCH_WAIT_S = 1.0  # how long to wait for a subscriber per key before playing anyway


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


def messages(path: Path, selection: Selection) -> Iterator[tuple[str, bytes, int]]:
    with path.open("rb") as f:
        for _schema, channel, message in make_reader(f).iter_messages(log_time_order=True):
            if channel.message_encoding == "msgpack" and selection.wants(channel.topic):
                key = channel.metadata.get("zenoh_key", channel.topic)
                yield key, message.data, message.log_time


def replay(
    session: zenoh.Session,
    path: Path,
    *,
    rate: float = 1.0,
    start_offset: float = 0.0,
    selection: Selection = Selection(),
    progress: Callable[[float, float], None] | None = None,
) -> int:
    """Play ``path`` once; returns the number of messages published. ``progress(done_s,
    total_s)`` follows the log's own time."""
    plan = list(messages(path, selection))
    if not plan:
        return 0
    t0 = plan[0][2] + int(start_offset * 1e9)
    total = (plan[-1][2] - t0) / 1e9
    pubs = {key: publisher(session, key) for key in {k for k, _d, _t in plan}}
    deadline = time.monotonic() + MATCH_WAIT_S
    while not all(p.matching_status for p in pubs.values()) and time.monotonic() < deadline:
        time.sleep(0.01)  # routes are declared asynchronously: give subscribers a moment
    start = time.monotonic()
    sent = 0
    for key, data, t in plan:
        if t < t0:
            continue
        due = start + (t - t0) / 1e9 / rate
        wait = due - time.monotonic()
        if wait > 0:
            time.sleep(wait)  # pacing to the log's clock, not synchronisation
        pubs[key].put(data)
        sent += 1
        if progress is not None:
            progress((t - t0) / 1e9, total)
    return sent
