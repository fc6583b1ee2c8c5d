"""tools/procs/children.py: each process of a run described once. Every command line the
launcher builds parses back, through the command's own click parser, to the same spec; every
environment variable the compose file sets is one that command reads."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click
import pytest

from shoal.bus.types import Clock, SafetyLayer
from shoal.tools.commands.agent import agent
from shoal.tools.commands.guard import guard
from shoal.tools.commands.logger import logger
from shoal.tools.commands.robots import robots
from shoal.tools.commands.router import router
from shoal.tools.commands.world import world
from shoal.tools.procs.children import (
    AgentSpec,
    ChildSpec,
    GuardSpec,
    LoggerSpec,
    RobotsSpec,
    RouterSpec,
    WorldSpec,
)

SECURE = Path(__file__).parent  # an existing folder: click checks that it exists
COMMON: dict[str, Any] = {"run_id": "r-1", "connect": ("tcp/127.0.0.1:7447", "tcp/10.0.0.2:7447")}
SPECS: list[tuple[ChildSpec, click.Command]] = [
    (RouterSpec(listen=("tcp/127.0.0.1:7000",), exit_after_run="r-1", secure=SECURE), router),
    (LoggerSpec(out=Path("/tmp/x.mcap"), force=True, **COMMON), logger),
    (LoggerSpec(out=Path("/tmp/y.mcap"), **COMMON), logger),
    (
        WorldSpec(
            scenario="passage",
            name="a name: with spaces",
            expect=("logger", "monitor"),
            clock=Clock.REALTIME,
            speed=2.5,
            safety_layer=SafetyLayer.NONE,
            delay_ms=20.0,
            jitter_ms=10.0,
            drop_rate=0.05,
            drop_seed=4,
            layer_epoch=0.2,
            start_timeout=12.0,
            multicast=True,
            robots="ros2",
            ros_connect=("tcp/10.0.0.9:7447",),
            ros_domain=12,
            ros_distro="humble",
            ros_prefix="tb",
            ros_namespaces=("/tb1", "/lab/tb2"),
            ros_pose="pose",
            pose_timeout=0.25,
            **COMMON,
        ),
        world,
    ),
    (WorldSpec(run_id="r-2"), world),
    (AgentSpec(agent_id=7, drop_rate=0.25, drop_seed=3, secure=SECURE, **COMMON), agent),
    (
        GuardSpec(
            ros_namespaces=("/tb1", "/lab/tb2"),
            ros_connect=("tcp/10.0.0.9:7447",),
            ros_domain=3,
            ros_distro="humble",
            **COMMON,
        ),
        guard,
    ),
    (
        RobotsSpec(
            scenario="robotarium",
            count=3,
            listen=("tcp/127.0.0.1:7448",),
            domain=7,
            distro="kilted",
            prefix="bot",
            rate=30.0,
            latency_ms=20.0,
            jitter_ms=5.0,
            cmd_timeout=0.2,
            seed=9,
        ),
        robots,
    ),
]


@pytest.mark.parametrize(("spec", "command"), SPECS, ids=lambda x: getattr(x, "command", ""))
def test_a_command_line_parses_back_to_the_same_spec(
    spec: ChildSpec, command: click.Command
) -> None:
    argv = spec.argv()
    assert argv[0] == spec.command == command.name
    with command.make_context(argv[0], argv[1:]) as ctx:
        assert type(spec).of(ctx.params) == spec


@pytest.mark.parametrize(("spec", "command"), SPECS, ids=lambda x: getattr(x, "command", ""))
def test_the_environment_says_what_the_command_line_says(
    spec: ChildSpec, command: click.Command, monkeypatch: pytest.MonkeyPatch
) -> None:
    for name, value in spec.environment().items():
        monkeypatch.setenv(name, value)
    with command.make_context(
        spec.command, spec.identity(), auto_envvar_prefix=f"SHOAL_{spec.command.upper()}"
    ) as ctx:
        assert type(spec).of(ctx.params) == spec


def test_defaults_are_left_off_the_command_line() -> None:
    assert AgentSpec(run_id="r", agent_id=2).argv() == ["agent", "--run", "r", "--id", "2"]
    assert WorldSpec(run_id="r").argv() == ["world", "default", "--run", "r"]
