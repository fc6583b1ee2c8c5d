"""``shoal agent``: one agent process (tools/procs/agent.py runs it)."""

from __future__ import annotations

from typing import Any

import click

from shoal.agent.process import AgentAbort
from shoal.bus.runtime import exit_on_signals
from shoal.tools.procs.agent import run_agent
from shoal.tools.procs.children import AgentSpec, click_options


@click.command()
@click_options(AgentSpec)
def agent(**params: Any) -> None:
    """Run agent ID of run RUN: fetch its configuration from the world and follow the laws."""
    exit_on_signals()
    try:
        run_agent(AgentSpec.of(params))
    except AgentAbort as exc:
        raise click.ClickException(str(exc)) from None
