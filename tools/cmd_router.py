"""``shoal router``: a Zenoh router (zenoh-python in router mode; no zenohd needed)."""

from __future__ import annotations

import threading
from pathlib import Path

import click

from bus.errors import WireError
from bus.runtime import announce_ready, exit_on_signals
from bus.zconfig import zenoh_config
from tools.options import open_session


@click.command()
@click.option(
    "--listen", "-l", multiple=True, default=["tcp/127.0.0.1:7447"], help="Endpoint to listen on."
)
@click.option("--connect", "-e", multiple=True, help="Another router to mesh with (repeatable).")
@click.option(
    "--zenoh-config",
    "config_file",
    type=click.Path(exists=True, dir_okay=False, path_type=Path),
    default=None,
)
def router(listen: tuple[str, ...], connect: tuple[str, ...], config_file: Path | None) -> None:
    """Run a Zenoh router until SIGINT/SIGTERM."""
    exit_on_signals()
    try:
        conf = zenoh_config(mode="router", listen=listen, connect=connect, config_file=config_file)
    except WireError as exc:
        raise click.ClickException(str(exc)) from None
    with open_session(conf, "router"):
        announce_ready(f"router {' '.join(listen)}")
        threading.Event().wait()  # until a signal turns into SystemExit
