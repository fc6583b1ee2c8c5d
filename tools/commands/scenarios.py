"""``shoal scenarios``: list the built-in scenarios, or print one to start your own from."""

from __future__ import annotations

import click

from shoal.tools.commands.options import load_for_cli
from shoal.world.loader import builtin_names


@click.command()
@click.argument("name", required=False)
def scenarios(name: str | None) -> None:
    """List the built-in scenarios, or print the YAML of NAME."""
    if name is not None:
        click.echo(load_for_cli(name).source, nl=False)
        return
    for n in builtin_names():
        s = load_for_cli(n)
        click.echo(f"{n:<10} {s.n} agents, {s.duration:g} s  {s.description}")
