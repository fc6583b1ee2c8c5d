"""The summary's safety figures (world/metrics.py): collisions over whole steps, the contact slack,
and the margins against the safety theorem's own bounds."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from shoal.bus.types import Reshape
from shoal.geometry.safety import TOLERANCE
from shoal.tools.simulator import simulate
from shoal.world.loader import load_scenario, parse_scenario
from shoal.world.metrics import clearances, contact_slack, pair_distances, summarize
from shoal.world.trajectory import Trajectory

TUNNEL = """
dim: 2
dt: 0.5
duration: 10.0
control: {safety: paper}
graph: {edges: [[1, 2]]}
agents: [{offset: [0, 0]}, {offset: [-6, 0], initial: [-6, 9]}]
leader: {waypoints: [[0, 0], [0, 0]], speed: 0.5}
obstacles: [{centre: [-6, 5], radius: 0.3}]
"""


def test_an_agent_that_passes_through_an_obstacle_between_ticks_collides() -> None:
    """Algorithm 2 alone with dt = 0.5 s: the follower's first step, 5.5 m long, goes from 4 m
    above the obstacle's centre to 1.5 m below it. Every tick is 1.2 m clear of the edge."""
    s = parse_scenario(TUNNEL)
    traj = simulate(s)
    assert traj.positions[:2, 1].tolist() == [[-6.0, 9.0], [-6.0, 3.5]]
    assert float(clearances(s, traj).min()) == pytest.approx(1.2)  # what ticks alone saw
    got = summarize(s, traj)
    assert got.collisions == 1
    assert got.min_clearance == pytest.approx(-0.3)  # through the centre
    assert got.guard_margin == pytest.approx(-0.3 - s.control.safety_margin)


PRESSED = """
dim: 2
dt: 0.01
duration: 10.0
agent_radius: 0.2
control: {safety_margin: 0.2}
graph: {edges: [[1, 2]]}
agents: [{offset: [0, 0]}, {offset: [-4, 0]}]
leader: {waypoints: [[0, 0], [0, 0]], speed: 0.5}
obstacles: [{centre: [-4, 3], radius: 1.0}]
"""


def pressed(overlap: np.ndarray) -> Trajectory:
    """The follower below the obstacle, its body ``overlap`` (T+1,) m into the edge at every
    tick (agent_radius = ρ: the body's edge is the guard), the leader standing at (0, 0)."""
    s = parse_scenario(PRESSED)
    ticks = overlap.shape[0] - 1
    gap = 1.0 + s.control.safety_margin - overlap  # centre to centre
    follower = np.stack([np.full_like(gap, -4.0), 3.0 - gap], axis=1)
    positions = np.stack([np.zeros_like(follower), follower], axis=1)
    return Trajectory(
        dt=s.dt,
        positions=positions,
        velocities=np.diff(positions, axis=0) / s.dt,
        omega=np.zeros((ticks, 2), dtype=bool),
        bid=np.ones((ticks, 2)),
        sigma=np.ones((ticks, 2)),
        theta=np.zeros((ticks, 2)),
        filtered=np.ones((ticks, 2), dtype=bool),
    )


def test_agent_radius_equal_to_rho_pressed_within_the_slack_does_not_collide() -> None:
    """Pressed against a row, the solver's 1e-12 m acceptance adds up tick after tick,
    and the tick metric counted overlaps of 1e-16 to 5e-12 m as collisions. They are within
    the slack the theorem allows, so 0 collisions and a guard margin in [−slack, 0]."""
    s = parse_scenario(PRESSED)
    assert s.agent_radius == s.control.safety_margin
    overlap = np.linspace(1e-16, 5e-12, s.steps + 1)
    got = summarize(s, pressed(overlap))
    assert got.contact_slack == contact_slack(s.steps) == s.steps * 4 * TOLERANCE
    assert got.collisions == 0
    assert -got.contact_slack <= got.guard_margin <= 0.0  # type: ignore[operator]
    assert got.guard_margin == pytest.approx(-5e-12, abs=1e-15)
    deeper = summarize(s, pressed(np.full(s.steps + 1, 1e-6)))  # 1 µm is no rounding
    assert deeper.collisions == 1 and deeper.guard_margin == pytest.approx(-1e-6)


def test_two_agents_pressed_together_by_a_reshape_keep_exactly_the_separation() -> None:
    """agent_radius = ρ, and a reshape (set here, past the loader) demands two slots 0.25 m
    apart with a separation of 0.4 m: the filter holds them pressed on their bisector."""
    base = parse_scenario(
        """
dim: 2
dt: 0.01
duration: 20.0
agent_radius: 0.2
control: {safety_margin: 0.2}
graph: {edges: [[1, 2], [1, 3], [2, 3]]}
agents: [{offset: [0, 0]}, {offset: [-1, 0.5]}, {offset: [-1, -0.5]}]
leader: {waypoints: [[0, 0], [0, 0]], speed: 0.5}
"""
    )
    s = dataclasses.replace(base, reshapes=(Reshape(tick=100, scale=4.0, rotate=0.0),))
    traj = simulate(s)
    got = summarize(s, traj)
    assert s.separation == 2 * s.agent_radius == 0.4
    pairs = pair_distances(traj)
    # pressed at the separation, held by the filter (going nowhere, each turns right along the
    # bisector, so they slide on it rather than sit exactly on it: geometry/safety.py sidestep)
    assert int((pairs - s.separation < 1e-4).sum()) > 50 and int(traj.filtered.sum()) > 1000
    assert got.collisions == 0
    assert -got.contact_slack <= got.separation_margin < 1e-4


def test_the_margins_are_the_least_distances_less_the_theorems_bounds() -> None:
    s = load_scenario("obstacles")
    got = summarize(s, simulate(s))
    assert got.min_clearance is not None and got.guard_margin is not None
    assert got.guard_margin == got.min_clearance - s.control.safety_margin
    assert got.separation_margin == got.min_interagent_distance - s.separation
    assert got.guard_margin >= -got.contact_slack and got.separation_margin >= 0.0


def test_the_slack_is_four_times_the_filters_tolerance_per_tick() -> None:
    assert TOLERANCE == 1e-12
    assert contact_slack(1) == 4e-12 and contact_slack(6200) == pytest.approx(2.48e-8)
