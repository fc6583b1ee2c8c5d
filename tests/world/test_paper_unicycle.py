"""``safety: paper`` with unicycles: the paper's Algorithm 2 alone, no filter, but each command
capped to the unicycle's own limit polygon (world/limits.py) by the agent, so the wheels are
never asked for more than they have. Measured on `robotarium` with the cap and without it (the
law as it was), and the lockstep loops still equal the reference with the cap in."""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
import pytest
from memoryrun import RUN, run_in_memory, short

from shoal.bus import codec
from shoal.bus.keys import Keys
from shoal.bus.memory import MemoryBus
from shoal.tools.simulator import simulate
from shoal.world.loader import load_scenario
from shoal.world.scenario import Scenario
from shoal.world.trajectory import Trajectory
from shoal.world.unicycle import wheel_command

SLACK = 1 + 1e-9  # on an edge up to rounding is on it (geometry/safety.py's cap)


def _paper(scn: Scenario) -> Scenario:
    return dataclasses.replace(scn, control=dataclasses.replace(scn.control, safety="paper"))


def _fastest(scn: Scenario) -> tuple[float, float, float]:
    """The largest |v| m/s, |ω| rad/s and wheel speed rad/s the run asks of any robot."""
    u = scn.unicycle
    assert u is not None and u.axle is not None and u.wheel_radius is not None
    traj = simulate(scn)
    assert traj.headings is not None
    v, w = wheel_command(
        traj.velocities.reshape(-1, 2), traj.headings[:-1].reshape(-1), u.lookahead, scn.dt
    )
    rim = np.maximum(np.abs(v + w * u.axle / 2), np.abs(v - w * u.axle / 2)) / u.wheel_radius
    return float(np.abs(v).max()), float(np.abs(w).max()), float(rim.max())


def test_the_papers_commands_keep_a_unicycles_wheels_within_their_limits(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    scn = _paper(load_scenario("robotarium"))
    u = scn.unicycle
    assert u is not None and u.max_wheel_speed == 12.5 and u.max_speed == 0.2
    v, w, wheel = _fastest(scn)
    assert v <= u.max_speed * SLACK and w <= u.max_turn_rate * SLACK
    assert wheel <= u.max_wheel_speed * SLACK
    assert wheel > 0.99 * u.max_wheel_speed  # the cap is met, not merely never approached
    # Without the cap (the law as it was before): 1.71 m/s, 36.4 rad/s, 172 rad/s at the wheels
    monkeypatch.setattr("shoal.agent.controller.cap_to_limits", lambda velocity, *_: velocity)
    v, w, wheel = _fastest(scn)
    assert v > 8 * u.max_speed and w > 9 * u.max_turn_rate and wheel > 13 * u.max_wheel_speed


def test_single_integrators_in_paper_mode_are_not_capped(monkeypatch: pytest.MonkeyPatch) -> None:
    called: list[Any] = []
    monkeypatch.setattr("shoal.agent.controller.cap_to_limits", lambda v, *_: called.append(v) or v)
    simulate(_paper(short("default", 1.0)))
    assert called == []  # no limits: the paper's law, bit for bit (tests/world/test_safety_modes)


def test_the_capped_paper_mode_in_lockstep_equals_the_reference_bit_for_bit() -> None:
    scn = _paper(short("robotarium", 3.0))
    bus = MemoryBus()
    summary, errors = run_in_memory(scn, bus)
    assert not errors, errors
    tick_key = Keys(RUN).tick
    records = [codec.decode_tick(p) for k, p in bus.published if k == tick_key]
    reference = simulate(scn)
    assert Trajectory.from_records(records, scn.dt, scn.lookaheads).equals(reference)
    assert summary["dropped_messages"] == 0 and summary["aborted"] is None
