"""The logger process: records every message of a run into an MCAP file.

It subscribes to the run's whole key space before declaring its liveliness token, so a world
that waits for the logger's token loses nothing. Messages are stamped on arrival by the Zenoh
callback and written in batches, every ``BATCH_S`` (a main loop woken per message cost more CPU
than the writing, on a 2-core machine shared with the whole swarm). It stops, finishing the
file, when the world publishes the run's summary, when the world's token vanishes after having
been seen, or on SIGINT/SIGTERM. (After the world's token vanishes it keeps recording until
nothing arrives for ``QUIET_S``, at most ``DRAIN_S``: the summary may trail the token.)
"""

from __future__ import annotations

import time
from collections import deque
from pathlib import Path

import zenoh

from shoal.bus import codec
from shoal.bus.errors import DecodeError
from shoal.bus.keys import Keys
from shoal.bus.links import collect, watch_presence
from shoal.bus.runtime import ArrivalKind, Inbox, announce_ready, warn
from shoal.tools.log.writer import McapLog

BATCH_S = 0.01  # s between two drains of what arrived
QUIET_S = 0.5  # s without a message that ends the drain after the world's token vanished
DRAIN_S = 2.0  # s the logger keeps recording, at most, after the world's token vanished


def run_logger(session: zenoh.Session, *, run: str, out: Path, overwrite: bool = False) -> int:
    """Record until the run ends; returns the number of messages written. FileExistsError if
    ``out`` exists, unless ``overwrite``."""
    keys = Keys(run)
    presence = Inbox()
    received: deque[tuple[str, bytes, int]] = deque()
    with McapLog(out, run=run, overwrite=overwrite) as log:
        held = [
            collect(session, keys.everything, received),
            watch_presence(session, keys.alive_world, presence),
        ]
        token = session.liveliness().declare_token(keys.alive_logger)
        announce_ready(f"logger {out}")
        world_seen = False
        drain_until: float | None = None  # set once the world's token is gone
        last_data = time.monotonic()
        while True:
            change = presence.get(timeout=BATCH_S)
            kind = None if change is None else change.kind
            if kind == ArrivalKind.UP:
                world_seen = True
            elif kind == ArrivalKind.DOWN and world_seen and drain_until is None:
                # Liveliness and data travel apart: the world's last messages (its summary)
                # may still be on their way. Drain a little before finishing.
                warn("logger: the world is gone; finishing the log")
                drain_until = time.monotonic() + DRAIN_S
            if received:
                last_data = time.monotonic()
                if _write(log, keys, received):
                    break  # the summary: the run is over
            log.flush_if_due()
            now = time.monotonic()
            if drain_until is not None and (now >= drain_until or now - last_data >= QUIET_S):
                break
        del held, token
        return log.messages


def _write(log: McapLog, keys: Keys, received: deque[tuple[str, bytes, int]]) -> bool:
    """Write everything received so far, in arrival order; True once the summary is written
    (anything after it is not part of the run)."""
    while received:
        key, payload, time_ns = received.popleft()
        log.add(key, payload, time_ns)
        if key not in (keys.scenario, keys.summary):
            continue
        kind = "scenario" if key == keys.scenario else "summary"
        try:
            doc = codec.decode_document(kind, payload)
        except DecodeError as exc:
            warn(f"logger: bad {key}: {exc}")
            continue
        if kind == "scenario":
            if not log.has_scenario:  # the world's comes first; a later one is not the run's
                log.attach_scenario(str(doc.get("name")), str(doc.get("yaml")), time_ns)
        else:
            log.add_summary(doc)
            return True
    return False
