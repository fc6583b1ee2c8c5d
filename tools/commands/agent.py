"""``shoal agent``: one agent process."""

from __future__ import annotations

import resource
from pathlib import Path

import click

from shoal.agent.process import AgentAbort, AgentNode, AgentOptions
from shoal.bus.acl import agent_name
from shoal.bus.runtime import exit_on_signals, warn
from shoal.bus.seam import ZenohBus
from shoal.tools.commands.options import bus_options, drop_options
from shoal.tools.procs.session import client_config, open_session


@click.command()
@click.option("--id", "agent_id", type=click.IntRange(min=1), required=True, help="Agent id.")
@bus_options
@click.option("--start-timeout", default=60.0, help="Seconds to wait for the world.")
@drop_options
def agent(
    agent_id: int,
    run_id: str,
    connect: tuple[str, ...],
    zenoh_config: Path | None,
    multicast: bool,
    secure: Path | None,
    start_timeout: float,
    drop_rate: float,
    drop_seed: int,
) -> None:
    """Run agent ID of run RUN: fetch its configuration from the world and follow the laws."""
    exit_on_signals()
    options = AgentOptions(
        run=run_id,
        agent_id=agent_id,
        start_timeout=start_timeout,
        drop_rate=drop_rate,
        drop_seed=drop_seed,
    )
    conf = client_config(connect, zenoh_config, multicast, secure, agent_name(agent_id))
    with open_session(conf, f"agent {agent_id}") as session:
        try:
            node = AgentNode(options, ZenohBus(session))
        except AgentAbort as exc:
            raise click.ClickException(str(exc)) from None
        try:
            with node:
                node.run()
        finally:
            if node.dropped:
                warn(f"agent {agent_id}: {node.dropped} bad messages dropped")
            warn(f"agent {agent_id}: stopped after tick {node.tick}")
            warn(node.stats())
            peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
            warn(f"agent {agent_id}: peak_rss_kb {peak}")
