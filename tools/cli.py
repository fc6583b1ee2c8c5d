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

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before anything imports numpy

import click

COMMANDS = {
    "run": "shoal.tools.cmd_run:run",
    "simulate": "shoal.tools.cmd_simulate:simulate",
    "scenarios": "shoal.tools.cmd_scenarios:scenarios",
    "bench": "shoal.tools.cmd_bench:bench",
    "router": "shoal.tools.cmd_router:router",
    "world": "shoal.tools.cmd_world:world",
    "agent": "shoal.tools.cmd_agent:agent",
    "logger": "shoal.tools.cmd_logger:logger",
    "certs": "shoal.tools.cmd_certs:certs",
    "inspect": "shoal.tools.cmd_inspect:inspect",
    "recover": "shoal.tools.cmd_recover:recover",
    "verify": "shoal.tools.cmd_verify:verify",
    "replay": "shoal.tools.cmd_replay:replay",
    "export": "shoal.tools.cmd_export:export",
    "plot": "shoal.tools.cmd_plot:plot",
    "floor": "shoal.tools.cmd_floor:floor",
    "campaign": "shoal.tools.cmd_campaign:campaign",
    "compose": "shoal.tools.cmd_compose:compose",
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


@click.group(
    cls=LazyGroup,
    context_settings={"auto_envvar_prefix": "SHOAL", "show_default": True},
)
@click.version_option(package_name="shoal")
def main() -> None:
    """Safe formation control for swarms of mobile robots (leader–follower, obstacle avoidance)."""
