"""Run logs for the export tests (tests/integration/test_foxglove.py, test_live.py,
tests/tools/test_ros2.py): small scenarios, the reference simulator's ticks as a run log, and a
raw log written with the logger's own writer."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from shoal.bus import codec
from shoal.bus.keys import Keys
from shoal.bus.messages import Event, TickRecord
from shoal.tools.foxglove.views import RunLog
from shoal.tools.log.writer import McapLog
from shoal.tools.simulator import run as simulate_ticks
from shoal.tools.simulator import simulate
from shoal.world.loader import parse_scenario
from shoal.world.metrics import summarize

T0 = 1_790_000_000_123_456_789  # ns: a log time in 2026
LOG_STEP = 7_000_000  # ns between tick records: log time is not simulated time (dt = 20 ms)

# Four agents, 200 ticks: follower 2 meets the obstacle and evades (Ω) from tick 22 to 159;
# the formation is scaled and turned at 3 s (σ 1 → 1.5, θ 0.3).
TINY = """
name: tiny
dim: 2
seed: 1
dt: 0.02
duration: 4.0
agent_radius: 0.05
tolerance_factor: 10
graph:
  directed: false
  edges: [[1, 2], [1, 3], [2, 3], [2, 4], [3, 4]]
agents:
  - offset: [0, 0]
  - offset: [-2, 1.5]
  - offset: [-2, -1.5]
  - offset: [-4, 0]
initial_noise: 0.3
leader:
  waypoints: [[0, 0], [10, 0]]
  speed: 1.0
obstacles:
  - {centre: [1.5, 1.5], radius: 0.5}
reshape:
  - {at: 3.0, scale: 1.5, rotate: 0.3}
"""
TINY_3D = (
    TINY.replace("name: tiny", "name: tiny3d")
    .replace("dim: 2", "dim: 3")
    .replace("[0, 0]", "[0, 0, 0]")
    .replace("[-2, 1.5]", "[-2, 1.5, 0.5]")
    .replace("[-2, -1.5]", "[-2, -1.5, 0]")
    .replace("[-4, 0]", "[-4, 0, -0.5]")
    .replace("[10, 0]", "[10, 0, 0]")
    .replace("[1.5, 1.5]", "[1.5, 1.5, 0.5]")
)
GONE_AT = 120  # agent 4's process "dies" here in the reference log with a departure


# Two people walk across TINY's path: a person (social force) and a blind walker.
TINY_PEOPLE = TINY.replace("name: tiny", "name: tinypeople").replace(
    "  - {centre: [1.5, 1.5], radius: 0.5}\n",
    "  - {centre: [1.5, 1.5], radius: 0.5}\n"
    "  - {centre: [4, 3], radius: 0.3, moves: {kind: person, goals: [[4, -3]], speed: 1.0}}\n"
    "  - {centre: [6, -3], radius: 0.3, moves: {kind: route, waypoints: [[6, 3]], speed: 1.2}}\n",
)


def reference_log(text: str, *, gone: int | None = None) -> RunLog:
    """The reference simulator's ticks as a run log. With ``gone``, agent 4 is held still from
    tick ``gone`` on, with the world's departure event, as the world does for a dead process."""
    scenario = parse_scenario(text)
    ticks: list[tuple[int, TickRecord]] = []
    held: tuple[float, ...] | None = None
    for t in simulate_ticks(scenario):
        alive = tuple(
            not (gone is not None and t.tick >= gone and i == 3) for i in range(scenario.n)
        )
        positions, velocities = list(t.positions), list(t.velocities)
        if not alive[3]:
            held = held or positions[3]
            positions[3], velocities[3] = held, (0.0,) * scenario.dim
        record = replace(
            t,
            positions=tuple(positions),
            velocities=tuple(velocities),
            omega=tuple(o and alive[i] for i, o in enumerate(t.omega)),
            alive=alive,
        )
        ticks.append((T0 + (t.tick + 1) * LOG_STEP, record))
    finished = Event(scenario.steps, 2, 0, "run finished; 0 bad messages dropped")
    events = [(ticks[-1][0] + 1, finished)]
    if gone is not None:
        text = f"agent 4 gone at tick {gone}; held still from now on"
        events.insert(0, (T0 + gone * LOG_STEP + 1, Event(gone, 3, 4, text)))
    return RunLog(scenario, T0, ticks, events)


def raw_log(path: Path, run: RunLog, run_id: str = "fox-1") -> None:
    """A raw log as the logger writes it (its own writer, keys and payloads), from ``run``."""
    keys = Keys(run_id)
    s = run.scenario
    summary = {**summarize(s, simulate(s)).as_dict(), "clock": "lockstep"}
    with McapLog(path, run=run_id) as log:
        doc = {"name": s.name, "yaml": s.source}
        log.add(keys.scenario, codec.encode_document("scenario", doc), run.start_ns)
        log.attach_scenario(s.name, s.source, run.start_ns)
        events = list(run.events)
        for ns, r in run.ticks:
            log.add(keys.sensing(1), b"\x80", ns - 2)  # agents' traffic: never read by export
            log.add(keys.tick, codec.encode_tick(r), ns)
            while events and events[0][0] <= ns:
                e_ns, e = events.pop(0)
                log.add(keys.event, codec.encode_event(e), e_ns)
        for e_ns, e in events:
            log.add(keys.event, codec.encode_event(e), e_ns)
        log.add(keys.summary, codec.encode_document("summary", summary), run.ticks[-1][0] + 5)
        log.add_summary(summary)
