"""``shoal world``: the world process of a run."""

from __future__ import annotations

import json
from pathlib import Path

import click

from shoal.bus.acl import WORLD
from shoal.bus.runtime import exit_on_signals
from shoal.bus.seam import ZenohBus
from shoal.bus.types import Clock
from shoal.tools.commands.options import bus_options, load_for_cli
from shoal.tools.commands.report import json_safe, render_summary
from shoal.tools.procs.session import client_config, open_session
from shoal.world.process import World, WorldAbort, WorldOptions


@click.command()
@click.argument("scenario", default="default")
@bus_options
@click.option(
    "--expect",
    multiple=True,
    help="Also wait for this process's token before tick 0 (logger, monitor; repeatable).",
)
@click.option(
    "--clock",
    type=click.Choice(["lockstep", "realtime"]),
    default="lockstep",
    help="lockstep: wait for every live agent each tick; realtime: a fixed wall-clock rate.",
)
@click.option(
    "--speed",
    type=click.FloatRange(min=0.01, max=100.0),
    default=1.0,
    help="realtime: simulated seconds per wall-clock second.",
)
@click.option("--start-timeout", default=60.0, help="Seconds to wait for every agent.")
@click.option("--json", "as_json", is_flag=True, help="Print the summary as JSON.")
def world(
    scenario: str,
    run_id: str,
    connect: tuple[str, ...],
    zenoh_config: Path | None,
    multicast: bool,
    secure: Path | None,
    expect: tuple[str, ...],
    clock: str,
    speed: float,
    start_timeout: float,
    as_json: bool,
) -> None:
    """Simulate kinematics and sensing for the agents of run RUN, in lockstep."""
    exit_on_signals()
    scn = load_for_cli(scenario)
    options = WorldOptions(
        run=run_id, expect=expect, clock=Clock(clock), speed=speed, start_timeout=start_timeout
    )
    conf = client_config(connect, zenoh_config, multicast, secure, WORLD)
    with open_session(conf, "world") as session:
        try:
            with World(scn, options, ZenohBus(session)) as w:
                w.wait_for_everyone()
                summary = json_safe(w.run())
        except WorldAbort as exc:
            raise click.ClickException(str(exc)) from None
    click.echo(json.dumps(summary) if as_json else render_summary(summary))
    if summary.get("aborted"):
        raise click.ClickException(f"the run ended early: {summary['aborted']}")
