"""``shoal logger``: record a run into an MCAP file."""

from __future__ import annotations

from pathlib import Path

import click

from shoal.bus.acl import LOGGER
from shoal.bus.runtime import exit_on_signals
from shoal.tools.commands.options import bus_options
from shoal.tools.log.logger import run_logger
from shoal.tools.procs.session import client_config, open_session


@click.command()
@click.option(
    "--out", "-o", type=click.Path(dir_okay=False, path_type=Path), required=True, help="MCAP file."
)
@click.option("--force", is_flag=True, help="Overwrite OUT if it exists.")
@bus_options
def logger(
    out: Path,
    force: bool,
    run_id: str,
    connect: tuple[str, ...],
    zenoh_config: Path | None,
    multicast: bool,
    secure: Path | None,
) -> None:
    """Record every message of run RUN into OUT until the run ends (or SIGINT/SIGTERM)."""
    exit_on_signals()
    conf = client_config(connect, zenoh_config, multicast, secure, LOGGER)
    with open_session(conf, "logger") as session:
        try:
            count = run_logger(session, run=run_id, out=out, overwrite=force)
        except FileExistsError:
            raise click.ClickException(f"{out} exists; pass --force to overwrite it") from None
        except OSError as exc:
            raise click.ClickException(f"{out}: cannot be written ({exc.strerror})") from None
    click.echo(f"{count} messages written to {out}", err=True)
