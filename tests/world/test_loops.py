"""The world's and the agents' process loops on an in-memory bus (bus/memory.py): threads of one
test, no router, no ports. The real-router integration tests (test_run_swarm.py and others) stay;
these pin the loops themselves: the same bits as the reference, bad input counted and dropped,
and everything declared undeclared when a loop closes."""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
import pytest
from memoryrun import RUN, recorded, run_in_memory, short

from shoal.agent.process import AgentAbort, AgentNode, AgentOptions
from shoal.bus import codec
from shoal.bus.keys import Keys
from shoal.bus.memory import MemoryBus, matches
from shoal.bus.report import reports_in
from shoal.bus.types import Clock, SafetyLayer
from shoal.tools.simulator import simulate
from shoal.world.loader import load_scenario
from shoal.world.onboard import Link
from shoal.world.process import World, WorldAbort, WorldOptions


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


def test_watching_referee_changes_nothing_in_lockstep_and_counts_nothing() -> None:
    """In lockstep every command was computed from the very sensing it is applied at, so the
    referee has nothing to change: watching it gives the reference's bits and counts 0."""
    scn = short("obstacles", 6.0)
    bus = MemoryBus()
    summary, errors = run_in_memory(scn, bus, layer=SafetyLayer.NONE)
    assert not errors, errors
    assert recorded(bus, scn.dt).equals(simulate(scn))
    assert summary["safety_layer"] == "none" and summary["referee_would_correct"] == 0
    assert summary["actuator_corrections"] == 0


def test_a_watching_referee_applies_every_command_as_the_agent_sent_it() -> None:
    """Realtime at 20 times the scenario's pace, agents as threads of one process: commands
    arrive late and are held. Watching, the world moves each agent with a command that agent
    sent (or holds it still), bit for bit, however stale — and corrects none; the referee's
    count is the number of agent-ticks where filtering again would have changed something."""
    scn = short("obstacles", 2.0)
    bus = MemoryBus()
    summary, errors = run_in_memory(
        scn, bus, clock=Clock.REALTIME, speed=20.0, layer=SafetyLayer.NONE
    )
    assert not errors, errors
    keys = Keys(RUN)
    sent: dict[int, set[tuple[float, ...]]] = {i: {(0.0,) * scn.dim} for i in range(1, scn.n + 1)}
    for key, payload in bus.published:
        for i in sent:
            if key == keys.command(i):
                _state, command = codec.decode_report(payload)
                sent[i].add(tuple(command.velocity))
    records = [codec.decode_tick(p) for k, p in bus.published if k == keys.tick]
    assert len(records) == scn.steps
    for r in records:
        for i, v in enumerate(r.velocities, start=1):
            assert tuple(v) in sent[i], (r.tick, i)
    assert summary["actuator_corrections"] == 0
    assert isinstance(summary["referee_would_correct"], int)
    assert summary["referee_would_correct"] >= 0 and summary["referee_largest_change"] >= 0


def test_the_referee_keeps_a_rogue_agent_out_and_watching_counts_every_command_it_would_fix(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Agent 2 ignores its filter and drives straight at the nearest agent it senses at 3 m/s
    (under the speed limit: only the filter's rows can stop it). With the referee on, the world
    filters each of those commands again: no collision, each change counted as a correction.
    Watching, it applies them as sent: agent 2 hits, and what the referee would have changed
    is counted instead."""
    from shoal.agent.controller import Controller
    from shoal.bus.messages import Command

    honest = Controller.act

    def act(self: Controller, memory: Any, sensing: Any, heard: Any) -> Any:
        memory, command = honest(self, memory, sensing, heard)
        if command.agent_id != 2 or not sensing.agent_positions:
            return memory, command
        me = np.asarray(sensing.position)
        others = np.asarray(sensing.agent_positions)
        target = others[np.argmin(np.linalg.norm(others - me, axis=1))]
        way = (target - me) / np.linalg.norm(target - me)
        rogue = tuple((3.0 * way).tolist())  # m/s: faster than the formation, under the cap
        return memory, Command(command.agent_id, command.tick, rogue, command.filtered)

    monkeypatch.setattr(Controller, "act", act)
    scn = dataclasses.replace(load_scenario("default"), duration=3.0)
    on, errors = run_in_memory(scn, MemoryBus())
    assert not errors, errors
    watched, errors = run_in_memory(scn, MemoryBus(), layer=SafetyLayer.NONE)
    assert not errors, errors
    assert on["collisions"] == 0 and on["actuator_corrections"] > 0
    assert watched["collisions"] > 0 and watched["actuator_corrections"] == 0
    assert watched["referee_would_correct"] > 0
    assert 0 < watched["referee_largest_change"] <= 6.0  # at most reversing a 3 m/s command
    # Each robot's own layer, with neighbours known only from its radio's snapshots (late by
    # 2 ± 1 ticks, 20 % lost): it keeps the rogue out without any referee.
    link = Link(delay=2.0, jitter=1.0, drop_rate=0.2, seed=7)
    onboard, errors = run_in_memory(scn, MemoryBus(), layer=SafetyLayer.ONBOARD, link=link)
    assert not errors, errors
    assert onboard["collisions"] == 0 and onboard["actuator_corrections"] > 0
    assert onboard["min_interagent_distance"] >= scn.separation - 1e-9
    assert onboard["layer_standing"] > 0 and onboard["referee_would_correct"] >= 0


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
