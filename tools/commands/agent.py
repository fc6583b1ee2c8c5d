"""``shoal agent``: one agent process."""

from __future__ import annotations

import resource
from typing import Any

import click

from shoal.agent.process import AgentAbort, AgentNode, AgentOptions
from shoal.bus.acl import agent_name
from shoal.bus.runtime import exit_on_signals, warn
from shoal.bus.seam import ZenohBus
from shoal.tools.procs.children import AgentSpec, click_options
from shoal.tools.procs.session import client_session


@click.command()
@click_options(AgentSpec)
def agent(**params: Any) -> None:
    """Run agent ID of run RUN: fetch its configuration from the world and follow the laws."""
    exit_on_signals()
    spec = AgentSpec.of(params)
    agent_id = spec.agent_id
    options = AgentOptions(
        run=spec.run_id,
        agent_id=agent_id,
        start_timeout=spec.start_timeout,
        drop_rate=spec.drop_rate,
        drop_seed=spec.drop_seed,
        delay_ms=spec.delay_ms,
        jitter_ms=spec.jitter_ms,
    )
    with client_session(spec, agent_name(agent_id), f"agent {agent_id}") as session:
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
