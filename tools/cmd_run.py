"""``shoal run``: a whole run as separate OS processes over Zenoh."""

from __future__ import annotations

import json
import socket
import sys
import time
import uuid
from pathlib import Path
from typing import Any

import click

from bus import codec
from bus.errors import DecodeError
from bus.keys import Keys
from bus.links import subscribe, watch_presence
from bus.runtime import Inbox, exit_on_signals
from tools.cmd_simulate import json_safe, load_for_cli
from tools.options import client_config, open_session
from tools.report import render_summary
from tools.swarm import ChildFailed, Swarm
from world.loader import builtin_names


def free_port() -> int:
    """A TCP port on 127.0.0.1 that nobody listens on right now."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@click.command()
@click.argument("scenario", default="default")
@click.option(
    "--mode",
    type=click.Choice(["lockstep", "realtime"]),
    default="lockstep",
    help="lockstep: the world advances once every live agent's command for the tick is in "
    "(exact, deterministic); realtime: the world integrates at a fixed wall-clock rate with "
    "each agent's latest command.",
)
@click.option(
    "--speed",
    type=click.FloatRange(min=0.01, max=100.0),
    default=1.0,
    help="realtime: simulated seconds per wall-clock second.",
)
@click.option(
    "--out",
    "-o",
    type=click.Path(dir_okay=False, path_type=Path),
    help="MCAP file to record the run in [default: runs/<scenario>-<run id>.mcap].",
)
@click.option(
    "--connect", "-e", help="Use the Zenoh router at this endpoint instead of starting one."
)
@click.option("--run", "run_id", help="Run id [default: a fresh random one].")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object instead of text.")
@click.option("--start-timeout", default=60.0, help="Seconds for every process to come up.")
def run(
    scenario: str,
    mode: str,
    speed: float,
    out: Path | None,
    connect: str | None,
    run_id: str | None,
    as_json: bool,
    start_timeout: float,
) -> None:
    """Run SCENARIO with one OS process per agent, a world, a logger (and a router).

    Prints the same summary as `shoal simulate`; the lockstep trajectory equals the reference
    simulator's bit for bit, and the whole run is recorded in an MCAP file.
    """
    exit_on_signals()
    scn = load_for_cli(scenario)
    world_arg = scenario if scenario in builtin_names() else str(Path(scenario).resolve())
    run_id = run_id or uuid.uuid4().hex[:8]
    keys = Keys(run_id)
    out = out or Path("runs") / f"{scn.name}-{run_id}.mcap"
    started = time.monotonic()
    try:
        with Swarm() as swarm:
            endpoint = connect or f"tcp/127.0.0.1:{free_port()}"
            if connect is None:
                router = swarm.spawn(
                    "router", "router", ["router", "--listen", endpoint], ready_pipe=True
                )
                swarm.wait_ready(router, start_timeout)
            common = ["--run", run_id, "--connect", endpoint]
            logger = swarm.spawn(
                "logger", "logger", ["logger", "--out", str(out), *common], ready_pipe=True
            )
            swarm.spawn(
                "world",
                "world",
                ["world", world_arg, *common, "--expect", "logger", "--expect", "monitor",
                 "--clock", mode, "--speed", str(speed), "--start-timeout", str(start_timeout)],
            )  # fmt: skip
            for i in range(1, scn.n + 1):
                swarm.spawn(f"agent {i}", "agent", ["agent", "--id", str(i), *common])
            swarm.wait_ready(logger, start_timeout)
            summary, startup = _monitor(swarm, keys, endpoint, scn.steps, as_json, started)
            swarm.expect_exit({"world", "agent"}, timeout=10.0)
            swarm.expect_exit({"logger"}, timeout=10.0)
    except ChildFailed as exc:
        raise click.ClickException(str(exc)) from None
    summary = json_safe(summary)
    wall = time.monotonic() - started
    if as_json:
        extra = {"mode": mode, "wall_s": round(wall, 3), "startup_s": startup, "mcap": str(out)}
        click.echo(json.dumps({**summary, **extra}))
    else:
        click.echo(render_summary(summary))
        click.echo(f"{'mode':<24}  {mode}, {wall:.1f} s wall, all agents up in {startup:.1f} s")
        click.echo(f"{'log':<24}  {out}")


def _monitor(
    swarm: Swarm, keys: Keys, endpoint: str, steps: int, quiet: bool, began: float
) -> tuple[dict[str, Any], float]:
    """Follow the run from a client session until the world's summary arrives; also returns
    the seconds from ``began`` until every agent's token was up."""
    inbox = Inbox()
    agents_up: set[str] = set()
    startup = float("nan")
    conf = client_config((endpoint,), None, False)
    with open_session(conf, "shoal run") as session:
        held = [
            subscribe(session, keys.tick, inbox),
            subscribe(session, keys.summary, inbox),
            watch_presence(session, keys.alive_agents, inbox),
        ]
        token = session.liveliness().declare_token(keys.alive_process("monitor"))
        show = not quiet and sys.stderr.isatty()
        with click.progressbar(
            length=steps, label="simulated time", file=sys.stderr, hidden=not show
        ) as bar:
            while True:
                swarm.check()
                arrival = inbox.get(timeout=0.2)
                if arrival is None:
                    continue
                if arrival.kind == "up":
                    agents_up.add(arrival.key)
                    if len(agents_up) == sum(c.role == "agent" for c in swarm.children):
                        startup = round(time.monotonic() - began, 3)
                    continue
                if arrival.kind != "data":
                    continue
                try:
                    if arrival.key == keys.summary:
                        summary = codec.decode_document("summary", arrival.payload)
                        break
                    tick = codec.decode_tick(arrival.payload).tick
                except DecodeError:
                    continue  # a stranger's garbage on our keys does not stop the run
                bar.update(tick + 1 - bar.pos)
        del held, token
    return summary, startup
