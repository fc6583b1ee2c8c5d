"""Opening a process's Zenoh session: its configuration and the session, with errors a person
can act on (:class:`SessionError`; the ``shoal`` command shows its message, not a traceback)."""

from __future__ import annotations

import re
from pathlib import Path

import zenoh

from shoal.bus.errors import WireError
from shoal.bus.secure import Identity, Material
from shoal.bus.zconfig import zenoh_config
from shoal.tools.errors import SessionError
from shoal.tools.procs.children import ClientSpec

# ms: how long a command a person runs against a router that should already be up (replay,
# run --connect) tries to reach it, rather than the 30 s a starting swarm's processes need.
PROMPT_CONNECT_MS = 5_000


def session_config(
    mode: str,
    *,
    listen: tuple[str, ...] = (),
    connect: tuple[str, ...] = (),
    config_file: Path | None = None,
    multicast: bool = False,
    secure: Path | None = None,
    name: str = "",
    connect_ms: int | None = None,
) -> zenoh.Config:
    """A session's configuration (``mode`` "client" or "router"), with errors a person can act
    on; with ``secure``, the process logs in as identity ``name`` (router, world, logger,
    monitor, agent-<i>). ``connect_ms``: how long to keep trying to reach the router (default:
    bus/zconfig.py's 30 s, which a swarm starting on a loaded machine needs; a command a person
    runs against a router that should be up answers sooner)."""
    identity = Identity(Material(secure), name) if secure is not None else None
    try:
        conf = zenoh_config(
            mode=mode,
            listen=listen,
            connect=connect,
            config_file=config_file,
            multicast=multicast,
            secure=identity,
        )
    except WireError as exc:
        raise SessionError(str(exc)) from None
    if connect_ms is not None:
        conf.insert_json5("connect/timeout_ms", str(connect_ms))
    return conf


def client_config(
    connect: tuple[str, ...],
    *,
    secure: Path | None = None,
    name: str = "",
    connect_ms: int | None = None,
) -> zenoh.Config:
    """A client of the router at ``connect`` (multicast off, no config file)."""
    return session_config(
        "client", connect=connect, secure=secure, name=name, connect_ms=connect_ms
    )


def client_session(spec: ClientSpec, name: str, what: str) -> zenoh.Session:
    """The session of a run's process (world, agent, logger) as its options say; ``name``: its
    identity in secured mode; ``what`` names it in errors."""
    conf = session_config(
        "client",
        connect=spec.connect,
        config_file=spec.zenoh_config,
        multicast=spec.multicast,
        secure=spec.secure,
        name=name,
    )
    return open_session(conf, what)


_RUST_SOURCE = re.compile(r"\s+at \S+\.rs:\d+\.?")  # "… Timeout! at /root/.cargo/…/x.rs:388."


def open_session(conf: zenoh.Config, what: str) -> zenoh.Session:
    try:
        return zenoh.open(conf)
    except Exception as exc:  # zenoh.ZError: e.g. no router at the endpoint
        why = _RUST_SOURCE.sub("", str(exc)).rstrip(".")
        raise SessionError(
            f"{what}: cannot open a Zenoh session: {why} (is a router running there?)"
        ) from None
