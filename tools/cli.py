"""The ``shoal`` command line: one click group, one module per subcommand.

Subcommands are imported only when invoked: an agent process (``shoal agent``) then loads the
controller and the bus but not the logger, MCAP, YAML or benchmark code, which keeps its start
fast and its memory small (there may be fifty of them on one machine).

Every shoal process is single-threaded in its numerics (vectors of two or three numbers), so
OpenBLAS is told to start no thread pool unless the user says otherwise: its threads cost each
process 0.15 s of CPU at import, which is most of a 50-agent start on two cores
(docs/performance.md).
"""

from __future__ import annotations

import importlib
import os
from typing import Any

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before anything imports numpy

import click

from shoal.tools.errors import ExtraMissing, SessionError
from shoal.tools.extras import extra_of

COMMANDS = {
    "run": "shoal.tools.commands.run:run",
    "simulate": "shoal.tools.commands.simulate:simulate",
    "scenarios": "shoal.tools.commands.scenarios:scenarios",
    "bench": "shoal.tools.commands.bench:bench",
    "router": "shoal.tools.commands.router:router",
    "robots": "shoal.tools.commands.robots:robots",
    "guard": "shoal.tools.commands.guard:guard",
    "world": "shoal.tools.commands.world:world",
    "agent": "shoal.tools.commands.agent:agent",
    "logger": "shoal.tools.commands.logger:logger",
    "certs": "shoal.tools.commands.certs:certs",
    "inspect": "shoal.tools.commands.inspect:inspect",
    "recover": "shoal.tools.commands.recover:recover",
    "verify": "shoal.tools.commands.verify:verify",
    "replay": "shoal.tools.commands.replay:replay",
    "export": "shoal.tools.commands.export:export",
    "plot": "shoal.tools.commands.plot:plot",
    "floor": "shoal.tools.commands.floor:floor",
    "campaign": "shoal.tools.commands.campaign:campaign",
    "compose": "shoal.tools.commands.compose:compose",
}


class LazyGroup(click.Group):
    """A group whose subcommands live in modules imported on first use."""

    def list_commands(self, ctx: click.Context) -> list[str]:
        return list(COMMANDS)

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        target = COMMANDS.get(cmd_name)
        if target is None:
            return None
        module, attr = target.split(":")
        command = getattr(importlib.import_module(module), attr)
        if not isinstance(command, click.Command):
            raise TypeError(f"{target} is not a click command")
        return command

    def invoke(self, ctx: click.Context) -> Any:
        """Run the subcommand; the library's errors a person can act on become its message, and
        so does an optional extra's module missing where no earlier check asked for it."""
        try:
            return super().invoke(ctx)
        except (SessionError, ExtraMissing) as exc:
            raise click.ClickException(str(exc)) from None
        except ModuleNotFoundError as exc:
            extra = extra_of(exc)
            if extra is None:
                raise
            needed_by = f"shoal {ctx.invoked_subcommand}"
            raise click.ClickException(str(ExtraMissing(extra, needed_by, str(exc)))) from None


@click.group(
    cls=LazyGroup,
    context_settings={"auto_envvar_prefix": "SHOAL", "show_default": True},
)
@click.version_option(package_name="shoal")
@click.option(
    "-v",
    "--verbose",
    is_flag=True,
    help="Show the log of the libraries shoal drives (the Foxglove server's client log).",
)
def main(verbose: bool) -> None:
    """Safe formation control for swarms of mobile robots (leader–follower, obstacle avoidance)."""
    quiet_libraries(verbose)


def quiet_libraries(verbose: bool) -> None:
    """The Foxglove SDK logs each viewer that connects or fails its handshake (a browser opened
    on the ws:// URL: `Dropping client …: handshake failed`) through Python's logging, which
    printed it into the run's own output. Quiet unless --verbose, which shows it prefixed."""
    import logging

    log = logging.getLogger("foxglove")
    log.propagate = False
    log.handlers.clear()
    if verbose:
        handler = logging.StreamHandler()
        handler.setFormatter(logging.Formatter("foxglove: %(message)s"))
        log.addHandler(handler)
        log.setLevel(logging.INFO)
    else:
        log.addHandler(logging.NullHandler())
        log.setLevel(logging.CRITICAL + 1)
