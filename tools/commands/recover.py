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
def recover(broken: Path, out: Path) -> None:
    """Copy every complete chunk of BROKEN into a finished file OUT."""
    if out.resolve() == broken.resolve():
        raise click.BadParameter("write the recovered file somewhere else", param_hint="--out")
    try:
        result = salvage(broken, out)
    except LogError as exc:
        raise click.ClickException(str(exc)) from None
    except OSError as exc:
        raise click.ClickException(f"{out}: cannot be written ({exc.strerror})") from None
    click.echo(json.dumps(result))
