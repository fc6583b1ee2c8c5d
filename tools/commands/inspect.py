"""``shoal inspect``: what is in a run's MCAP file."""

from __future__ import annotations

import json
from pathlib import Path

import click

from shoal.tools.log.salvage import LogError, inspect_file


@click.command()
@click.argument("file", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
def inspect(file: Path, as_json: bool) -> None:
    """Channels, message counts, duration, scenario, summary metrics, and whether FILE was
    finished (a killed logger leaves it unfinished: see `shoal recover`)."""
    try:
        info = inspect_file(file)
    except LogError as exc:
        raise click.ClickException(str(exc)) from None
    if as_json:
        click.echo(json.dumps(info))
        return
    state = "finished" if info["finished"] else f"NOT finished ({info['stopped'] or 'no summary'})"
    click.echo(f"{info['file']}: {state}")
    attached = ", ".join(info["attachments"]) or "—"
    click.echo(
        f"scenario {info['scenario']}, run {info['run']}, {info['messages']} messages "
        f"over {info['duration_s']} s, attachments {attached}"
    )
    width = max((len(t) for t in info["channels"]), default=0)
    for topic, n in info["channels"].items():
        click.echo(f"  {topic:<{width}}  {n}")
    if info["summary"]:
        click.echo("summary: " + ", ".join(f"{k}={v}" for k, v in info["summary"].items()))
