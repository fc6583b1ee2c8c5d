"""world/plant.py in the world's loop: with robots in place of its kinematics, the world
senses and records where the robots say they are, hands them the tick's velocities, holds a
robot whose pose is stale, and stops every robot however the run ends. The robots here are a
test double on an in-memory bus (the ROS 2 ones: tests/tools/test_bridge.py)."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from memoryrun import RUN, recorded, run_in_memory, short

from shoal.bus import codec
from shoal.bus.keys import Keys
from shoal.bus.memory import MemoryBus
from shoal.bus.types import REACHED, Clock, Waypoints
from shoal.world.plant import Observed, PlantError
from shoal.world.process import World, WorldAbort, WorldOptions
from shoal.world.scenario import Scenario


class Robots:
    """Single integrators the test moves itself, a tick of each velocity sent, offset from the
    scenario's starts by ``shift`` (real robots are never quite where a scenario says);
    ``stale``: agents whose pose never refreshes; ``fail_after``: sends before one raises."""

    def __init__(
        self,
        scn: Scenario,
        *,
        shift: float = 0.0,
        stale: frozenset[int] = frozenset(),
        fail_after: int | None = None,
        ready: bool = True,
    ) -> None:
        self.dt = scn.dt
        self.positions = scn.initial_positions + shift
        self.stale = stale
        self.fail_after = fail_after
        self.ready = ready
        self.observed: list[np.ndarray[Any, Any]] = []
        self.sent: list[np.ndarray[Any, Any]] = []
        self.stops = 0

    def wait_ready(self, timeout: float) -> None:
        if not self.ready:
            raise PlantError("no pose from /robot2")

    def observe(self) -> Observed:
        self.observed.append(self.positions.copy())
        ages = np.full(len(self.positions), 0.001 * len(self.observed))
        return Observed(self.positions.copy(), None, self.stale, ages)

    simulated = False  # robots on the wall clock

    def send(self, velocities: Any, headings: Any, movers: Any = None) -> Any:
        if self.fail_after is not None and len(self.sent) >= self.fail_after:
            raise RuntimeError("the robots' link broke")
        self.sent.append(velocities.copy())
        self.positions = self.positions + self.dt * velocities
        return np.column_stack([velocities, -velocities[:, 0]])  # whatever the robots took

    def stop(self) -> None:
        self.stops += 1

    def report(self) -> dict[str, Any]:
        return {"robot_commands": len(self.sent)}

    def record(self, tick: int) -> None:
        return None


def test_the_world_records_where_the_robots_are_and_sends_them_each_tick() -> None:
    scn = short("obstacles", 0.5)
    robots = Robots(scn, shift=0.01)
    bus = MemoryBus()
    summary, errors = run_in_memory(scn, bus, clock=Clock.REALTIME, plant=robots)
    assert not errors, errors
    traj = recorded(bus, scn.dt)
    assert summary["robot_commands"] == len(robots.sent) == scn.steps == traj.ticks
    assert summary["pose_holds"] == 0
    # every tick's record is the pose the robots reported at its start, not an integration
    assert np.array_equal(traj.positions[: scn.steps], np.asarray(robots.observed[: scn.steps]))
    assert np.array_equal(traj.positions[0], scn.initial_positions + 0.01)
    assert robots.stops >= 1 and any(np.abs(v).max() > 0 for v in robots.sent)
    # each tick the log has what the robots reported (their poses' ages) and were sent
    records = [codec.decode_robots(p) for k, p in bus.published if k == Keys(RUN).robots]
    assert [r.tick for r in records] == list(range(len(robots.sent)))
    for k, r in enumerate(records):
        assert r.ages == (0.001 * (k + 1),) * scn.n
        sent = robots.sent[k]
        assert r.twists == tuple((x, y, -x) for x, y in sent.tolist())


def test_a_robot_whose_pose_is_stale_is_held_still_and_said_so() -> None:
    scn = short("obstacles", 0.3)
    robots = Robots(scn, stale=frozenset({3}))
    bus = MemoryBus()
    summary, errors = run_in_memory(scn, bus, clock=Clock.REALTIME, plant=robots)
    assert not errors, errors
    assert all((v[2] == 0.0).all() for v in robots.sent)
    assert any(np.abs(v[1]).max() > 0 for v in robots.sent)  # the others move
    assert summary["pose_holds"] == scn.steps
    events = [codec.decode_event(p) for k, p in bus.published if k == Keys(RUN).event]
    said = [e for e in events if e.agent == 3 and "stale" in e.text]
    assert len(said) == 1 and said[0].tick == 0


def test_robots_are_stopped_when_the_run_breaks_and_a_silent_robot_is_named() -> None:
    scn = short("obstacles", 0.5)
    robots = Robots(scn, fail_after=5)
    with pytest.raises(RuntimeError, match="link broke"):
        run_in_memory(scn, MemoryBus(), clock=Clock.REALTIME, plant=robots)
    assert len(robots.sent) == 5 and robots.stops == 1
    with pytest.raises(WorldAbort, match="no pose from /robot2"):
        run_in_memory(scn, MemoryBus(), clock=Clock.REALTIME, plant=Robots(scn, ready=False))


def test_robots_are_refused_in_lockstep_and_at_another_speed() -> None:
    scn = short("obstacles", 0.5)
    for options in (
        WorldOptions(run="r", clock=Clock.LOCKSTEP, plant=Robots(scn)),
        WorldOptions(run="r", clock=Clock.REALTIME, speed=2.0, plant=Robots(scn)),
    ):
        with pytest.raises(WorldAbort, match="wall clock"):
            World(scn, options, MemoryBus())


def test_driving_robots_the_leader_is_served_a_reach_of_a_ticks_travel() -> None:
    scn = short("obstacles", 0.5)
    keys = Keys(RUN)

    def served(plant: Robots | None) -> dict[int, Any]:
        bus = MemoryBus()
        with World(scn, WorldOptions(run=RUN, clock=Clock.REALTIME, plant=plant), bus):
            got = bus.ask([keys.config(i) for i in range(1, scn.n + 1)], timeout=1.0)
        return {i + 1: codec.decode_config(a.payload) for i, a in enumerate(got)}

    simulated, driven = served(None), served(Robots(scn))
    path = simulated[1].path
    assert isinstance(path, Waypoints) and path.reach == REACHED
    wide = driven[1].path
    assert isinstance(wide, Waypoints)
    assert wide.reach == path.speed * scn.dt and wide.points == path.points
    assert all(driven[i] == simulated[i] for i in range(2, scn.n + 1))  # followers as they were
