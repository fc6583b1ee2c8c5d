"""Arrival, its causes and livelocks (world/arrival.py), each rule on a synthetic trajectory.

The scenario: a leader from (0, 0) to (10, 0) at 1 m/s and one follower whose slot is 2 m behind
it, dt = 0.1 s (a 1 s window of 10 ticks; no progress for 10 s is 100 ticks). The positions are
written by hand, so each rule is exercised on its own.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from shoal.world.arrival import (
    NO_PROGRESS_TIME,
    arrival,
    arrival_tolerance,
    route_left,
    trailing_mean,
    trailing_min,
    window_ticks,
)
from shoal.world.loader import parse_scenario
from shoal.world.metrics import summarize
from shoal.world.scenario import Scenario
from shoal.world.trajectory import Trajectory

DT = 0.1
SCENARIO = """
dim: 2
dt: 0.1
duration: {duration}
control: {{beta: {beta}}}
graph: {{edges: [[1, 2]]}}
agents: [{{offset: [0, 0]}}, {{offset: [-2, 0]}}]
leader: {{waypoints: {waypoints}, speed: 1.0}}
"""


def scenario(
    duration: float = 60.0, beta: float = 2.0, waypoints: str = "[[0, 0], [10, 0]]"
) -> Scenario:
    return parse_scenario(SCENARIO.format(duration=duration, beta=beta, waypoints=waypoints))


def trajectory(leader: np.ndarray, follower: np.ndarray) -> Trajectory:
    """A run from the (T+1, 2) positions of the leader and of the follower, m."""
    positions = np.stack([leader, follower], axis=1)
    ticks = positions.shape[0] - 1
    return Trajectory(
        dt=DT,
        positions=positions,
        velocities=np.diff(positions, axis=0) / DT,
        omega=np.zeros((ticks, 2), dtype=bool),
        bid=np.ones((ticks, 2)),
        sigma=np.ones((ticks, 2)),
        theta=np.zeros((ticks, 2)),
        filtered=np.zeros((ticks, 2), dtype=bool),
    )


def times(duration: float = 60.0) -> np.ndarray:
    return np.arange(round(duration / DT) + 1) * DT


def on_route(t: np.ndarray) -> np.ndarray:
    """(T+1, 2) the leader on schedule: along x at 1 m/s, then standing at (10, 0)."""
    return np.stack([np.minimum(t, 10.0), np.zeros_like(t)], axis=1)


def chatter(t: np.ndarray, amplitude: float) -> np.ndarray:
    """(T+1, 2) ± amplitude along x, every other tick: the sign term's period-2 chatter."""
    sign = np.where(np.arange(t.shape[0]) % 2 == 0, 1.0, -1.0)
    return np.stack([amplitude * sign, np.zeros_like(t)], axis=1)


SLOT = np.array([-2.0, 0.0])


def test_a_formation_chattering_by_more_than_the_tolerance_arrives_on_its_average() -> None:
    """The follower chatters ±0.3 m (β·dt/2 with β = 6), beyond R = 0.2 m at every tick; its
    1 s average is on the slot, so the run arrives when the leader comes within R of its goal."""
    s, t = scenario(beta=6.0), times()
    leader = on_route(t)
    got = arrival(s, trajectory(leader, leader + SLOT + chatter(t, 0.3)))
    assert got.arrived and got.cause is None
    assert got.tolerance == 0.2
    assert got.time == pytest.approx(9.8)  # the leader 0.2 m from (10, 0)
    assert got.slot_distance == pytest.approx(0.0, abs=1e-12)
    assert got.livelocks == 0


def test_the_tolerance_is_half_the_separation_whatever_beta() -> None:
    assert arrival_tolerance(scenario(beta=2.0)) == arrival_tolerance(scenario(beta=60.0)) == 0.2


def test_a_follower_knocked_off_its_slot_and_standing_at_the_end_is_a_deadlock() -> None:
    """Settled since 9.8 s, the follower is pushed 1 m aside at 55 s and stands there: the
    formation is worse than 10 s before and its farthest follower is still."""
    s, t = scenario(), times()
    leader = on_route(t)
    follower = leader + SLOT
    follower[t >= 55.0, 1] += 1.0
    got = arrival(s, trajectory(leader, follower))
    assert not got.arrived and got.time is None
    assert got.cause == "deadlock" and got.livelocks == 0


def test_followers_off_their_slots_when_the_leader_has_just_come_home_are_out_of_time() -> None:
    """The leader reaches the end of a 55 m route at 55 s of 60: 5 s is too soon to judge."""
    s, t = scenario(waypoints="[[0, 0], [55, 0]]"), times()
    leader = np.stack([np.minimum(t, 55.0), np.zeros_like(t)], axis=1)
    got = arrival(s, trajectory(leader, leader + SLOT + [0.0, 1.0]))
    assert not got.arrived and got.cause == "out of time"


def test_a_leader_circling_short_of_its_goal_is_trapped() -> None:
    """From t = 5 s the leader circles (5, 1) at 1 m/s for the rest of the run, its follower in
    place behind it: 'leader trapped'."""
    s, t = scenario(), times()
    leader = on_route(t)
    later = t >= 5.0
    phase = t[later] - 5.0
    leader[later] = np.stack([5.0 + np.sin(phase), 1.0 - np.cos(phase)], axis=1)
    got = arrival(s, trajectory(leader, leader + SLOT))
    assert not got.arrived and got.cause == "leader trapped"


def test_a_leader_still_on_its_way_when_the_run_ends_is_out_of_time() -> None:
    s, t = scenario(duration=30.0, waypoints="[[0, 0], [100, 0]]"), times(30.0)
    leader = np.stack([t, np.zeros_like(t)], axis=1)
    got = arrival(s, trajectory(leader, leader + SLOT))
    assert not got.arrived and got.cause == "out of time"


def test_a_follower_standing_off_its_slot_is_a_deadlock_with_the_filter_idle() -> None:
    """The leader is home at 10 s; from then on the follower stands 1 m short of its slot,
    chattering: 'deadlock', though the filter never acted (so no stall either)."""
    s, t = scenario(), times()
    leader = on_route(t)
    follower = leader + SLOT
    follower[t >= 10.0] = [7.0, 0.0]  # the slot is (8, 0)
    follower += chatter(t, 0.3)
    traj = trajectory(leader, follower)
    got = arrival(s, traj)
    assert not got.arrived and got.cause == "deadlock"
    assert got.slot_distance == pytest.approx(1.0, abs=1e-9)
    assert got.livelocks == 0
    summary = summarize(s, traj)
    assert summary.stalls == 0 and summary.not_arrived == "deadlock"


def circling(t: np.ndarray, start: float, radius: float = 1.0) -> np.ndarray:
    """(T+1, 2) offsets from the slot: none until ``start``, then out to ``radius`` m over 1 s,
    then round the slot at 1 m/s."""
    out = np.zeros((t.shape[0], 2))
    rise = np.clip(t - start, 0.0, 1.0) * radius
    angle = np.clip(t - start - 1.0, 0.0, None) / radius
    out[:, 0] = rise * np.cos(angle)
    out[:, 1] = rise * np.sin(angle)
    return out


def test_a_follower_circling_its_slot_for_good_is_a_livelock() -> None:
    s, t = scenario(), times()
    leader = on_route(t)
    got = arrival(s, trajectory(leader, leader + SLOT + circling(t, start=12.0)))
    assert not got.arrived and got.cause == "livelock"
    assert got.livelocks == 1
    # off its slot from 12.6 s (when its 1 s average passes R) to the end at 60 s
    assert got.longest_livelock == pytest.approx(60.0 - 12.6)


def test_a_detour_shorter_than_the_no_progress_time_is_no_livelock() -> None:
    """Out 1 m and round the slot for 7 s, then back: an evasion, not a livelock."""
    s, t = scenario(), times()
    leader = on_route(t)
    away = circling(t, start=12.0)
    away[t >= 12.0 + 7.0] = 0.0
    assert NO_PROGRESS_TIME > 7.0
    got = arrival(s, trajectory(leader, leader + SLOT + away))
    assert got.arrived and got.livelocks == 0
    assert got.time == pytest.approx(19.7)  # back at 19 s; its 1 s average within R at 19.7 s


def test_a_follower_trailing_its_moving_slot_is_tracking_not_livelocked() -> None:
    """The leader is on a 100 m route for all 60 s; its follower keeps 1 m behind its slot: no
    progress towards it, moving, but the slot moves too."""
    s, t = scenario(waypoints="[[0, 0], [100, 0]]"), times()
    leader = np.stack([t, np.zeros_like(t)], axis=1)
    got = arrival(s, trajectory(leader, leader + SLOT - [1.0, 0.0]))
    assert not got.arrived and got.cause == "out of time"
    assert got.livelocks == 0 and got.slot_distance == pytest.approx(1.0)


def test_followers_still_converging_when_the_run_ends_are_out_of_time() -> None:
    """The leader is home; the follower closes in on its slot at 0.2 m/s, 2 m every 10 s."""
    s, t = scenario(duration=30.0), times(30.0)
    leader = on_route(t)
    follower = leader + SLOT
    follower[:, 1] = 6.6 - 0.2 * t  # 0.6 m off at the end
    got = arrival(s, trajectory(leader, follower))
    assert not got.arrived and got.cause == "out of time"
    assert got.slot_distance == pytest.approx(6.6 - 0.2 * 29.45)  # the mean of ticks 29.0..29.9 s


def test_the_route_left_shrinks_along_a_route_that_turns_back() -> None:
    """Straight-line distance to the goal grows by 10 m on the way out; the route left shrinks
    all the way, but for the ``reach`` it counts the turning point as visited early by."""
    s = scenario(waypoints="[[0, 0], [10, 0], [0, 0]]")
    t = np.arange(200) * DT
    x = np.where(t <= 10.0, t, 20.0 - t)
    leader = np.stack([x, np.zeros_like(x)], axis=1)
    left = route_left(s.path, leader, reach=0.3, dt=DT)
    assert left[0] == pytest.approx(20.0) and left[-1] == pytest.approx(0.1)
    rising = np.flatnonzero(np.diff(left) > 1e-12)
    assert x[rising].tolist() == pytest.approx([9.7, 9.8, 9.9])  # reached at 9.7, then on to 10
    assert left[97] == pytest.approx(9.7) and left[96] == pytest.approx(10.4)


def test_the_window_is_a_second_at_least_ten_ticks_and_even() -> None:
    assert [window_ticks(dt) for dt in (0.01, 0.03, 0.05, 0.1, 0.5)] == [100, 34, 20, 10, 10]


@pytest.mark.parametrize("p", [0, 1, 4, 7, 30])
def test_the_trailing_min_is_the_least_of_the_last_p_plus_one_samples(p: int) -> None:
    x = np.random.default_rng(p).normal(size=(50, 3))
    want = np.stack([x[max(0, k - p) : k + 1].min(axis=0) for k in range(50)])
    assert np.array_equal(trailing_min(x, p), want)


def test_the_trailing_mean_averages_what_there_is_before_a_full_window() -> None:
    x = np.arange(6, dtype=np.float64)[:, None]
    assert trailing_mean(x, 4)[:, 0].tolist() == [0.0, 0.5, 1.0, 1.5, 2.5, 3.5]


def test_a_formation_whose_agreed_sigma_flips_every_tick_has_not_arrived() -> None:
    """σ 2 ↔ 1 every tick from 30 s: the follower stands halfway between its two slots
    (-1.5, 0), so its error alternates ±0.5 m and the 1 s average cancels it; the formation
    has not arrived all the same, and the flipping is named a livelock."""
    s, t = scenario(), times()
    leader = on_route(t)
    follower = leader + SLOT
    follower[300:] = leader[300:] + np.array([-1.5, 0.0])
    traj = trajectory(leader, follower)
    flips = np.where(np.arange(traj.ticks) % 2 == 0, 2.0, 1.0)
    sigma = traj.sigma.copy()
    sigma[300:] = flips[300:, None]
    got = arrival(s, dataclasses.replace(traj, sigma=sigma))
    assert got.slot_distance < got.tolerance  # the average alone would call it arrived
    assert not got.arrived and got.time is None and got.cause == "livelock"
    steady = arrival(s, dataclasses.replace(traj, sigma=np.where(sigma > 1.0, 1.0, sigma)))
    assert not steady.arrived and steady.cause == "deadlock"  # 0.5 m off, standing
