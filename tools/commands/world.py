"""``shoal world``: the world process of a run."""

from __future__ import annotations

import dataclasses
import json
from typing import Any

import click

from shoal.bus.acl import WORLD
from shoal.bus.runtime import exit_on_signals
from shoal.bus.seam import ZenohBus
from shoal.tools.commands.options import load_for_cli
from shoal.tools.commands.report import json_safe, render_summary
from shoal.tools.procs.children import WorldSpec, click_options
from shoal.tools.procs.session import client_session
from shoal.world.onboard import Link
from shoal.world.process import World, WorldAbort, WorldOptions
from shoal.world.scenario import Scenario


def scenario_of(spec: WorldSpec) -> Scenario:
    """The scenario the world runs: its file (or built-in), under ``--name`` if given."""
    scn = load_for_cli(spec.scenario)
    return scn if spec.name is None else dataclasses.replace(scn, name=spec.name)


def link_of(spec: WorldSpec, scn: Scenario) -> Link:
    """The robots' radio of ``spec`` in ticks: its wall-clock delays over the wall-clock tick
    (dt / speed; lockstep ticks as fast as the agents answer, and the delays count at speed 1)."""
    if spec.link_jitter_ms > spec.link_delay_ms:
        raise click.BadParameter(
            f"{spec.link_jitter_ms:g} ms is more than --link-delay-ms {spec.link_delay_ms:g}",
            param_hint="--link-jitter-ms",
        )
    tick_ms = scn.dt / spec.speed * 1e3
    return Link(
        delay=spec.link_delay_ms / tick_ms,
        jitter=spec.link_jitter_ms / tick_ms,
        drop_rate=spec.link_drop_rate,
        seed=spec.link_seed,
    )


@click.command()
@click_options(WorldSpec)
@click.option("--json", "as_json", is_flag=True, help="Print the summary as JSON.")
def world(as_json: bool, **params: Any) -> None:
    """Simulate kinematics and sensing for the agents of run RUN, in lockstep."""
    exit_on_signals()
    spec = WorldSpec.of(params)
    scn = scenario_of(spec)
    options = WorldOptions(
        run=spec.run_id,
        expect=spec.expect,
        clock=spec.clock,
        speed=spec.speed,
        layer=spec.safety_layer,
        link=link_of(spec, scn),
        layer_epoch=spec.layer_epoch,
        start_timeout=spec.start_timeout,
    )
    with client_session(spec, WORLD, "world") as session:
        try:
            with World(scn, options, ZenohBus(session)) as w:
                w.wait_for_everyone()
                summary = json_safe(w.run())
        except WorldAbort as exc:
            raise click.ClickException(str(exc)) from None
    click.echo(json.dumps(summary) if as_json else render_summary(summary))
    if summary.get("aborted"):
        raise click.ClickException(f"the run ended early: {summary['aborted']}")
