"""``shoal logger``: record a run into an MCAP file."""

from __future__ import annotations

from typing import Any

import click

from shoal.bus.acl import LOGGER
from shoal.bus.runtime import exit_on_signals
from shoal.tools.log.logger import run_logger
from shoal.tools.procs.children import LoggerSpec, click_options
from shoal.tools.procs.session import client_session


@click.command()
@click_options(LoggerSpec)
def logger(**params: Any) -> None:
    """Record every message of run RUN into OUT until the run ends (or SIGINT/SIGTERM)."""
    exit_on_signals()
    spec = LoggerSpec.of(params)
    out = spec.out
    with client_session(spec, LOGGER, "logger") as session:
        try:
            count = run_logger(session, run=spec.run_id, out=out, overwrite=spec.force)
        except FileExistsError:
            raise click.ClickException(f"{out} exists; pass --force to overwrite it") from None
        except OSError as exc:
            raise click.ClickException(f"{out}: cannot be written ({exc.strerror})") from None
    click.echo(f"{count} messages written to {out}", err=True)
