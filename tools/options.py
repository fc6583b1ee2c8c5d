"""Options shared by the process commands (router, world, agent, logger, run)."""

from __future__ import annotations

import re
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

import click
import zenoh

from shoal.bus.errors import WireError
from shoal.bus.keys import Keys
from shoal.bus.secure import Identity, Material
from shoal.bus.zconfig import zenoh_config

F = TypeVar("F", bound=Callable[..., Any])


def drop_options(func: F) -> F:
    """--drop-rate, --drop-seed: realtime fault injection (shoal agent, and shoal run for all)."""
    func = click.option(
        "--drop-seed", default=0, envvar="SHOAL_DROP_SEED", help="Seed of the injected drops."
    )(func)
    return click.option(
        "--drop-rate",
        type=click.FloatRange(min=0.0, max=1.0, max_open=True),
        default=0.0,
        envvar="SHOAL_DROP_RATE",
        help="Fault injection, realtime only: throw away this fraction of incoming neighbour "
        "states (seeded, counted; shoal run totals them in its summary, `injected_drops`).",
    )(func)


def bus_options(func: F) -> F:
    """--run, --connect, --zenoh-config, --multicast, --secure."""
    func = click.option(
        "--secure",
        type=click.Path(exists=True, file_okay=False, path_type=Path),
        help="Secured mode: TLS with this run's certificates, a password and the router's "
        "access rules, from DIR (made by `shoal certs DIR`; docs/security.md).",
    )(func)
    func = click.option(
        "--multicast", is_flag=True, help="Allow Zenoh multicast scouting (off by default)."
    )(func)
    func = click.option(
        "--zenoh-config",
        type=click.Path(exists=True, dir_okay=False, path_type=Path),
        help="A Zenoh JSON5 config file (ZENOH_CONFIG is honoured too).",
    )(func)
    func = click.option(
        "--connect",
        "-e",
        multiple=True,
        help="Zenoh endpoint of the router, e.g. tcp/127.0.0.1:7447 (repeatable).",
    )(func)
    func = click.option(
        "--run",
        "run_id",
        required=True,
        callback=check_run_id,
        help="The run id every key lives under.",
    )(func)
    return func


def check_run_id(_ctx: click.Context, _param: click.Parameter, value: str | None) -> str | None:
    """Refuse a run id that cannot be a Zenoh key chunk, before anything starts."""
    if value is not None:
        try:
            Keys(value)
        except WireError as exc:
            raise click.BadParameter(str(exc)) from None
    return value


def client_config(
    connect: tuple[str, ...],
    zenoh_config_file: Path | None,
    multicast: bool,
    secure: Path | None = None,
    name: str = "",
) -> zenoh.Config:
    """A client session's configuration, with errors a person can act on; with ``secure``, the
    process logs in as identity ``name`` (world, logger, monitor, agent-<i>)."""
    identity = Identity(Material(secure), name) if secure is not None else None
    try:
        return zenoh_config(
            mode="client",
            connect=connect,
            config_file=zenoh_config_file,
            multicast=multicast,
            secure=identity,
        )
    except WireError as exc:
        raise click.ClickException(str(exc)) from None


_RUST_SOURCE = re.compile(r"\s+at \S+\.rs:\d+\.?")  # "… Timeout! at /root/.cargo/…/x.rs:388."


def open_session(conf: zenoh.Config, what: str) -> zenoh.Session:
    try:
        return zenoh.open(conf)
    except Exception as exc:  # zenoh.ZError: e.g. no router at the endpoint
        why = _RUST_SOURCE.sub("", str(exc)).rstrip(".")
        raise click.ClickException(
            f"{what}: cannot open a Zenoh session: {why} (is a router running there?)"
        ) from None
