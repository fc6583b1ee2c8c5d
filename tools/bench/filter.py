"""What the safety filter costs per agent-tick (``shoal bench --filter``), warm, on the calls a
real run makes: every call of one campaign field where the filter acts is recorded, then
replayed through the agents' own :class:`shoal.geometry.safety.SafetyFilter` alone. Beside it, in
the same invocation, the whole reference simulator's CPU per agent-tick (the agent's laws,
sensing, the world's second pass): the budget the filter takes its share of."""

from __future__ import annotations

import importlib.util
import statistics
import sys
import time
from pathlib import Path
from types import ModuleType
from typing import Any
from unittest import mock

from shoal.agent import controller
from shoal.bus.messages import Sensing
from shoal.bus.types import Vector
from shoal.geometry import safety
from shoal.tools import simulator
from shoal.tools.campaign.fields import make_field
from shoal.tools.simulator import simulate
from shoal.world.loader import load_scenario

# One call of an agent's filter: its nominal, its sensing, the filter, its previous heading.
Call = tuple[Vector, Sensing, safety.SafetyFilter, Vector | None]


def _source(module: ModuleType) -> ModuleType:
    """``module`` as Python: a compiled controller (setup.py) calls the filter within C, where
    no patch reaches, and a compiled simulator calls the compiled controller, so the calls are
    recorded through their sources instead (the same bits: tests/tools/test_compiled.py)."""
    source = Path(str(module.__file__)).with_name(module.__name__.rpartition(".")[2] + ".py")
    if Path(str(module.__file__)) == source:
        return module
    name = module.__name__ + "_source"
    spec = importlib.util.spec_from_file_location(name, source)
    assert spec is not None and spec.loader is not None
    loaded = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = loaded  # its dataclasses look their module up there
    spec.loader.exec_module(loaded)
    return loaded


def _record(seed: int) -> tuple[list[Call], float, int]:
    """Every filter call of campaign field ``seed`` (base ``obstacles``), the simulator's CPU
    seconds for the field (as installed: compiled or not), and its agent-ticks."""
    field = make_field(load_scenario("obstacles"), seed)
    calls: list[Call] = []

    class Recording:
        """Stands in for the controller's SafetyFilter: each agent's real filter, every call
        recorded."""

        @staticmethod
        def of(*args: Any, **kw: Any) -> Any:
            real = safety.SafetyFilter.of(*args, **kw)

            def recorded(
                nominal: Vector, sensing: Sensing, *, previous: Vector | None = None
            ) -> Any:
                calls.append((nominal, sensing, real, previous))
                return real(nominal, sensing, previous=previous)

            return recorded

    laws, loop = _source(controller), _source(simulator)
    with (
        mock.patch.object(laws, "SafetyFilter", Recording),
        mock.patch.object(loop, "Controller", laws.Controller),
    ):
        loop.simulate(field)
    start = time.process_time()
    simulate(field)
    cpu = time.process_time() - start
    return calls, cpu, field.steps * field.n


def _per_call_us(calls: list[Call], repeats: int) -> float:
    best = float("inf")
    for _ in range(repeats):  # the best of several passes: warm caches, least interference
        start = time.process_time()
        for nominal, sensing, f, previous in calls:
            f(nominal, sensing, previous=previous)
        best = min(best, time.process_time() - start)
    return best / max(1, len(calls)) * 1e6


def bench_filter(seed: int = 6, repeats: int = 5) -> dict[str, Any]:
    """The figures, as one JSON-able dict (µs of CPU)."""
    calls, sim_cpu, agent_ticks = _record(seed)
    flags = [
        f(nominal, sensing, previous=previous).active for nominal, sensing, f, previous in calls
    ]
    active = [c for c, f in zip(calls, flags, strict=True) if f]
    idle = [c for c, f in zip(calls, flags, strict=True) if not f]
    rows = [len(c[1].obstacle_ids) + len(c[1].agent_ids) for c in calls]
    return {
        "field": f"obstacles-inside-{seed}",
        "agent_ticks": agent_ticks,
        "filter_us_per_agent_tick": round(_per_call_us(calls, repeats), 2),
        "filter_us_idle": round(_per_call_us(idle, repeats), 2),
        "filter_us_active": round(_per_call_us(active, repeats), 2) if active else None,
        "active_share": round(len(active) / max(1, len(calls)), 4),
        "sensed_per_call_median": statistics.median(rows) if rows else 0,
        "target_us": 10.0,
        "simulator_us_per_agent_tick": round(sim_cpu / agent_ticks * 1e6, 2),
    }
