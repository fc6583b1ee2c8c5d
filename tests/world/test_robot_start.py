"""Real robots far from their scenario starts (world/start.py, world/process.py): a warning
event naming the robot, the distance and the bound beyond its body's reach; a refusal before
any command beyond halfway to another agent's start or the sensing radius. The robots are
tests/world/test_plant.py's test double on an in-memory bus."""

from __future__ import annotations

import dataclasses
import re

import numpy as np
import pytest
from memoryrun import RUN, run_in_memory, short
from test_plant import Robots

from shoal.bus import codec
from shoal.bus.keys import Keys
from shoal.bus.memory import MemoryBus
from shoal.bus.messages import Event
from shoal.bus.types import Clock
from shoal.world.loader import load_scenario
from shoal.world.process import WorldAbort
from shoal.world.scenario import Scenario
from shoal.world.start import misplaced, start_bounds

MOVED = 3  # the robot the tests move off its start (agent id)


def _events(bus: MemoryBus) -> list[Event]:
    return [codec.decode_event(p) for k, p in bus.published if k == Keys(RUN).event]


def _about_starts(bus: MemoryBus) -> list[Event]:
    return [e for e in _events(bus) if "from its scenario start" in e.text]


def _halfway(scn: Scenario, agent: int) -> float:
    """Half the distance from ``agent``'s start to the nearest other start, m."""
    starts = scn.initial_positions
    here = starts[agent - 1]
    return min(float(np.linalg.norm(here - s)) for j, s in enumerate(starts, 1) if j != agent) / 2


def _moved(scn: Scenario, by: tuple[float, float]) -> Robots:
    robots = Robots(scn, shift=0.01)  # every robot 1.4 cm off, as placed by hand
    robots.positions[MOVED - 1] += np.asarray(by)
    return robots


def test_robots_within_their_bodys_reach_start_without_a_word() -> None:
    scn = short("obstacles", 0.2)
    bus = MemoryBus()
    summary, errors = run_in_memory(scn, bus, clock=Clock.REALTIME, plant=Robots(scn, shift=0.01))
    assert not errors, errors
    assert summary["aborted"] is None and _about_starts(bus) == []


def test_a_robot_beyond_its_bodys_reach_is_warned_by_name_distance_and_bound() -> None:
    scn = short("obstacles", 0.2)
    robots, bus = _moved(scn, (0.3, 0.0)), MemoryBus()
    distance = float(np.linalg.norm(robots.positions[MOVED - 1] - scn.initial_positions[MOVED - 1]))
    summary, errors = run_in_memory(scn, bus, clock=Clock.REALTIME, plant=robots)
    assert not errors, errors
    assert summary["aborted"] is None and len(robots.sent) == scn.steps  # the run goes on
    (event,) = _about_starts(bus)
    assert (event.tick, event.level, event.agent) == (0, 3, MOVED)
    found = re.search(
        r"agent (\d+)'s robot starts ([0-9.]+) m .* more than ([0-9.]+) m", event.text
    )
    assert found, event.text
    assert int(found.group(1)) == MOVED
    assert float(found.group(2)) == pytest.approx(distance, abs=5e-4)
    assert distance == pytest.approx(np.hypot(0.31, 0.01))  # 0.3 m on top of the 1 cm each way
    assert float(found.group(3)) == pytest.approx(scn.body_reach, abs=5e-4) == 0.05
    assert "its body's reach 0.05 m" in event.text


def test_a_robot_nearer_another_start_is_refused_before_any_command() -> None:
    scn = short("obstacles", 0.2)
    bound = _halfway(scn, MOVED)
    robots, bus = _moved(scn, (bound + 0.1, 0.0)), MemoryBus()
    distance = float(np.linalg.norm(robots.positions[MOVED - 1] - scn.initial_positions[MOVED - 1]))
    with pytest.raises(WorldAbort) as caught:
        run_in_memory(scn, bus, clock=Clock.REALTIME, plant=robots)
    said = str(caught.value)
    assert f"agent {MOVED}'s robot starts {distance:.3f} m from its scenario start" in said
    assert f"beyond {bound:.3f} m (half the way to agent 5's start)" in said
    assert bound == pytest.approx(2.0363, abs=1e-4)  # agents 3 and 5 start 4.07 m apart
    assert robots.sent == [] and robots.stops == 1  # nothing driven, and a stop all the same
    (event,) = _about_starts(bus)
    assert (event.tick, event.level, event.agent) == (0, 4, MOVED)
    assert not any(k == Keys(RUN).sensing(1) for k, _ in bus.published)  # no sensing went out


def test_a_fleet_beyond_the_sensing_radius_is_refused_naming_every_robot() -> None:
    base = short("obstacles", 0.2)
    scn = dataclasses.replace(
        base, control=dataclasses.replace(base.control, sensing_radius=1.5)
    )  # halfway (≥ 2.04 m) is now farther than d
    robots = Robots(scn, shift=1.2)  # left 1.7 m away, where another run ended
    with pytest.raises(WorldAbort) as caught:
        run_in_memory(scn, MemoryBus(), clock=Clock.REALTIME, plant=robots)
    said = str(caught.value)
    for i in range(1, scn.n + 1):
        assert f"agent {i}'s robot starts 1.697 m from its scenario start, beyond 1.500 m " in said
    assert said.count("(the sensing radius 1.5 m)") == scn.n


def test_the_bounds_of_the_built_ins_and_a_declared_pose_error() -> None:
    robotarium = load_scenario("robotarium")
    b = start_bounds(robotarium)
    assert b.warn == robotarium.body_reach == pytest.approx(0.142609, abs=1e-6)  # a unicycle's
    assert b.refuse.tolist() == pytest.approx([0.282843] * 5, abs=1e-6)  # starts 0.566 m apart
    sloppy = dataclasses.replace(robotarium, position_error=0.02)
    assert start_bounds(sloppy).warn == pytest.approx(robotarium.body_reach + 0.02)
    assert "position_error 0.02 m" in start_bounds(sloppy).warn_why
    # the refusal bound is never below the warning's: the loader keeps starts ≥ 2R + 4e apart
    for name in ("default", "obstacles", "passage", "crossing", "sinusoid", "robotarium"):
        bounds = start_bounds(load_scenario(name))
        assert bounds.refuse.min() > bounds.warn, name
    # just inside the warning's bound: nothing; just beyond: robot 1 only, warned
    at = robotarium.initial_positions.copy()
    at[0, 0] += b.warn * (1 - 1e-9)
    assert misplaced(at, robotarium) == []
    at[0, 0] += b.warn * 2e-9
    (m,) = misplaced(at, robotarium)
    assert (m.agent, m.refused, m.bound) == (1, False, b.warn)
