"""The ``shoal`` command line: one click group, one module per subcommand."""

from __future__ import annotations

import click

from tools.cmd_scenarios import scenarios
from tools.cmd_simulate import simulate


@click.group(context_settings={"auto_envvar_prefix": "SHOAL", "show_default": True})
@click.version_option(package_name="shoal")
def main() -> None:
    """Safe formation control for swarms of mobile robots (leader–follower, obstacle avoidance)."""


main.add_command(simulate)
main.add_command(scenarios)
