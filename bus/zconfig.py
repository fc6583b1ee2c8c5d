"""The one place that builds a Zenoh configuration.

Order of precedence, lowest first: Zenoh's defaults; a config file (``--zenoh-config`` or the
``ZENOH_CONFIG`` environment variable, as zenoh itself reads it); ``ZENOH_CONFIG_OVERRIDE``
(``key=json5;key=json5``, rmw_zenoh's convention); then what shoal sets explicitly: the mode,
the connect and listen endpoints, and multicast scouting, which is off unless asked for. A
client with no config file or override of its own retries its router for 30 s. In the secured
mode (``secure``, see bus/secure.py) shoal also sets TLS, usrpwd and, for the router, the ACL,
and refuses any endpoint that is not ``tls/``.
"""

from __future__ import annotations

import json
import os
from collections.abc import Sequence
from pathlib import Path

import zenoh

from shoal.bus.errors import WireError
from shoal.bus.secure import Identity, check_tls_endpoints, secure_settings

MODES = ("client", "peer", "router")
CLIENT_CONNECT_MS = 30_000  # how long a client keeps trying to reach its router


def zenoh_config(
    *,
    mode: str,
    connect: Sequence[str] = (),
    listen: Sequence[str] = (),
    config_file: Path | None = None,
    multicast: bool = False,
    secure: Identity | None = None,
) -> zenoh.Config:
    """A Zenoh configuration for a shoal process (secured if ``secure`` is given)."""
    if mode not in MODES:
        raise WireError(f"zenoh mode {mode!r}: use one of {', '.join(MODES)}")
    if secure is not None:
        check_tls_endpoints([*connect, *listen])
        if multicast or mode == "peer":
            # Peers found by scouting would link to each other directly, around the router's ACL.
            raise WireError("secured mode: clients of one router only (no peers, no multicast)")
    path = config_file or (
        Path(os.environ["ZENOH_CONFIG"]) if os.environ.get("ZENOH_CONFIG") else None
    )
    try:
        conf = zenoh.Config.from_file(str(path)) if path else zenoh.Config()
    except Exception as exc:  # zenoh raises its own ZError for unreadable files
        raise WireError(f"zenoh config {path}: {exc}") from None
    for item in filter(None, os.environ.get("ZENOH_CONFIG_OVERRIDE", "").split(";")):
        key, sep, value = item.partition("=")
        if not sep:
            raise WireError(f"ZENOH_CONFIG_OVERRIDE: {item!r} is not key=json5")
        _insert(conf, key.strip(), value.strip())
    overridden = "connect/timeout_ms" in os.environ.get("ZENOH_CONFIG_OVERRIDE", "")
    if mode == "client" and path is None and not overridden:
        # Zenoh's client default is a single attempt; a loaded machine can miss it (seen with
        # 50 agents starting at once on 2 cores). Keep trying for a while instead.
        _insert(conf, "connect/timeout_ms", str(CLIENT_CONNECT_MS))
    _insert(conf, "mode", json.dumps(mode))
    if connect:
        _insert(conf, "connect/endpoints", json.dumps(list(connect)))
    if listen:
        _insert(conf, "listen/endpoints", json.dumps(list(listen)))
    _insert(conf, "scouting/multicast/enabled", json.dumps(multicast))
    if mode == "router":
        _insert(conf, "scouting/delay", "0")  # else a router's open() blocks 500 ms
    if secure is not None:
        for key, value in secure_settings(secure, mode).items():
            _insert(conf, key, json.dumps(value))
    return conf


def _insert(conf: zenoh.Config, key: str, value: str) -> None:
    try:
        conf.insert_json5(key, value)
    except Exception as exc:
        raise WireError(f"zenoh config {key} = {value}: {exc}") from None
