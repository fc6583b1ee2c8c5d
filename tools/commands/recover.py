"""``shoal recover``: salvage an MCAP file whose logger was killed."""

from __future__ import annotations

import json
from pathlib import Path

import click

from shoal.tools.log.salvage import LogError
from shoal.tools.log.salvage import recover as salvage


@click.command()
@click.argument("broken", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option(
    "-o", "--out", type=click.Path(dir_okay=False, path_type=Path), required=True, help="Output."
)
@click.option("--force", is_flag=True, help="Replace OUT if it exists.")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object instead of text.")
def recover(broken: Path, out: Path, force: bool, as_json: bool) -> None:
    """Copy every complete record of BROKEN (a log whose logger was killed) into a finished
    file OUT, which every MCAP reader and every shoal command can open."""
    if out.resolve() == broken.resolve():
        raise click.BadParameter("write the recovered file somewhere else", param_hint="--out")
    if out.exists() and not force:
        raise click.ClickException(f"{out} exists; pass --force to overwrite it, or --out another")
    try:
        result = salvage(broken, out)
    except LogError as exc:
        raise click.ClickException(str(exc)) from None
    except OSError as exc:
        raise click.ClickException(f"{out}: cannot be written ({exc.strerror})") from None
    if as_json:
        click.echo(json.dumps(result))
        return
    was = "finished already" if result["was_finished"] else "not finished"
    why = f": {result['stopped']}" if result["stopped"] else ""
    click.echo(
        f"{result['to']}: {result['messages']} messages on {result['channels']} channels "
        f"recovered from {result['from']} ({was}{why})"
    )
    click.echo(f"look at it with `shoal inspect {out}`; a lockstep run: `shoal verify {out}`")
