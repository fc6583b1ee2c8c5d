"""The formations the benchmark runs: n agents in a widening wedge behind the leader.

Follower i senses i-1 and i-2 (agents 2 and 3 sense the leader), so the graph has no cut vertex
and a diameter of about n/2; the leader drives straight on; there are no obstacles.
"""

from __future__ import annotations

import math
from typing import Any

from shoal.bus import codec
from shoal.bus.messages import AgentState, Command, Sensing, TickRecord
from shoal.world.loader import scenario_from_dict
from shoal.world.scenario import Scenario


def bench_scenario(n: int, ticks: int, dt: float = 0.01) -> dict[str, Any]:
    offsets = [[0.0, 0.0]]
    for i in range(1, n):
        row, side = (i + 1) // 2, (1 if i % 2 else -1)
        offsets.append([-2.0 * row, 2.0 * side * math.sqrt(row)])
    edges = [[2, 1], [3, 1], [3, 2]]
    edges += [[i, i - 1] for i in range(4, n + 1)] + [[i, i - 2] for i in range(4, n + 1)]
    edges = [e for e in edges if max(e) <= n]  # two agents: the follower senses the leader
    return {
        "name": f"bench-{n}",
        "description": f"{n} agents in a wedge, straight line, no obstacles (benchmark)",
        "dt": dt,
        "duration": ticks * dt,
        "graph": {"edges": edges},
        "agents": [{"offset": o} for o in offsets],
        "initial_noise": 0.5,
        "leader": {"waypoints": [[0, 0], [1000, 0]], "speed": 1.0},
    }


def load_bench(n: int, ticks: int) -> Scenario:
    return scenario_from_dict(bench_scenario(n, ticks))


def neighbours(scenario: Scenario, agent_id: int) -> list[int]:
    """Whose states agent ``agent_id`` waits for each tick (as its controller does)."""
    c = scenario.agent_config(agent_id)
    return sorted(set(c.senses) | set(c.talks_to))


def message_sizes(scenario: Scenario) -> dict[str, int]:
    """Bytes of each message kind in a real run of ``scenario`` (typical values)."""
    n, dim = scenario.n, scenario.dim
    pos = (1.2345678901234567,) * dim
    state = AgentState(1, 123, pos, False, 1.0, 1.0, 0.0)
    tick = TickRecord(123, (pos,) * n, (pos,) * n, (False,) * n, (1.0,) * n, (1.0,) * n,
                      (0.0,) * n, (True,) * n, (False,) * n)  # fmt: skip
    return {
        "sensing": len(codec.encode_sensing(Sensing(123, pos, (), (), ()))),
        "state": len(codec.encode_state(state)),
        "cmd": len(codec.encode_report(state, Command(1, 123, pos))),
        "tick": len(codec.encode_tick(tick)),
    }
