"""The world and every agent of a scenario as threads of one test on an in-memory bus
(bus/memory.py): no router, no ports (tests/world/test_loops.py, tests/agent/test_latency.py)."""

from __future__ import annotations

import dataclasses
import threading
from typing import Any

from shoal.agent.process import AgentNode, AgentOptions
from shoal.bus import codec
from shoal.bus.keys import Keys
from shoal.bus.memory import MemoryBus
from shoal.bus.types import Clock
from shoal.world.loader import load_scenario
from shoal.world.process import World, WorldOptions
from shoal.world.scenario import Scenario
from shoal.world.trajectory import Trajectory

RUN = "memory"


def short(name: str, duration: float) -> Scenario:
    return dataclasses.replace(load_scenario(name), duration=duration)


def run_in_memory(
    scn: Scenario,
    bus: MemoryBus,
    before: Any = None,
    agent_options: AgentOptions | None = None,
    **options: Any,
) -> tuple[dict[str, Any], list[BaseException]]:
    """The world and every agent as threads on ``bus``; ``before(world)`` runs once all are up;
    ``options``: the world's, beyond the lockstep clock; ``agent_options``: every agent's (its
    id set for each)."""
    errors: list[BaseException] = []
    chosen = {"clock": Clock.LOCKSTEP, "start_timeout": 30.0, **options}
    world = World(scn, WorldOptions(run=RUN, **chosen), bus)

    def agent(i: int) -> None:
        try:
            base = agent_options or AgentOptions(run=RUN, agent_id=i, start_timeout=30.0)
            mine = dataclasses.replace(base, agent_id=i)
            with AgentNode(mine, bus) as node:
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
