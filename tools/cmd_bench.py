"""``shoal bench``: performance figures next to their floor, measured in the same run."""

from __future__ import annotations

import json
from pathlib import Path

import click

from bus.runtime import exit_on_signals
from tools.bench import bench as run_bench
from tools.swarm import ChildFailed


@click.command()
@click.option("--sizes", default="5,10,20,50", help="Formation sizes, comma-separated.")
@click.option("--ticks", default=400, help="Ticks per lockstep run (halved above 20 agents).")
@click.option(
    "--out", type=click.Path(dir_okay=False, path_type=Path), help="Also write JSON here."
)
def bench(sizes: str, ticks: int, out: Path | None) -> None:
    """Measure lockstep ticks/s against a bare Zenoh exchange of the same message pattern, the
    time until every agent is up, realtime command latency and memory per agent process.

    Prints one JSON object; progress goes to stderr.
    """
    exit_on_signals()
    try:
        numbers = [int(s) for s in sizes.split(",") if s.strip()]
    except ValueError:
        raise click.BadParameter(f"{sizes!r} is not a comma-separated list of integers") from None
    if not numbers or min(numbers) < 2:
        raise click.BadParameter("every size needs a leader and a follower (≥ 2)")
    try:
        result = run_bench(numbers, ticks, say=lambda s: click.echo(s, err=True))
    except ChildFailed as exc:
        raise click.ClickException(str(exc)) from None
    text = json.dumps(result, indent=2)
    if out is not None:
        out.write_text(text + "\n")
    click.echo(text)
