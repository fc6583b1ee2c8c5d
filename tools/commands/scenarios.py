"""``shoal scenarios``: list the built-ins, print one to start your own from, or make a new one."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import click

from shoal.tools.campaign.shapes import SHAPES, ShapeError, new_scenario
from shoal.tools.commands.options import load_for_cli
from shoal.world.errors import ScenarioError
from shoal.world.loader import builtin_names


class _NameOrCommand(click.Group):
    """``shoal scenarios NAME`` prints a built-in; ``shoal scenarios new …`` is a subcommand."""

    def parse_args(self, ctx: click.Context, args: list[str]) -> list[str]:
        if args and not args[0].startswith("-") and args[0] not in self.commands:
            args = ["show", *args]
        return super().parse_args(ctx, args)


@click.group(cls=_NameOrCommand, invoke_without_command=True)
@click.pass_context
def scenarios(ctx: click.Context) -> None:
    """List the built-in scenarios (also `shoal scenarios list`); `shoal scenarios NAME` prints
    the YAML of one to start your own from; `shoal scenarios new` makes a new one from a
    formation's shape.

    The printed YAML has no `name:`, so a copy saved as mine.yaml runs (and names its logs and
    figures) as "mine", not as the built-in it came from.
    """
    if ctx.invoked_subcommand is None:
        ctx.invoke(list_builtins)


@scenarios.command("list")
def list_builtins() -> None:
    """One line per built-in: its name, agents, dimension, duration and what it shows."""
    for n in builtin_names():
        s = load_for_cli(n)
        click.echo(f"{n:<10} {s.n:>2} agents, {s.dim}-D, {s.duration:>3g} s  {s.description}")


@scenarios.command(hidden=True)
@click.argument("name")
def show(name: str) -> None:
    """Print the YAML of the built-in (or file) NAME, without its name."""
    click.echo(_unnamed(load_for_cli(name).source), nl=False)


@scenarios.command()
@click.option("--agents", "-n", type=click.IntRange(min=2), required=True, help="Agents.")
@click.option("--shape", type=click.Choice(SHAPES), default="wedge", show_default=True)
@click.option("--spacing", type=float, default=3.0, show_default=True, help="m between slots.")
@click.option("--obstacles", type=click.IntRange(min=0), default=0, show_default=True)
@click.option("--dim", type=click.Choice(["2", "3"]), default="2", show_default=True)
@click.option("--length", type=float, default=30.0, show_default=True, help="m of path.")
@click.option("--speed", type=float, default=1.0, show_default=True, help="Leader, m/s.")
@click.option("--seed", type=int, default=0, show_default=True, help="Draws the obstacles.")
@click.option(
    "--kinematics", type=click.Choice(["single", "unicycle"]), default="single",
    show_default=True, help="Single integrators (the paper's) or unicycles facing along the "
    "path, 2-D (docs/scenarios.md, Unicycles).",
)  # fmt: skip
@click.option(
    "--out",
    "-o",
    type=click.Path(dir_okay=False, path_type=Path),
    help="Write the YAML here instead of printing it; the run is named after the file.",
)
@click.option("--force", is_flag=True, help="Overwrite --out if it exists.")
def new(out: Path | None, force: bool, dim: str, **options: Any) -> None:
    """Make a scenario: a formation of --agents in a --shape following a straight path, its
    graph built to satisfy the paper's Assumptions 1 and 2, with --obstacles drawn inside
    every load-time check (as the campaign draws them). The YAML is checked by the loader
    before it is written, and commented for editing.

    \b
      shoal scenarios new -n 12 --shape grid --obstacles 4 -o grid12.yaml
      shoal run grid12.yaml
    """
    if out is not None and out.exists() and not force:
        raise click.ClickException(f"{out} exists; pass --force to overwrite it")
    try:
        text = new_scenario(dim=int(dim), **options)  # unnamed: the file's name names it
    except (ShapeError, ScenarioError) as exc:
        raise click.ClickException(str(exc)) from None
    if out is None:
        click.echo(text, nl=False)
        return
    try:
        out.write_text(text, encoding="utf-8")
    except OSError as exc:
        raise click.ClickException(f"cannot write {out}: {exc.strerror}") from None
    click.echo(f"wrote {out}: run it with `shoal run {out}`", err=True)


_NAME = re.compile(r"^name:.*$", re.MULTILINE)


def _unnamed(source: str) -> str:
    """``source`` with its top-level ``name:`` line turned into a comment saying where the name
    comes from instead."""
    return _NAME.sub(
        "# name: taken from the file's name (mine.yaml runs as mine); or set one here", source
    )
