"""The world's and the agents' process loops on an in-memory bus (bus/memory.py): threads of one
test, no router, no ports. The real-router integration tests (test_run_swarm.py and others) stay;
these pin the loops themselves: the same bits as the reference, bad input counted and dropped,
and everything declared undeclared when a loop closes."""

from __future__ import annotations

import dataclasses
import threading
from typing import Any

import pytest

from shoal.agent.process import AgentAbort, AgentNode, AgentOptions
from shoal.bus import codec
from shoal.bus.keys import Keys
from shoal.bus.memory import MemoryBus, matches
from shoal.bus.report import reports_in
from shoal.bus.types import Clock
from shoal.tools.simulator import simulate
from shoal.world.loader import load_scenario
from shoal.world.process import World, WorldAbort, WorldOptions
from shoal.world.scenario import Scenario
from shoal.world.trajectory import Trajectory

RUN = "memory"


def short(name: str, duration: float) -> Scenario:
    return dataclasses.replace(load_scenario(name), duration=duration)


def run_in_memory(
    scn: Scenario, bus: MemoryBus, before: Any = None
) -> tuple[dict[str, Any], list[BaseException]]:
    """The world and every agent as threads on ``bus``; ``before(world)`` runs once all are up."""
    errors: list[BaseException] = []
    world = World(scn, WorldOptions(run=RUN, clock=Clock.LOCKSTEP, start_timeout=30.0), bus)

    def agent(i: int) -> None:
        try:
            with AgentNode(AgentOptions(run=RUN, agent_id=i, start_timeout=30.0), bus) as node:
                node.run()
        except BaseException as exc:  # reported to the test, not lost in a thread
            errors.append(exc)

    threads = [threading.Thread(target=agent, args=(i,), daemon=True) for i in range(1, scn.n + 1)]
    for t in threads:
        t.start()
    with world:
        world.wait_for_everyone()
        if before is not None:
            before(world)
        summary = world.run()
    for t in threads:
        t.join(timeout=30.0)
    assert not any(t.is_alive() for t in threads), "an agent did not exit with the world"
    return summary, errors


def recorded(bus: MemoryBus, dt: float) -> Trajectory:
    tick_key = Keys(RUN).tick
    records = [codec.decode_tick(p) for k, p in bus.published if k == tick_key]
    return Trajectory.from_records(records, dt)


@pytest.mark.parametrize(("name", "duration"), [("obstacles", 6.0), ("default", 4.0)])
def test_the_loops_on_a_memory_bus_equal_the_reference_bit_for_bit(
    name: str, duration: float
) -> None:
    scn = short(name, duration)
    bus = MemoryBus()
    summary, errors = run_in_memory(scn, bus)
    assert not errors, errors
    assert recorded(bus, scn.dt).equals(simulate(scn))
    assert summary["dropped_messages"] == 0 and summary["aborted"] is None
    reports = reports_in(summary)  # every agent answered the world's report query
    assert sorted(reports) == list(range(1, scn.n + 1))
    assert all(r["last_tick"] == scn.steps - 1 and r["bad_messages"] == 0 for r in reports.values())
    assert all((r["pss_kb"] or 0) > 0 for r in reports.values())  # Linux: /proc/self/smaps_rollup
    assert bus.declared == 0  # every loop undeclared what it declared


def test_malformed_commands_are_counted_and_dropped_and_change_nothing() -> None:
    scn = short("sinusoid", 1.0)
    bus = MemoryBus()
    keys = Keys(RUN)

    def garbage(_world: World) -> None:
        bus.put(keys.command(2), b"\x00not msgpack")
        bus.put(keys.command(3), codec.encode_event(codec_event()))  # valid bytes, wrong kind

    summary, errors = run_in_memory(scn, bus, before=garbage)
    assert not errors, errors
    assert summary["dropped_messages"] == 2
    assert recorded(bus, scn.dt).equals(simulate(scn))


def codec_event() -> Any:
    from shoal.bus.messages import Event

    return Event(0, 2, 0, "not a command")


def test_an_agent_without_a_world_gives_up_and_leaves_nothing_declared() -> None:
    bus = MemoryBus()
    with pytest.raises(AgentAbort, match="no world for run"):
        AgentNode(AgentOptions(run=RUN, agent_id=1, start_timeout=0.05), bus)
    assert bus.declared == 0


def test_a_second_world_on_the_same_run_is_refused() -> None:
    scn = short("sinusoid", 1.0)
    bus = MemoryBus()
    with (
        World(scn, WorldOptions(run=RUN), bus),
        pytest.raises(WorldAbort, match="another world already serves"),
    ):
        World(scn, WorldOptions(run=RUN), bus)
    assert bus.declared == 0


@pytest.mark.parametrize(
    ("pattern", "key", "hit"),
    [
        ("shoal/r/agent/*/cmd", "shoal/r/agent/3/cmd", True),
        ("shoal/r/agent/*/cmd", "shoal/r/agent/3/state", False),
        ("shoal/r/**", "shoal/r/world/tick", True),
        ("@shoal/r/**", "@shoal/r/agent/1", True),
        ("shoal/r/**", "shoal/other/world/tick", False),
        ("shoal/r/agent/1", "shoal/r/agent/1", True),
        ("shoal/r/agent/*", "shoal/r/agent/1/extra", False),
    ],
)
def test_key_expressions_match_as_in_zenoh(pattern: str, key: str, hit: bool) -> None:
    assert matches(pattern, key) is hit
