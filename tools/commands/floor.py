"""``shoal floor``: the bare processes the benchmark measures its floor with (internal)."""

from __future__ import annotations

import json

import click
import zenoh

from shoal.bus.runtime import exit_on_signals
from shoal.tools.bench.floor import floor_agent, floor_listener, floor_world
from shoal.tools.bench.formations import load_bench, message_sizes, neighbours
from shoal.tools.procs.session import client_config, open_session


@click.group(hidden=True)
def floor() -> None:
    """Bare message-pattern processes for `shoal bench` (no control math)."""


def _session(connect: str, what: str) -> zenoh.Session:
    return open_session(client_config((connect,)), what)


@floor.command("world")
@click.option("--run", "run_id", required=True)
@click.option("--connect", required=True)
@click.option("--agents", type=int, required=True)
@click.option("--ticks", type=int, required=True)
@click.option("--period", type=float, default=0.0, help="Realtime: seconds per tick (0: lockstep).")
def world_cmd(run_id: str, connect: str, agents: int, ticks: int, period: float) -> None:
    exit_on_signals()
    sizes = message_sizes(load_bench(agents, ticks))
    with _session(connect, "floor world") as session:
        result = floor_world(
            session, run=run_id, agents=agents, ticks=ticks, sizes=sizes, period=period
        )
        click.echo(json.dumps(result))  # before the session closes: the agents are still up


@floor.command("agent")
@click.option("--run", "run_id", required=True)
@click.option("--connect", required=True)
@click.option("--agents", type=int, required=True)
@click.option("--id", "agent_id", type=int, required=True)
def agent_cmd(run_id: str, connect: str, agents: int, agent_id: int) -> None:
    exit_on_signals()
    scenario = load_bench(agents, 1)
    with _session(connect, f"floor agent {agent_id}") as session:
        floor_agent(
            session,
            run=run_id,
            agent_id=agent_id,
            neighbours=neighbours(scenario, agent_id),
            sizes=message_sizes(scenario),
        )


@floor.command("listener")
@click.option("--run", "run_id", required=True)
@click.option("--connect", required=True)
@click.option("--role", type=click.Choice(["logger", "monitor"]), required=True)
def listener_cmd(run_id: str, connect: str, role: str) -> None:
    exit_on_signals()
    with _session(connect, f"floor {role}") as session:
        floor_listener(session, run=run_id, role=role)
