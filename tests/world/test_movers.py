"""Moving obstacles and people (world/movers.py, geometry/safety.py's moving rows, docs/people.md):
the filter keeps an agent faster than u_max off any obstacle that walks at up to u_max, a
cornered agent never moves towards who corners it, contacts are classified by that rule, the
social force model walks people where they should go, and a run with people is exact."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from shoal.bus import codec
from shoal.bus.errors import DecodeError
from shoal.bus.messages import Mover, Sensing, TickRecord
from shoal.geometry import safety
from shoal.geometry.safety import mover_row, safe_velocity
from shoal.tools.simulator import simulate
from shoal.world.contacts import TOWARDS, contacts
from shoal.world.errors import ScenarioError
from shoal.world.loader import load_scenario, scenario_from_dict
from shoal.world.metrics import summarize
from shoal.world.movers import Body, Drift, MoverState, Person, Route, advance, plan, start
from shoal.world.trajectory import Trajectory

DT, RHO, RADIUS = 0.05, 0.3, 0.3


def gap_over_step(s: np.ndarray, v: np.ndarray, c: np.ndarray, w: np.ndarray) -> float:
    """Least distance between agent s + τv and obstacle c + τw for τ in [0, DT]."""
    rel, closing = s - c, v - w
    a = float(closing @ closing)
    t = 0.0 if a == 0.0 else min(DT, max(0.0, -float(rel @ closing) / a))
    return float(np.linalg.norm(rel + t * closing))


def filtered(nominal: tuple[float, ...], position: tuple[float, ...], movers: list[Mover],
             limit: float) -> safety.Filtered:  # fmt: skip
    sensing = Sensing(0, position, (), (), (), movers=tuple(movers))
    return safe_velocity(
        nominal, sensing, 1, dt=DT, margin=RHO, half_separation=0.2, speed_limit=limit
    )


unit_angle = st.floats(0.0, 2 * math.pi)


@settings(max_examples=400, deadline=None)
@given(
    gap=st.floats(0.0, 1.5),  # how far outside the guard circle the agent starts, m
    bearing=unit_angle,
    heading=unit_angle,
    walk=unit_angle,
    walk_speed=st.floats(0.0, 1.0),  # fraction of u_max the obstacle really walks at
    nominal_speed=st.floats(0.0, 3.0),
    u_max=st.floats(0.1, 1.75),
)
def test_an_agent_faster_than_u_max_keeps_its_clearance_whatever_the_obstacle_does(
    gap: float, bearing: float, heading: float, walk: float, walk_speed: float,
    nominal_speed: float, u_max: float,
) -> None:  # fmt: skip
    """One moving obstacle, free space all round: for any nominal and any velocity the obstacle
    really walks at (up to u_max), the filtered step keeps the agent outside r + ρ over the
    whole step, within the speed limit (v_max = 1.2·u_max + 0.1)."""
    limit = 1.2 * u_max + 0.1
    c = np.zeros(2)
    s = (RADIUS + RHO + gap) * np.array([math.cos(bearing), math.sin(bearing)])
    w = walk_speed * u_max * np.array([math.cos(walk), math.sin(walk)])
    mover = Mover(0, tuple(c), RADIUS, tuple(w), u_max)
    nominal = (nominal_speed * math.cos(heading), nominal_speed * math.sin(heading))
    out = filtered(nominal, tuple(s), [mover], limit)
    v = np.asarray(out.velocity)
    assert not out.cornered
    assert float(np.linalg.norm(v)) <= limit * (1 + 1e-9)
    assert gap_over_step(s, v, c, w) >= RADIUS + RHO - 1e-9


def test_without_the_walking_term_the_filter_lets_a_person_reach_the_guard(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The property above fails for a filter whose moving row forgets u_max·dt (the static
    row): a person walking straight at an agent that stands on its guard circle."""
    u_max = 1.3
    s, c, w = np.array([RADIUS + RHO + 0.01, 0.0]), np.zeros(2), np.array([u_max, 0.0])
    mover = Mover(0, (0.0, 0.0), RADIUS, (u_max, 0.0), u_max)
    good = np.asarray(filtered((0.0, 0.0), tuple(s), [mover], 2.0).velocity)
    assert gap_over_step(s, good, c, w) >= RADIUS + RHO - 1e-9
    static = Mover(0, (0.0, 0.0), RADIUS, (u_max, 0.0), 0.0)  # as if it stood
    monkeypatch.setattr(safety, "mover_row", lambda p, m, r, dt: mover_row(p, static, r, dt))
    bad = np.asarray(filtered((0.0, 0.0), tuple(s), [mover], 2.0).velocity)
    assert gap_over_step(s, bad, c, w) < RADIUS + RHO - 1e-3


def test_one_person_walking_at_a_standing_agent_for_many_ticks_never_reaches_its_guard() -> None:
    """A drift at u_max straight at an agent whose nominal is to stay: tick after tick the agent
    backs off, at least as fast as the person comes, and the gap never drops below ρ."""
    u_max = 1.3
    s, c, w = np.array([3.0, 0.0]), np.zeros(2), np.array([u_max, 0.0])
    least = math.inf
    for _ in range(200):
        mover = Mover(0, tuple(c), RADIUS, tuple(w), u_max)
        v = np.asarray(filtered((0.0, 0.0), tuple(s), [mover], 2.0).velocity)
        least = min(least, gap_over_step(s, v, c, w) - RADIUS)
        s, c = s + DT * v, c + DT * w
    assert least >= RHO - 1e-9
    assert c[0] == pytest.approx(200 * DT * u_max)  # the person walked 13 m ...
    assert s[0] >= c[0] + RADIUS + RHO - 1e-9  # ... and pushed the agent ahead of it


@settings(max_examples=300, deadline=None)
@given(
    bearings=st.lists(unit_angle, min_size=2, max_size=4),
    gaps=st.lists(st.floats(-0.2, 0.05), min_size=4, max_size=4),
    heading=unit_angle,
    nominal_speed=st.floats(0.0, 2.0),
)
def test_a_cornered_agent_never_moves_towards_who_corners_it(
    bearings: list[float], gaps: list[float], heading: float, nominal_speed: float
) -> None:
    """People close in from several sides (some already inside the guard), faster than the
    agent can flee: wherever the filter cannot meet every row, the agent moves towards none of
    the obstacles whose rows it cannot meet (g·v ≥ 0), and never faster than its limit."""
    limit = 0.5  # slower than the people: cornering is possible
    movers = []
    for k, b in enumerate(bearings):
        d = RADIUS + RHO + gaps[k]
        centre = (-d * math.cos(b), -d * math.sin(b))
        movers.append(Mover(k, centre, RADIUS, (math.cos(b), math.sin(b)), 1.3))
    nominal = (nominal_speed * math.cos(heading), nominal_speed * math.sin(heading))
    out = filtered(nominal, (0.0, 0.0), movers, limit)
    v = np.asarray(out.velocity)
    assert float(np.linalg.norm(v)) <= limit * (1 + 1e-9)
    rows = [mover_row((0.0, 0.0), m, RHO, DT) for m in movers]
    if out.cornered:
        for r in rows:
            if r.bound > 0:
                assert float(np.dot(r.normal, v)) >= -TOWARDS
    else:
        for r in rows:
            assert float(np.dot(r.normal, v)) * DT >= r.bound - 1e-12


def test_an_agent_pinned_between_two_people_flees_or_stands_and_contacts_are_theirs() -> None:
    """Two blind walkers converge on a slow agent from both sides (it cannot outrun them):
    they touch it, and every contact is classified as the obstacles' fault."""
    data = {
        "dim": 2, "dt": DT, "duration": 4.0, "agent_radius": 0.2,
        "control": {"alpha": 1.0, "beta": 0.3, "sensing_radius": 4.0, "trigger_radius": 3.0,
                    "epsilon": 0.05, "safety_margin": RHO, "speed_limit": 0.3},
        "graph": {"directed": False, "edges": [[1, 2]]},
        "agents": [{"offset": [0, 0], "initial": [0, 0]}, {"offset": [-2, 0], "initial": [-2, 0]}],
        "leader": {"waypoints": [[0, 0], [0.1, 0]], "speed": 0.1},
        "obstacles": [
            {"centre": [0, 2.5], "radius": RADIUS,
             "moves": {"kind": "drift", "velocity": [0, -1.2]}},
            {"centre": [0, -2.5], "radius": RADIUS,
             "moves": {"kind": "drift", "velocity": [0, 1.2]}},
        ],
    }  # fmt: skip
    scenario = scenario_from_dict(data)
    traj = simulate(scenario)
    touches = contacts(scenario, traj)
    assert touches, "the walkers were meant to reach the agent"
    assert all(c.fault == "obstacle" and c.approach <= 1e-9 for c in touches)
    summary = summarize(scenario, traj)
    assert summary.agent_at_fault == 0
    assert summary.obstacle_at_fault == len(touches)


def test_contact_fault_follows_the_agents_own_motion() -> None:
    """The classifier alone: an agent that walks into a standing-still mover is at fault; one
    that stands while the mover walks into it is not; a touch between two samples counts."""

    def run(agent_v: float, mover_v: float) -> list[object]:
        s = load_scenario("crossing")
        ticks = 10
        pos = np.zeros((ticks + 1, s.n, 2))
        pos[:, :, 1] = np.arange(s.n) * 10.0  # agents far apart; agent 1 on the x axis
        vel = np.zeros((ticks, s.n, 2))
        vel[:, 0, 0] = agent_v
        pos[1:, 0, 0] = np.cumsum(vel[:, 0, 0]) * s.dt
        movers = np.full((ticks + 1, len(s.mover_ids), 2), 100.0)
        mvel = np.zeros((ticks, len(s.mover_ids), 2))
        movers[:, 0] = [[1.0, 0.0]] * (ticks + 1)
        mvel[:, 0, 0] = mover_v
        movers[1:, 0, 0] = 1.0 + np.cumsum(mvel[:, 0, 0]) * s.dt
        zeros = np.zeros((ticks, s.n))
        traj = Trajectory(s.dt, pos, vel, zeros.astype(bool), zeros + 1, zeros + 1, zeros,
                          zeros.astype(bool), movers, mvel)  # fmt: skip
        return contacts(s, traj)  # type: ignore[return-value]

    into = run(agent_v=20.0, mover_v=0.0)  # 1 m per tick: jumps through it between samples
    assert [c.fault for c in into] == ["agent"]  # type: ignore[attr-defined]
    hit = run(agent_v=0.0, mover_v=-20.0)
    assert [c.fault for c in hit] == ["obstacle"]  # type: ignore[attr-defined]
    assert run(agent_v=0.0, mover_v=0.0) == []


# -- the social force model and the other motions ------------------------------------------------


def test_a_person_alone_walks_to_its_goal_at_its_preferred_speed_and_stands() -> None:
    p = Person(goals=((10.0, 0.0),), speed=1.0, u_max=1.3)
    state = start([p], [(0.0, 0.0)])
    speeds = []
    for _ in range(400):
        state = plan([p], [RADIUS], state, [], 0.2, [], DT)
        speeds.append(math.hypot(*state.velocities[0]))
        state = advance(state, DT)
    assert math.dist(state.centres[0], (10.0, 0.0)) < 0.25
    assert max(speeds) <= 1.3 + 1e-12
    assert speeds[50] == pytest.approx(1.0, abs=1e-9)  # cruising at the preferred speed
    assert speeds[-1] < 0.01  # arrived: it stands


def test_two_people_head_on_give_way_and_never_touch() -> None:
    people = [Person(((8.0, 0.05),), 1.0, 1.3), Person(((0.0, -0.05),), 1.0, 1.3)]
    state = start(people, [(0.0, 0.0), (8.0, 0.0)])
    least = math.inf
    for _ in range(300):
        state = plan(people, [RADIUS, RADIUS], state, [], 0.2, [], DT)
        state = advance(state, DT)
        least = min(least, math.dist(*state.centres) - 2 * RADIUS)
    assert least > 0.0
    assert math.dist(state.centres[0], (8.0, 0.05)) < 0.3


def test_a_reactive_person_steps_round_a_robot_and_a_blind_one_does_not() -> None:
    def closest(reactive: bool) -> float:
        p = Person(((8.0, 0.0),), 1.0, 1.3, reactive=reactive)
        state, least = start([p], [(0.0, 0.02)]), math.inf
        for _ in range(200):
            state = plan([p], [RADIUS], state, [(4.0, 0.0)], 0.2, [], DT)
            state = advance(state, DT)
            least = min(least, math.dist(state.centres[0], (4.0, 0.0)))
        return least

    assert closest(reactive=True) > RADIUS + 0.2
    assert closest(reactive=False) < 0.1


def test_a_person_is_pushed_off_a_standing_obstacle_on_its_way() -> None:
    p = Person(((8.0, 0.0),), 1.0, 1.3, reactive=False)
    wall = [Body((4.0, 0.0), 0.5, wall=True)]
    state, least = start([p], [(0.0, 0.05)]), math.inf
    for _ in range(300):
        state = plan([p], [RADIUS], state, [], 0.2, wall, DT)
        state = advance(state, DT)
        least = min(least, math.dist(state.centres[0], (4.0, 0.0)) - 0.5 - RADIUS)
    assert least > 0.0


def test_a_route_is_walked_exactly_and_a_drift_keeps_its_velocity() -> None:
    route = Route(((1.0, 0.0), (1.0, 1.0)), speed=0.5)
    drift = Drift((0.3, -0.4))
    state = start([route, drift], [(0.0, 0.0), (0.0, 0.0)])
    for _ in range(200):
        state = plan([route, drift], [0.3, 0.3], state, [], 0.2, [], 0.1)
        assert math.hypot(*state.velocities[0]) <= 0.5 + 1e-12
        state = advance(state, 0.1)
    assert state.centres[0] == pytest.approx((1.0, 1.0), abs=1e-12)  # stopped at the end
    assert state.centres[1] == pytest.approx((6.0, -8.0), abs=1e-9)
    assert drift.speed_cap == pytest.approx(0.5)


# -- scenarios, wire, log -------------------------------------------------------------------------


def crossing_with(**moves: object) -> dict[str, object]:
    from importlib import resources

    import yaml

    text = resources.files("shoal.world.scenarios").joinpath("crossing.yaml").read_text()
    data: dict[str, object] = yaml.safe_load(text)
    obstacles = data["obstacles"]
    assert isinstance(obstacles, list)
    obstacles[0]["moves"] = {**obstacles[0]["moves"], **moves}
    return data


@pytest.mark.parametrize(
    ("moves", "field", "says"),
    [
        ({"kind": "fly"}, "obstacles[0].moves.kind", "must be one of drift, route, person"),
        ({"u_max": 0.5}, "obstacles[0].moves.u_max", "below the preferred speed"),
        ({"goals": []}, "obstacles[0].moves.goals", "at least one point"),
        ({"reactive": "yes"}, "obstacles[0].moves.reactive", "true or false"),
        ({"speed": -1}, "obstacles[0].moves.speed", "must be > 0"),
        ({"wings": 2}, "obstacles[0].moves.wings", "unknown"),
    ],
)
def test_a_bad_motion_is_refused_naming_its_field(moves: dict[str, object], field: str,
                                                   says: str) -> None:  # fmt: skip
    with pytest.raises(ScenarioError) as err:
        scenario_from_dict(crossing_with(**moves))
    assert err.value.field == field and says in str(err.value)


def test_moving_obstacles_need_the_filter_and_the_sensing_range_for_u_max() -> None:
    data = crossing_with()
    data["control"] = {**data["control"], "safety": "paper"}  # type: ignore[dict-item]
    with pytest.raises(ScenarioError, match=r"need control\.safety: filter"):
        scenario_from_dict(data)
    data = crossing_with(u_max=70.0)  # u_max·dt = 3.5 m eats the sensing range
    with pytest.raises(ScenarioError, match=r"u_max·dt") as err:
        scenario_from_dict(data)
    assert err.value.field == "control.sensing_radius"
    data = crossing_with()
    data["obstacles"][0]["centre"] = [-1.5, 1.4]  # type: ignore[index]
    with pytest.raises(ScenarioError, match="inside its guard circle"):
        scenario_from_dict(data)


def test_sensing_and_tick_records_carry_movers_and_refuse_bad_ones() -> None:
    mover = Mover(3, (1.0, 2.0), 0.3, (0.5, -0.5), 1.3)
    s = Sensing(7, (0.0, 0.0), (1,), ((5.0, 5.0),), (1.0,), (2,), ((1.0, 0.0),), (mover,))
    assert codec.decode_sensing(codec.encode_sensing(s)) == s
    plain = Sensing(7, (0.0, 0.0), (), (), ())
    assert b"mv" not in codec.encode_sensing(plain)  # a static run's bytes are unchanged
    import msgpack

    body = msgpack.unpackb(codec.encode_sensing(s))
    for bad in ([[3, [1.0, 2.0], 0.3, [0.5], 1.3]], [[3, [1.0, 2.0], -1.0, [0.5, 0.5], 1.3]],
                [[3, [1.0, 2.0, 3.0], 0.3, [0.5, 0.5, 0.1], 1.3]], "x", [[1, 2]]):  # fmt: skip
        with pytest.raises(DecodeError):
            codec.decode_sensing(msgpack.packb({**body, "mv": bad}))
    t = TickRecord(0, ((0.0, 0.0),), ((1.0, 0.0),), (False,), (1.0,), (1.0,), (0.0,), (True,),
                   (False,), ((3.0, 3.0),), ((0.0, 1.0),))  # fmt: skip
    assert codec.decode_tick(codec.encode_tick(t)) == t
    with pytest.raises(DecodeError):
        codec.decode_tick(msgpack.packb({**msgpack.unpackb(codec.encode_tick(t)), "mw": []}))


def test_crossing_keeps_every_agent_off_the_people_and_the_record_round_trips(
    tmp_path: object,
) -> None:
    scenario = load_scenario("crossing")
    traj = simulate(scenario)
    summary = summarize(scenario, traj)
    assert traj.movers is not None and traj.movers.shape == (scenario.steps + 1, 5, 2)
    assert summary.collisions == 0 and summary.agent_at_fault == 0
    assert summary.min_mover_clearance is not None
    assert summary.min_mover_clearance >= scenario.control.safety_margin - 1e-9
    people = traj.movers
    # The people really walked through where the formation went: each one crossed x = 8 ± 4.
    assert np.all(np.linalg.norm(people[-1] - people[0], axis=1) > 6.0)
    assert summary.final_formation_error <= scenario.tolerance
    from pathlib import Path

    path = Path(str(tmp_path)) / "t.npz"
    traj.save(path)
    again = Trajectory.load(path)
    assert again.equals(traj) and again.digest() == traj.digest()
    without = Trajectory(**{**traj.__dict__, "movers": None, "mover_velocities": None})
    assert without.digest() != traj.digest()  # the people are part of what is compared


def test_moving_state_is_unchanged_by_a_plan_without_movers() -> None:
    state = MoverState((), (), ())
    assert plan([], [], state, [(0.0, 0.0)], 0.2, [], DT) == state
