"""``shoal inspect``: what is in a run's MCAP file."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import click

from shoal.tools.commands.logs import log_files, run_logs
from shoal.tools.commands.report import render_summary
from shoal.tools.log.salvage import LogError, inspect_file


@click.command()
@log_files
@click.option(
    "--json", "as_json", is_flag=True, help="Print one JSON object per file, a line each."
)
def inspect(files: tuple[Path, ...], as_json: bool) -> None:
    """Channels, message counts, duration, scenario, the run's summary, and whether each FILE
    was finished (a killed logger leaves it unfinished: see `shoal recover`). A glob works
    (Foxglove views files are left out); with no FILE, the last run in runs/."""
    for k, file in enumerate(run_logs(files, command="inspect")):
        try:
            info = inspect_file(file)
        except LogError as exc:
            raise click.ClickException(str(exc)) from None
        if as_json:
            click.echo(json.dumps(info))
        else:
            click.echo(("\n" if k else "") + _described(info))


def _described(info: dict[str, Any]) -> str:
    """What ``shoal inspect`` prints for one file: its state, its channels, its summary."""
    lines = []
    state = "finished" if info["finished"] else f"NOT finished ({info['stopped'] or 'no summary'})"
    lines.append(f"{info['file']}: {state}")
    attached = ", ".join(info["attachments"]) or "—"
    lines.append(
        f"scenario {info['scenario']}, run {info['run']}, {info['messages']} messages "
        f"over {info['duration_s']} s, attachments {attached}"
    )
    width = max((len(t) for t in info["channels"]), default=0)
    lines.extend(f"  {topic:<{width}}  {n}" for topic, n in info["channels"].items())
    if info["summary"]:
        lines.append("summary (as `shoal run` printed it; --json for every figure):")
        try:
            table = render_summary(info["summary"])
        except KeyError as exc:  # a summary from an older shoal lacks a row's figure
            table = f"(an older summary without {exc}; --json shows what it has)"
        lines.extend(f"  {line}" for line in table.splitlines())
    return "\n".join(lines)
