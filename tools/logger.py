"""The logger process: records every message of a run into an MCAP file.

It subscribes to the run's whole key space before declaring its liveliness token, so a world
that waits for the logger's token loses nothing. It stops, finishing the file, when the world
publishes the run's summary, when the world's token vanishes after having been seen, or on
SIGINT/SIGTERM. (After the world's token vanishes it keeps recording until nothing arrives
for half a second, at most 2 s: the summary may trail the token.)
"""

from __future__ import annotations

import time
from pathlib import Path

import zenoh

from bus import codec
from bus.errors import DecodeError
from bus.keys import Keys
from bus.links import subscribe, watch_presence
from bus.runtime import Inbox, announce_ready, warn
from tools.mcap_log import FLUSH_EVERY_S, McapLog

DRAIN_S = 2.0  # s the logger keeps recording after the world's token vanished


def run_logger(session: zenoh.Session, *, run: str, out: Path) -> int:
    """Record until the run ends; returns the number of messages written."""
    keys = Keys(run)
    inbox = Inbox()
    with McapLog(out, run=run) as log:
        held = [
            subscribe(session, keys.everything, inbox),
            watch_presence(session, keys.alive_world, inbox),
        ]
        token = session.liveliness().declare_token(keys.alive_logger)
        announce_ready(f"logger {out}")
        world_seen = False
        drain_until: float | None = None  # set once the world's token is gone
        while drain_until is None or time.monotonic() < drain_until:
            arrival = inbox.get(timeout=FLUSH_EVERY_S)
            if arrival is None:
                log.flush_if_due()
                if drain_until is not None:
                    break  # nothing more in flight
                continue
            if arrival.kind == "up":
                world_seen = True
                continue
            if arrival.kind == "down":
                if world_seen and drain_until is None:
                    # Liveliness and data travel apart: the world's last messages (its
                    # summary) may still be on their way. Drain a little before finishing.
                    warn("logger: the world is gone; finishing the log")
                    drain_until = time.monotonic() + DRAIN_S
                continue
            log.add(arrival.key, arrival.payload, arrival.time_ns)
            if arrival.key in (keys.scenario, keys.summary):
                try:
                    kind = "scenario" if arrival.key == keys.scenario else "summary"
                    doc = codec.decode_document(kind, arrival.payload)
                except DecodeError as exc:
                    warn(f"logger: bad {arrival.key}: {exc}")
                    continue
                if kind == "scenario":
                    log.attach_scenario(str(doc.get("name")), str(doc.get("yaml")), arrival.time_ns)
                else:
                    log.add_summary(doc)
                    break
        del held, token
        return log.messages
