"""Launching a whole run as separate OS processes and following it to its end.

Used by ``shoal run`` and by the benchmark. The order is what makes the start race-free: the
router (unless one is given), then the logger, the world and every agent at once; the world waits
for every agent's, the logger's and this monitor's liveliness tokens before its first tick.
"""

from __future__ import annotations

import re
import socket
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import click

from bus import codec
from bus.errors import DecodeError
from bus.keys import Keys
from bus.links import subscribe, watch_presence
from bus.runtime import Inbox
from tools.options import client_config, open_session
from tools.swarm import Swarm

_PEAK_RSS = re.compile(r"peak_rss_kb (\d+)")


def free_port() -> int:
    """A TCP port on 127.0.0.1 that nobody listens on right now."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@dataclass(frozen=True)
class RunPlan:
    scenario: str  # a built-in name or an absolute path
    agents: int
    steps: int
    out: Path
    run_id: str
    clock: str = "lockstep"
    speed: float = 1.0
    connect: str | None = None  # a router's endpoint; None starts one
    start_timeout: float = 60.0
    progress: bool = False


@dataclass(frozen=True)
class RunResult:
    summary: dict[str, Any]  # the world's summary (metrics and timing)
    startup_s: float  # from launch until every agent's token was up
    wall_s: float
    agent_peak_rss_mb: list[float]  # one per agent process that reported it


def launch(plan: RunPlan) -> RunResult:
    """Run ``plan`` to its end; raises tools.swarm.ChildFailed if a process fails."""
    started = time.monotonic()
    with Swarm() as swarm:
        endpoint = plan.connect or f"tcp/127.0.0.1:{free_port()}"
        if plan.connect is None:
            router = swarm.spawn(
                "router", "router", ["router", "--listen", endpoint], ready_pipe=True
            )
            swarm.wait_ready(router, plan.start_timeout)
        common = ["--run", plan.run_id, "--connect", endpoint]
        logger = swarm.spawn(
            "logger", "logger", ["logger", "--out", str(plan.out), *common], ready_pipe=True
        )
        swarm.spawn(
            "world",
            "world",
            ["world", plan.scenario, *common, "--expect", "logger", "--expect", "monitor",
             "--clock", plan.clock, "--speed", str(plan.speed),
             "--start-timeout", str(plan.start_timeout)],
        )  # fmt: skip
        for i in range(1, plan.agents + 1):
            swarm.spawn(f"agent {i}", "agent", ["agent", "--id", str(i), *common])
        swarm.wait_ready(logger, plan.start_timeout)
        summary, startup = _monitor(swarm, Keys(plan.run_id), endpoint, plan, started)
        swarm.expect_exit({"world", "agent"}, timeout=10.0)
        swarm.expect_exit({"logger"}, timeout=10.0)
        rss = [
            int(m.group(1)) / 1024
            for c in swarm.children
            if c.role == "agent" and (m := _PEAK_RSS.search(c.tail(3)))
        ]
    return RunResult(summary, startup, time.monotonic() - started, rss)


def _monitor(
    swarm: Swarm, keys: Keys, endpoint: str, plan: RunPlan, began: float
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
        show = plan.progress and sys.stderr.isatty()
        with click.progressbar(
            length=plan.steps, label="simulated time", file=sys.stderr, hidden=not show
        ) as bar:
            checked = 0.0
            while True:
                if time.monotonic() - checked >= 0.2:  # not once per tick: 0.2 s is soon enough
                    swarm.check()
                    checked = time.monotonic()
                arrival = inbox.get(timeout=0.2)
                if arrival is None:
                    continue
                if arrival.kind == "up":
                    agents_up.add(arrival.key)
                    if len(agents_up) == plan.agents:
                        startup = round(time.monotonic() - began, 3)
                    continue
                if arrival.kind != "data":
                    continue
                try:
                    if arrival.key == keys.summary:
                        summary = codec.decode_document("summary", arrival.payload)
                        break
                    if show:  # a hidden bar needs no tick number: skip decoding every record
                        tick = codec.decode_tick(arrival.payload).tick
                        bar.update(tick + 1 - bar.pos)
                except DecodeError:
                    continue  # a stranger's garbage on our keys does not stop the run
        del held, token
    return summary, startup
