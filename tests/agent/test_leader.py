"""The leader's detour (agent/leader.py): with the safety filter a leader whose leg crosses an
obstacle's guard goes round it on a polygon that keeps r + 2ρ + ε, then resumes its route."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from triangle import triangle

from shoal.agent.leader import detour, lead, remember, steer
from shoal.bus.types import REACHED
from shoal.geometry.vectors import segment_distance
from shoal.world.errors import AssumptionError, DetourWarning
from shoal.world.loader import scenario_from_dict

RHO, CLEAR = 0.2, 0.25  # the controller's guard ρ and clearance ρ + ε


def _legs(start: np.ndarray, route: tuple[tuple[float, ...], ...]) -> list[tuple[object, ...]]:
    points = [tuple(start.tolist()), *route]
    return list(itertools.pairwise(points))


@settings(max_examples=200, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    dim=st.sampled_from([2, 3]),
)
def test_a_detour_keeps_its_circle_on_every_leg_and_ends_at_the_waypoint(
    seed: int, dim: int
) -> None:
    rng = np.random.default_rng(seed)
    start, goal = np.zeros(dim), np.zeros(dim)
    goal[0] = 12.0
    centre = rng.uniform(-1, 1, size=dim) * 0.8
    centre[0] = rng.uniform(3, 9)
    radius = float(rng.uniform(0.3, 1.5))
    waypoint = tuple(goal.tolist())
    route = detour(start, (waypoint,), centre[None], np.array([radius]), guard=RHO, clearance=CLEAR)
    keep = radius + RHO + CLEAR
    if segment_distance(centre, start, goal) >= keep - CLEAR / 2:
        assert route == (waypoint,)  # nothing in the way: no detour
        return
    assert len(route) >= 2 and route[-1] is waypoint
    for a, b in _legs(start, route):
        assert segment_distance(centre, a, b) >= keep - 1e-9


def test_a_leg_clear_of_every_obstacle_is_left_alone() -> None:
    start, route = np.zeros(2), ((10.0, 0.0),)
    far = np.array([[5.0, 3.0]])
    assert detour(start, route, far, np.array([1.0]), guard=RHO, clearance=CLEAR) is route


def test_a_blocked_short_side_sends_the_leader_round_the_other() -> None:
    start, goal = np.zeros(2), (12.0, 0.0)
    centres = np.array([[6.0, 0.3], [6.0, 2.2]])  # the second sits on the short way round
    radii = np.array([1.0, 0.5])
    route = detour(start, (goal,), centres, radii, guard=RHO, clearance=CLEAR)
    assert all(p[1] < 0 for p in route[:-1])  # round below, the long way
    for a, b in _legs(start, route):
        for c, r in zip(centres, radii, strict=True):
            assert segment_distance(c, a, b) >= r + RHO + CLEAR / 2


def test_two_obstacles_with_no_way_between_or_round_are_gone_round_together() -> None:
    start, goal = np.zeros(2), (12.0, 0.0)
    centres = np.array([[6.0, -0.6], [6.0, 0.9]])
    radii = np.array([0.8, 0.6])
    route = detour(start, (goal,), centres, radii, guard=RHO, clearance=CLEAR)
    assert len(route) >= 2
    for a, b in _legs(start, route):
        for c, r in zip(centres, radii, strict=True):
            assert segment_distance(c, a, b) >= r + RHO


def test_lead_visits_the_waypoints_in_order_at_the_paths_speed() -> None:
    position = np.zeros(2)
    route = ((1.0, 0.0), (1.0, 1.0))
    visited, speeds = [], []
    for _ in range(400):
        v, left = lead(position, route, 2.0, 0.01)
        speeds.append(float(np.linalg.norm(v)))
        if len(left) < len(route):
            visited.append(route[0])
        route = left
        position = position + 0.01 * np.asarray(v)
    assert visited == [(1.0, 0.0), (1.0, 1.0)]
    assert max(speeds) <= 2.0 + 1e-12 and speeds[-1] == 0.0
    assert np.allclose(position, [1.0, 1.0], atol=1e-12)


def _scenario(waypoints: list[list[float]], **control: object) -> dict[str, object]:
    return triangle(waypoints, duration=30.0, obstacle=([8, 0.2], 1.0), **control)


def test_an_obstacle_on_the_leaders_path_is_a_warning_with_the_filter_an_error_without() -> None:
    with pytest.warns(DetourWarning, match="leader will go round it"):
        scenario_from_dict(_scenario([[0, 0], [16, 0]]))
    with pytest.raises(AssumptionError, match="Assumption 4"):
        scenario_from_dict(_scenario([[0, 0], [16, 0]], safety="paper"))


def test_a_waypoint_too_close_to_an_obstacle_is_refused_even_with_the_filter() -> None:
    with pytest.raises(AssumptionError, match="not reach a waypoint") as refused:
        scenario_from_dict(_scenario([[0, 0], [8, 1.3], [16, 0]]))
    assert refused.value.field == "leader.waypoints[1]"


def test_the_formation_follows_a_leader_that_goes_round_an_obstacle_on_its_path() -> None:
    from shoal.tools.simulator import simulate
    from shoal.world.metrics import summarize

    with pytest.warns(DetourWarning):
        scn = scenario_from_dict(_scenario([[0, 0], [16, 0]]))
    traj = simulate(scn)
    s = summarize(scn, traj)
    assert s.collisions == 0 and s.min_clearance >= RHO - 1e-9
    assert np.allclose(traj.positions[-1, 0], [16.0, 0.0], atol=1e-9)  # the leader got there
    assert s.final_formation_error <= s.tolerance  # and the formation closed up behind it
    leader_y = traj.positions[:, 0, 1]
    assert leader_y.min() < -1.0  # it went round (below: the centre is above the leg)


def test_a_detour_crossed_by_an_obstacle_that_comes_into_view_is_planned_anew() -> None:
    start, goal = (0.0, 0.0), (12.0, 0.0)
    first = (np.array([[6.0, -0.1]]), np.array([1.0]))  # below the leg: round above, shorter
    route, planned = steer(start, (goal,), 0, *first, guard=RHO, clearance=CLEAR)
    assert planned == len(route) - 1 >= 1 and all(p[1] > 0 for p in route[:-1])
    # Closer in, a second obstacle appears above the first, on the detour (0.43 m edge to edge
    # from it, > 2ρ): the top polygon now runs through its guard.
    both = (np.array([[6.0, -0.1], [6.2, 2.3]]), np.array([1.0, 1.0]))
    assert any(segment_distance(both[0][1], a, b) < 1.0 + RHO for a, b in _legs(np.zeros(2), route))
    again, planned = steer(start, route, planned, *both, guard=RHO, clearance=CLEAR)
    assert planned == len(again) - 1 >= 1 and again[-1] == goal
    assert all(p[1] < 0 for p in again[:-1])  # round below now, the long way
    for a, b in _legs(np.zeros(2), again):
        for c, r in zip(*both, strict=True):
            assert segment_distance(c, a, b) >= r + RHO + CLEAR / 2


def test_a_clear_detour_ahead_is_kept_and_reached_vertices_are_counted_off() -> None:
    obstacle = (np.array([[6.0, -0.1]]), np.array([1.0]))
    route, planned = steer((0.0, 0.0), ((12.0, 0.0),), 0, *obstacle, guard=RHO, clearance=CLEAR)
    kept, still = steer((0.0, 0.0), route, planned, *obstacle, guard=RHO, clearance=CLEAR)
    assert kept is route and still == planned
    on, left = steer(route[0], route, planned, *obstacle, guard=RHO, clearance=CLEAR)
    assert on == route[1:] and left == planned - 1


def test_a_leader_whose_detour_a_later_obstacle_blocks_still_reaches_its_goal() -> None:
    """The second obstacle is beyond the sensing radius when the
    leader plans round the first; before re-planning it circled the first for 38 s and ended
    21.6 m short."""
    from shoal.tools.simulator import simulate
    from shoal.world.metrics import summarize

    field = {
        "dim": 2, "dt": 0.01, "duration": 90.0,
        "control": {"sensing_radius": 6.0, "trigger_radius": 5.0},
        "graph": {"edges": [[1, 2]]},
        "agents": [{"offset": [0, 0]}, {"offset": [-3, 0]}],
        "leader": {"waypoints": [[0, 0], [40, 0]], "speed": 0.77},
        "obstacles": [
            {"centre": [18.394, -0.093], "radius": 0.98},
            {"centre": [18.597, 2.29], "radius": 0.98},
        ],
    }  # fmt: skip
    with pytest.warns(DetourWarning):
        scn = scenario_from_dict(field)
    traj = simulate(scn)
    s = summarize(scn, traj)
    assert s.collisions == 0 and s.leader_shortfall <= 1e-9
    arrived = np.flatnonzero(np.linalg.norm(traj.positions[:, 0] - [40.0, 0.0], axis=1) <= 1e-9)
    assert arrived.size and arrived[0] * scn.dt < 60.0  # the route alone takes 52 s
    assert s.final_formation_error <= s.tolerance


def test_a_leader_remembers_the_obstacles_it_has_seen_in_id_order() -> None:
    known = remember((), (2, 0), [(5.0, 1.0), (1.0, 0.0)], [0.5, 0.4])
    assert known == ((0, (1.0, 0.0), 0.4), (2, (5.0, 1.0), 0.5))
    assert remember(known, (0,), [(1.0, 0.0)], [0.4]) is known  # nothing new: the same tuple
    again = remember(known, (1,), [(3.0, 0.0)], [0.3])  # out of range now: 0 and 2 stay known
    assert [k for k, _, _ in again] == [0, 1, 2]


def test_a_leader_that_loses_sight_of_an_obstacle_round_a_cluster_does_not_turn_back() -> None:
    """A field kept from the hard generator: planning against what was in view alone, the
    leader turned back each time one obstacle of a cluster left its sensing range, and ended
    9 m short after 84 s."""
    from pathlib import Path

    from shoal.tools.simulator import simulate
    from shoal.world.loader import load_scenario
    from shoal.world.metrics import summarize

    with pytest.warns(DetourWarning):
        scn = load_scenario(Path(__file__).parents[1] / "fields" / "leader-sees-and-loses.yaml")
    s = summarize(scn, simulate(scn))
    assert s.collisions == 0 and s.leader_shortfall <= 1e-9


def _late_leader(reach: float, lag: int, ticks: int = 3000) -> tuple[int, float, float]:
    """A leader that sees its own position ``lag`` ticks late (a robot's pose) on an L-shaped
    route, 1 m/s, dt 0.01 s: the waypoints left at the end, how far it ended from the last
    one (m) and how fast it still moved over the last second (m/s, greatest)."""
    dt, route = 0.01, ((5.0, 0.0), (5.0, 5.0))
    here, seen, moving = np.zeros(2), [np.zeros(2)] * (lag + 1), 0.0
    for k in range(ticks):
        v, route = lead(seen[-lag - 1], route, 1.0, dt, reach=reach)
        here = here + dt * np.asarray(v)
        seen.append(here)
        if k >= ticks - 100:
            moving = max(moving, float(np.linalg.norm(v)))
    return len(route), float(np.linalg.norm(here - (5.0, 5.0))), moving


@pytest.mark.parametrize("lag", [2, 3, 5])
def test_a_leader_seen_late_visits_its_route_within_the_reach_the_world_serves(lag: int) -> None:
    """Through late poses (ROS 2 robots) a leader that must land within 1 nm overshoots, is sent
    back, overshoots again, and never ends its route; with the reach the world serves robots
    (a tick's travel at the path's speed, world/process.py) it ends it and stands still,
    within that reach and the lag's travel of its goal."""
    dt = 0.01
    left, _, moving = _late_leader(REACHED, lag)
    assert left == 1 and moving > 0.01
    reach = 1.0 * dt
    left, off, moving = _late_leader(reach, lag)
    assert left == 0 and moving == 0.0
    assert off <= reach + lag * dt * 1.0
