"""``shoal router``: a Zenoh router (zenoh-python in router mode; no zenohd needed)."""

from __future__ import annotations

import os
import threading
from typing import Any

import click
import zenoh

from shoal.bus.acl import ROUTER
from shoal.bus.keys import Keys
from shoal.bus.links import watch_presence
from shoal.bus.runtime import ArrivalKind, Inbox, announce_ready, exit_on_signals
from shoal.tools.procs.children import RouterSpec, click_options
from shoal.tools.procs.session import open_session, session_config

# Zenoh closes a TCP link with SO_LINGER 10 s: a link to a host that went silent with data still
# unsent blocks the runtime thread that drops it for up to 10 s (eclipse-zenoh/zenoh#1101). Its
# receiving pool has 2 threads, so two agents cut off at once stopped this router reading from
# anybody for 10 s, and healthy clients, the leader among them, then expired on their lease
# (docs/multihost.md §3). With 8, up to 7 links can die at once and the others are still read.
RX_THREADS = 8
RUNTIME = f"(rx: (worker_threads: {RX_THREADS}))"


@click.command()
@click_options(RouterSpec)
def router(**params: Any) -> None:
    """Run a Zenoh router until SIGINT/SIGTERM (or until run RUN is over)."""
    exit_on_signals()
    spec = RouterSpec.of(params)
    os.environ.setdefault("ZENOH_RUNTIME", RUNTIME)  # read when the session starts; the user's wins
    listen = spec.listen or (f"{'tls' if spec.secure else 'tcp'}/127.0.0.1:7447",)
    conf = session_config(
        "router",
        listen=listen,
        connect=spec.connect,
        config_file=spec.zenoh_config,
        secure=spec.secure,
        name=ROUTER,
    )
    with open_session(conf, "router") as session:
        announce_ready(f"router {' '.join(listen)}")
        if spec.exit_after_run is None:
            threading.Event().wait()  # until a signal turns into SystemExit
        else:
            wait_for_run_end(session, Keys(spec.exit_after_run))


def wait_for_run_end(session: zenoh.Session, keys: Keys) -> None:
    """Return once the run's world token has appeared and vanished and no token of the run is
    left (agents leave with the world, the logger after draining): the router's own session
    sees every token routed through it, so no extra process is needed to watch the run."""
    inbox = Inbox()
    held = watch_presence(session, keys.alive_everyone, inbox)
    present: set[str] = set()
    world_seen = False
    while not (world_seen and not present):
        arrival = inbox.wait()
        if arrival.kind == ArrivalKind.UP:
            present.add(arrival.key)
            world_seen = world_seen or arrival.key == keys.alive_world
        elif arrival.kind == ArrivalKind.DOWN:
            present.discard(arrival.key)
    del held
