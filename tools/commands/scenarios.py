"""``shoal scenarios``: list the built-in scenarios, or print one to start your own from."""

from __future__ import annotations

import re

import click

from shoal.tools.commands.options import load_for_cli
from shoal.world.loader import builtin_names


@click.command()
@click.argument("name", required=False)
def scenarios(name: str | None) -> None:
    """List the built-in scenarios, or print the YAML of NAME to start your own from.

    The printed YAML has no `name:`, so a copy saved as mine.yaml runs (and names its logs and
    figures) as "mine", not as the built-in it came from.
    """
    if name is not None:
        click.echo(_unnamed(load_for_cli(name).source), nl=False)
        return
    for n in builtin_names():
        s = load_for_cli(n)
        click.echo(f"{n:<10} {s.n} agents, {s.duration:g} s  {s.description}")


_NAME = re.compile(r"^name:.*$", re.MULTILINE)


def _unnamed(source: str) -> str:
    """``source`` with its top-level ``name:`` line turned into a comment saying where the name
    comes from instead."""
    return _NAME.sub(
        "# name: taken from the file's name (mine.yaml runs as mine); or set one here", source
    )
