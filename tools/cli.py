"""The ``shoal`` command line: one click group, one module per subcommand."""

from __future__ import annotations

import click

from tools.cmd_agent import agent
from tools.cmd_bench import bench
from tools.cmd_floor import floor
from tools.cmd_logger import logger
from tools.cmd_router import router
from tools.cmd_run import run
from tools.cmd_scenarios import scenarios
from tools.cmd_simulate import simulate
from tools.cmd_world import world


@click.group(context_settings={"auto_envvar_prefix": "SHOAL", "show_default": True})
@click.version_option(package_name="shoal")
def main() -> None:
    """Safe formation control for swarms of mobile robots (leader–follower, obstacle avoidance)."""


for command in (run, simulate, scenarios, bench, router, world, agent, logger, floor):
    main.add_command(command)
