"""Unicycles (world/unicycle.py): the exact arc the world integrates, the bounds the safety
theorem for unicycles rests on (the point lands on its certified step, its departure, the
limits), and the guarantee itself along the true arcs over many ticks — with the Robotarium's
start-of-tick map, whose departure ratchets into the guard, caught."""

from __future__ import annotations

import dataclasses
import math
from importlib import resources

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from shoal.bus.messages import Mover, Sensing
from shoal.geometry.safety import safe_velocity
from shoal.tools.commands.report import render_summary
from shoal.tools.simulator import simulate
from shoal.world.errors import ScenarioError
from shoal.world.loader import load_scenario, parse_scenario
from shoal.world.metrics import summarize
from shoal.world.scenario import Scenario, Unicycle
from shoal.world.trajectory import Trajectory
from shoal.world.unicycle import (
    arc_departure,
    body_centres,
    drive,
    speed_cap,
    step,
    wheel_command,
)

ANGLES = st.floats(-math.pi, math.pi)
GRITSBOT = Unicycle(0.05, 0.2, 3.6363636363636362, 0.016, 0.11, 12.5)


def _command(u: np.ndarray, theta: float, ell: float, dt: float) -> tuple[float, float]:
    v, w = wheel_command(u[None], np.array([theta]), ell, dt)
    return float(v[0]), float(w[0])


def _euler(point: np.ndarray, theta: float, u: np.ndarray, ell: float, dt: float, n: int) -> tuple:
    """The same (v, ω) held, integrated in n tiny Euler steps of the body: the reference."""
    v, w = _command(u, theta, ell, dt)
    c = point - ell * np.array([math.cos(theta), math.sin(theta)])
    h = dt / n
    for _ in range(n):
        c = c + h * v * np.array([math.cos(theta), math.sin(theta)])
        theta += h * w
    return c + ell * np.array([math.cos(theta), math.sin(theta)]), theta


def test_a_command_along_the_heading_drives_straight_and_exactly() -> None:
    points, headings = np.array([[1.0, 2.0]]), np.array([math.pi / 2])
    moved, turned = step(points, headings, np.array([[0.0, 0.5]]), 0.05, 0.1)
    assert moved.tolist() == [[pytest.approx(1.0, abs=1e-15), 2.05]] and turned.tolist() == [
        math.pi / 2
    ]


@settings(max_examples=60, deadline=None)
@given(ANGLES, ANGLES, st.floats(0.01, 1.0), st.floats(0.02, 0.3), st.floats(0.005, 0.1))
def test_the_arc_is_the_bodys_exact_motion(
    theta: float, direction: float, fraction: float, ell: float, dt: float
) -> None:
    speed = fraction * ell / dt
    u = speed * np.array([math.cos(direction), math.sin(direction)])
    p0 = np.array([0.3, -0.7])
    moved, turned = step(p0[None], np.array([theta]), u[None], ell, dt)
    ref, ref_theta = _euler(p0, theta, u, ell, dt, 4000)
    v, w = _command(u, theta, ell, dt)
    euler = abs(v) * dt * abs(w) * dt / 4000  # the reference's own error, first order
    assert float(np.linalg.norm(moved[0] - ref)) <= 2 * euler + 1e-12
    assert turned[0] == pytest.approx(ref_theta, abs=1e-9)


@settings(max_examples=300, deadline=None)
@given(ANGLES, ANGLES, st.floats(0.0, 1.0), st.floats(0.01, 0.5), st.floats(0.001, 0.2))
def test_the_point_lands_on_its_step_and_never_strays_from_it_by_more_than_the_departure(
    theta: float, direction: float, fraction: float, ell: float, dt: float
) -> None:
    """For any heading and any speed up to l/dt: the tick ends with the point at p0 + u·dt (the
    step the filter certified), and along the whole tick (sampled) the point is within the
    departure l·x²/2 of where the straight step has it at the same instant, and within |u|·dt
    of its start (it runs a little faster than |u| along the arc, but never farther than the
    chord's end)."""
    speed = fraction * ell / dt
    u = speed * np.array([math.cos(direction), math.sin(direction)])
    p0 = np.array([[2.0, 1.0]])
    h0 = np.array([theta])
    moved, _ = step(p0, h0, u[None], ell, dt)
    assert float(np.linalg.norm(moved[0] - p0[0] - u * dt)) <= 1e-12
    v, w = wheel_command(u[None], h0, ell, dt)
    departure = arc_departure(speed, ell, dt)
    for tau in np.linspace(0.0, 1.0, 21):
        p, _ = drive(p0, h0, v, w, ell, tau * dt)
        off = p[0] - p0[0]
        assert float(np.linalg.norm(off - tau * dt * u)) <= departure + 1e-12
        assert float(np.linalg.norm(off)) <= speed * dt + 1e-12  # the arc is under π


@settings(max_examples=100, deadline=None)
@given(st.floats(0.01, 1.0), st.floats(0.01, 0.5), st.floats(0.001, 0.2))
def test_the_departure_is_reached_by_a_point_turning_in_place(
    fraction: float, ell: float, dt: float
) -> None:
    """Pure rotation (u across the heading) reaches the bound up to O(x²): l·x²/2 is not loose
    (measured: 99.9 % of it at a tenth of the cap's speed, 86 % at the cap, x = π/6)."""
    speed = fraction * ell / dt
    u = np.array([[0.0, speed]])
    v, w = wheel_command(u, np.array([0.0]), ell, dt)
    worst = 0.0
    for tau in np.linspace(0.0, 1.0, 201):
        p, _ = drive(np.zeros((1, 2)), np.zeros(1), v, w, ell, tau * dt)
        worst = max(worst, float(np.linalg.norm(p[0] - tau * dt * u[0])))
    x = math.asin(speed * dt / (2 * ell))
    assert worst >= (1 - x * x) * arc_departure(speed, ell, dt)


@settings(max_examples=200, deadline=None)
@given(ANGLES, ANGLES, st.floats(0.0, 1.0), st.sampled_from([0.005, 0.033, 0.1, 0.3]))
def test_a_point_under_its_cap_keeps_every_limit_whatever_the_heading(
    theta: float, direction: float, fraction: float, dt: float
) -> None:
    speed = fraction * GRITSBOT.point_speed_cap(dt)
    u = speed * np.array([math.cos(direction), math.sin(direction)])
    v, w = _command(u, theta, GRITSBOT.lookahead, dt)
    assert abs(v) <= GRITSBOT.max_speed + 1e-12 and abs(w) <= GRITSBOT.max_turn_rate + 1e-12
    for rim in (v + w * 0.11 / 2, v - w * 0.11 / 2):  # each wheel's rim speed
        assert abs(rim) <= 0.016 * 12.5 + 1e-12


def test_the_gritsbots_point_cap_is_set_by_its_wheels() -> None:
    rim = 0.2 / math.hypot(1, 0.11 / 0.1)  # 0.1345 m/s
    assert GRITSBOT.limit() == pytest.approx(rim)
    # at its 0.033 s tick the arc costs 0.033 % of that; at 0.3 s, 2.7 %
    assert GRITSBOT.point_speed_cap(0.033) == pytest.approx(rim, rel=4e-4)
    assert GRITSBOT.point_speed_cap(0.033) < rim
    assert GRITSBOT.point_speed_cap(0.3) == pytest.approx(rim, rel=0.03)
    assert Unicycle(0.05, 0.2, 3.0).limit() == pytest.approx(0.15)  # l·ω_max
    assert speed_cap(100.0, 0.05, 0.1) == pytest.approx(0.05 / 0.1)  # never above l/dt


# -- the guarantee along the true arcs, tick after tick ------------------------------------------

R_OBSTACLE, BODY, L, DT, V = 1.0, 0.05, 0.075, 0.01, 4.0


def _robotarium_step(points: np.ndarray, headings: np.ndarray, u: np.ndarray, ell: float,
                     dt: float) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """The mutant: the Robotarium's map, ṗ = u at the tick's start only."""
    cos, sin = np.cos(headings), np.sin(headings)
    v = cos * u[:, 0] + sin * u[:, 1]
    w = (-sin * u[:, 0] + cos * u[:, 1]) / ell
    return drive(points, headings, v, w, ell, dt)


def _least_clearances(stepper, margin: float, theta: float, ticks: int = 300) -> tuple:  # type: ignore[no-untyped-def]
    """A point on its guard circle (margin m from the obstacle's edge) heading for a goal behind
    the obstacle, so the filter slides it round the guard: the least distance of its body (a
    disc of BODY about the axle) from the obstacle's edge along the true arcs of every tick, and
    the least of its point's from the guard circle at the ticks."""
    p, h = np.array([[0.0, R_OBSTACLE + margin]]), np.array([theta])
    previous = None
    least = guard = math.inf
    for k in range(ticks):
        towards = np.array([0.0, -3.0]) - p[0]
        nominal = tuple(V * towards / np.linalg.norm(towards))
        sensing = Sensing(k, (float(p[0, 0]), float(p[0, 1])), (0,), ((0.0, 0.0),), (R_OBSTACLE,))
        u = safe_velocity(
            nominal, sensing, 1, dt=DT, margin=margin, half_separation=margin,
            speed_limit=V, previous=previous,
        ).velocity  # fmt: skip
        previous = u
        for tau in np.linspace(0.0, 1.0, 5, endpoint=False)[1:]:
            q, g = stepper(p, h, np.array([u]), L, tau * DT) if stepper is _robotarium_step else (
                drive(p, h, *wheel_command(np.array([u]), h, L, DT), L, tau * DT))  # fmt: skip
            c = body_centres(q, g, L)[0]
            least = min(least, float(np.linalg.norm(c)) - R_OBSTACLE - BODY)
        p, h = stepper(p, h, np.array([u]), L, DT)
        c = body_centres(p, h, L)[0]
        least = min(least, float(np.linalg.norm(c)) - R_OBSTACLE - BODY)
        guard = min(guard, float(np.linalg.norm(p[0])) - R_OBSTACLE - margin)
    return least, guard


def test_the_body_stays_off_the_obstacle_tick_after_tick_and_a_start_of_tick_map_does_not() -> None:
    """ρ = agent_radius + l + the departure (Scenario.body_reach): sliding round a guard for 3 s
    from any heading, the body never touches the obstacle. The Robotarium's map, given its own
    one-tick margin agent_radius + l + δ, δ = v²dt²/(2l), lets the body in: its point's departure
    ratchets past δ, tick after tick (measured: 3.1 δ into the guard, the body 1.5 mm in)."""
    reach = BODY + L + arc_departure(V, L, DT)
    headings = np.linspace(-math.pi, math.pi, 9)
    body, guard = np.array([_least_clearances(step, reach, theta) for theta in headings]).T
    assert body.min() > 0 and guard.min() >= -1e-12  # the point never inside its guard at a tick
    delta = V * V * DT * DT / (2 * L)
    body, guard = np.array(
        [_least_clearances(_robotarium_step, BODY + L + delta, theta) for theta in headings]
    ).T
    assert body.min() < 0 and guard.min() < -2 * delta


# -- any safe state, any nominal: one tick of two unicycles among obstacles --------------------

S = arc_departure(V, L, DT)
REACH = BODY + L + S  # Scenario.body_reach for these figures


def _tick_gaps(
    points: list[tuple[float, float]],
    headings: list[float],
    nominals: list[tuple[float, float]],
    obstacles: list[tuple[tuple[float, float], float]],
    margin: float,
) -> tuple[float, float]:
    """Both agents filtered as the agent process does (each sees the obstacles and the other's
    point), then held to their wheel commands for a tick, along the true arcs (sampled 41
    times): the least gap between a body and an obstacle or between the two bodies, and the
    least of a point's distance from its guard circles less the margin (m)."""
    centres = tuple(c for c, _ in obstacles)
    radii = tuple(r for _, r in obstacles)
    velocities = []
    for i in (0, 1):
        other = points[1 - i]
        sensing = Sensing(0, points[i], tuple(range(len(obstacles))), centres, radii, (2 - i,),
                          (other,))  # fmt: skip
        velocities.append(safe_velocity(
            nominals[i], sensing, i + 1, dt=DT, margin=margin, half_separation=margin,
            speed_limit=V, previous=None,
        ).velocity)  # fmt: skip
    p0, h0 = np.array(points), np.array(headings)
    v, w = wheel_command(np.array(velocities), h0, L, DT)
    body = guard = math.inf
    for tau in np.linspace(0.0, 1.0, 41):
        p, h = drive(p0, h0, v, w, L, tau * DT)
        c = body_centres(p, h, L)
        for centre, r in obstacles:
            body = min(body, float((np.linalg.norm(c - np.array(centre), axis=-1) - r).min()))
            guard = min(guard, float((np.linalg.norm(p - np.array(centre), axis=-1) - r).min()))
        body = min(body, float(np.linalg.norm(c[0] - c[1])) - BODY)
    return body - BODY, guard - margin


@settings(max_examples=300, deadline=None)
@given(
    st.lists(ANGLES, min_size=8, max_size=8),
    st.lists(st.floats(0.0, 0.1), min_size=3, max_size=3),
    st.floats(0.0, 2.5),
)
def test_from_any_safe_state_any_nominal_keeps_every_body_clear_over_the_tick(
    angles: list[float], gaps: list[float], push: float
) -> None:
    """Agent 1 at the origin with an obstacle on its guard (within 0.1 m), agent 2 at the
    separation (within 0.1 m) with its own obstacle, any headings and any nominal up to 2.5 v_max:
    the bodies never touch an obstacle or each other along the tick's true arcs."""
    a_obstacle, a_neighbour, a_second, h1, h2, n1, n2, spread = angles
    unit = lambda a: (math.cos(a), math.sin(a))  # noqa: E731
    r1, r2 = 0.3, 0.6
    o1 = tuple((r1 + REACH + gaps[0]) * x for x in unit(a_obstacle))
    q = tuple((2 * REACH + gaps[1]) * x for x in unit(a_neighbour))
    o2 = tuple(qx + (r2 + REACH + gaps[2]) * x for qx, x in zip(q, unit(a_second), strict=True))
    obstacles = [(o1, r1), (o2, r2)]
    for point in ((0.0, 0.0), q):  # a safe state: every point outside every guard
        for centre, r in obstacles:
            if math.dist(point, centre) < r + REACH:
                return
    speed = push * V
    nominals = [tuple(speed * x for x in unit(n1)), tuple(speed * x for x in unit(n2 + spread))]
    body, _ = _tick_gaps([(0.0, 0.0), q], [h1, h2], nominals, obstacles, REACH)
    assert body >= -1e-12


@settings(max_examples=300, deadline=None)
@given(ANGLES, ANGLES, ANGLES, ANGLES, st.floats(0.0, 0.2), st.floats(0.0, 2.5))
def test_a_person_walking_anywhere_at_its_cap_never_meets_a_body_the_filter_kept_clear(
    where: float, heading: float, walk: float, aim: float, gap: float, push: float
) -> None:
    """A person (a moving obstacle capped at u_max) near a unicycle that starts outside the
    guard, walking any way at up to u_max through the tick, any nominal: unless the filter
    reports the agent cornered (then only passive safety is claimed), the body stays clear of
    the person along the true arc, matched in time with the person's walk."""
    u_max, r = 1.5, 0.3
    centre = np.array([math.cos(where), math.sin(where)]) * (r + REACH + gap)
    person = Mover(7, tuple(centre), r, (0.0, 0.0), u_max)
    sensing = Sensing(0, (0.0, 0.0), (), (), (), movers=(person,))
    nominal = (push * V * math.cos(aim), push * V * math.sin(aim))
    out = safe_velocity(nominal, sensing, 1, dt=DT, margin=REACH, half_separation=REACH,
                        speed_limit=V, previous=None)  # fmt: skip
    if out.cornered:
        return
    v, w = wheel_command(np.array([out.velocity]), np.array([heading]), L, DT)
    stride = u_max * np.array([math.cos(walk), math.sin(walk)])
    for tau in np.linspace(0.0, 1.0, 41):
        p, h = drive(np.zeros((1, 2)), np.array([heading]), v, w, L, tau * DT)
        body = body_centres(p, h, L)[0]
        assert float(np.linalg.norm(body - centre - tau * DT * stride)) >= r + BODY - 1e-12


def _worst_on_a_guard(margin: float) -> tuple[float, float]:
    """The least gaps (:func:`_tick_gaps`) over headings and nominal directions (a grid) of an
    agent on its guard circle, its neighbour far away."""
    points = [(0.0, R_OBSTACLE + margin), (100.0, 100.0)]  # the neighbour far away
    obstacle = [((0.0, 0.0), R_OBSTACLE)]
    grid = np.linspace(-math.pi, math.pi, 37)
    gaps = [
        _tick_gaps(
            points, [theta, 0.0], [(V * math.cos(a), V * math.sin(a)), (0.0, 0.0)], obstacle, margin
        )
        for theta in grid
        for a in grid
    ]
    return min(g[0] for g in gaps), min(g[1] for g in gaps)


def test_each_term_of_the_margin_is_there_for_a_reason() -> None:
    """ρ = r_b + l + s keeps the body out from every heading and nominal. Without l, the body
    behind its point starts inside. The departure s is the point's own: sliding along its guard
    the point dips inside it by nearly s in mid-tick (never more). Measured on this grid, its
    worst dip and the body's worst offset never coincide (turning in place, the point's arc
    bulges away from the body), so the body keeps s to spare: the bound is safe, not tight."""
    body, guard = _worst_on_a_guard(REACH)
    assert body >= -1e-12 and -S - 1e-12 <= guard < -0.9 * S
    assert _worst_on_a_guard(BODY + S)[0] < -0.5 * L  # the body offset dropped


@pytest.mark.parametrize(
    ("cap", "what"),
    [
        (GRITSBOT.limit(), "the arc's x/sin x"),
        (min(GRITSBOT.max_speed, GRITSBOT.lookahead * GRITSBOT.max_turn_rate), "the wheels"),
    ],
)
def test_a_cap_that_forgets_a_term_breaks_a_wheel_limit(cap: float, what: str) -> None:
    """The point's cap at a 0.3 s tick, with one term forgotten (the mutant): some heading and
    direction drives a wheel past its speed. With the whole cap none does (the property test
    above); the wheels' term is tight, so the first mutant breaks it by the arc's share."""
    dt, rim = 0.3, 0.016 * 12.5
    worst = 0.0
    for theta in np.linspace(-math.pi, math.pi, 181):
        for a in np.linspace(-math.pi, math.pi, 181):
            u = cap * np.array([math.cos(a), math.sin(a)])
            v, w = _command(u, theta, GRITSBOT.lookahead, dt)
            worst = max(worst, abs(v) + abs(w) * 0.11 / 2)
    assert worst > rim * (1 + 1e-3), what
    u_max = GRITSBOT.point_speed_cap(dt)
    assert u_max < cap


# -- the scenario ------------------------------------------------------------------------------


def _robotarium(**changes: object) -> str:
    data = yaml.safe_load(
        resources.files("shoal.world.scenarios").joinpath("robotarium.yaml").read_text()
    )
    for key, value in changes.items():
        where, _, leaf = key.partition("__")
        if leaf:
            data[where][leaf] = value
        else:
            data[where] = value
    return yaml.safe_dump(data)


@pytest.mark.parametrize(
    ("changes", "field", "says"),
    [
        ({"dim": 3}, "kinematics.model", "dim must be 2"),
        ({"kinematics__model": "tank"}, "kinematics.model", "single or unicycle"),
        ({"kinematics": {"model": "unicycle", "max_speed": 0.2, "max_turn_rate": 3.0}},
         "kinematics.lookahead", "missing"),
        ({"kinematics": {"model": "unicycle", "lookahead": 0.05, "max_speed": 0.2,
                         "max_turn_rate": 3.0, "axle": 0.1}}, "kinematics.wheel_radius", "missing"),
        ({"kinematics__lookahead": -0.05}, "kinematics.lookahead", "> 0"),
        ({"kinematics": {"lookahead": 0.05}}, "kinematics.lookahead", "model: unicycle"),
        ({"control": {"safety_margin": 0.12, "sensing_radius": 0.8, "trigger_radius": 0.6}},
         "control.safety_margin", "a unicycle's reach"),
        ({"control": {"safety_margin": 0.15, "separation": 0.25, "sensing_radius": 0.8,
                      "trigger_radius": 0.6}}, "control.separation", "a unicycle's reach"),
        ({"control": {"safety_margin": 0.15, "speed_limit": 0.21, "sensing_radius": 0.8,
                      "trigger_radius": 0.6}}, "control.speed_limit", "in any direction"),
        # faster than l/dt: named as the speed limit, not as the reach reckoned at it
        ({"control__speed_limit": 3.0}, "control.speed_limit", "no more than lookahead/dt"),
        ({"agents": [{"offset": [0, 0], "heading": 7.0}, {"offset": [-0.4, 0.4]}]},
         "agents[0].heading", "outside"),
    ],
)  # fmt: skip
def test_a_wrong_unicycle_scenario_names_its_field(
    changes: dict[str, object], field: str, says: str
) -> None:
    with pytest.raises(ScenarioError) as caught:
        parse_scenario(_robotarium(**changes))
    assert caught.value.field == field and says in str(caught.value)


def test_single_integrators_are_the_default_and_a_unicycle_has_its_reach() -> None:
    s = load_scenario("robotarium")
    assert load_scenario("default").unicycle is None and load_scenario("default").lookahead is None
    assert s.unicycle is not None
    assert s.speed_limit == s.unicycle.fastest_point(s.dt)  # straight ahead, 0.2 m/s less 0.06 %
    assert s.speed_limit == pytest.approx(0.2, rel=1e-3)
    assert s.body_reach == pytest.approx(0.0925 + 0.05 + arc_departure(s.speed_limit, 0.05, 0.033))
    assert s.control.safety_margin >= s.body_reach


def test_the_robotarium_run_keeps_its_bodies_apart_and_off_the_obstacles() -> None:
    """The built-in's bodies, each a disc of agent_radius about its axle, measured along the
    exact arcs (sampled 20 times a tick): never closer than the bodies' radii."""
    s = load_scenario("robotarium")
    traj = simulate(s)
    assert traj.headings is not None and summarize(s, traj).arrived
    least_obstacle, least_pair = _swept_clearances(s, traj)
    assert least_obstacle > 0 and least_pair > 0


@pytest.mark.parametrize(
    ("headings", "backwards"),
    [([math.pi] * 5, 5), ([math.pi / 2, -math.pi / 2] * 2 + [math.pi], 1),
     ([0.0, math.pi, math.pi, -2.5, 2.5], 4)],
    ids=["all reversed", "sideways", "mixed"],
)  # fmt: skip
def test_unicycles_that_start_facing_away_turn_round_beside_obstacles_and_arrive(
    headings: list[float], backwards: int
) -> None:
    """Robots that start facing away from where they must go (every one
    reversed; side-on; a mix), agents 2 and 3 beside an obstacle, neighbours 0.4 m apart. The
    point moves as the law asks from the first tick, whatever the heading: a follower facing
    back turns round (more than a quarter turn) on the spot or in a multi-point turn; a leader
    facing back, whose path lies straight behind it, reverses the whole way without turning. The
    formation arrives, and the bodies, swept along the exact arcs, never touch an obstacle or
    each other."""
    data = yaml.safe_load(_robotarium())
    for agent, theta in zip(data["agents"], headings, strict=True):
        agent["heading"] = theta
    s = parse_scenario(yaml.safe_dump(data))
    traj = simulate(s)
    assert traj.headings is not None
    facing_back = np.cos(traj.headings[0]) < -0.5
    assert int(facing_back.sum()) == backwards
    turned = np.abs(np.unwrap(traj.headings, axis=0) - traj.headings[0]).max(axis=0)
    followers = facing_back & (np.arange(s.n) > 0)
    assert (turned[followers] > math.pi / 2).all(), turned
    if facing_back[0]:
        assert turned[0] < 1e-9  # the leader drove its route backwards
    summary = summarize(s, traj)
    assert summary.arrived and summary.collisions == 0, summary.as_dict()
    least_obstacle, least_pair = _swept_clearances(s, traj)
    assert least_obstacle > 0 and least_pair > 0


def _swept_clearances(s: Scenario, traj: Trajectory) -> tuple[float, float]:
    """The least gap (m) between a body and an obstacle, and between two bodies, along the
    exact arcs of every tick, sampled 20 times a tick."""
    assert traj.headings is not None
    ell, dt = s.unicycle.lookahead if s.unicycle else 0.0, s.dt
    centres, radii = s.obstacle_centres, s.obstacle_radii
    least_obstacle = least_pair = math.inf
    for k in range(traj.ticks):
        v, w = wheel_command(traj.velocities[k], traj.headings[k], ell, dt)
        for tau in np.linspace(0.0, 1.0, 20, endpoint=False):
            p, h = drive(traj.positions[k], traj.headings[k], v, w, ell, tau * dt)
            c = body_centres(p, h, ell)
            gaps = np.linalg.norm(c[:, None] - centres[None], axis=-1) - radii - s.agent_radius
            least_obstacle = min(least_obstacle, float(gaps.min()))
            d = np.linalg.norm(c[:, None] - c[None], axis=-1) + np.eye(s.n) * 1e9
            least_pair = min(least_pair, float(d.min()) - 2 * s.agent_radius)
    return least_obstacle, least_pair


def test_the_summary_says_how_often_the_point_is_held_to_its_cap() -> None:
    """Where the point moves at its cap the limits cut in and it does not follow the law
    exactly: the summary counts those agent-ticks, and says what they mean."""
    s = load_scenario("robotarium")
    traj = simulate(s)
    summary = summarize(s, traj)
    assert traj.headings is not None
    sides = s.unicycle.sides(s.dt) if s.unicycle is not None else ()
    normals = np.asarray([side[:2] for side in sides])
    bounds = np.asarray([side[2] for side in sides])
    at = 0
    for k in range(len(traj.velocities)):  # each agent-tick on its polygon, one by one
        for i in range(s.n):
            theta = traj.headings[k, i]
            w = np.array([[np.cos(theta), np.sin(theta)], [-np.sin(theta), np.cos(theta)]])
            at += bool(np.any(normals @ (w @ traj.velocities[k, i]) >= bounds * (1 - 1e-9)))
    expected = at / traj.velocities.shape[0] / s.n
    assert summary.at_speed_limit == pytest.approx(expected, abs=1e-12) and 0.0 < expected < 0.5
    assert "speed limit" in render_summary(summary.as_dict())
    plain = load_scenario("default")  # without its 4 m/s, the law never meets a limit
    plain = dataclasses.replace(plain, control=dataclasses.replace(plain.control, speed_limit=None))
    assert summarize(plain, simulate(plain)).at_speed_limit == 0.0


def test_unicycles_give_way_to_a_person_and_never_walk_into_one() -> None:
    """The robotarium's formation with a person walking across its path and back (a moving
    obstacle at 0.1 m/s, as fast as the robots): every contact is the person's doing, and the
    bodies keep clear of the standing obstacles and of each other."""
    person = {
        "centre": [0.3, -0.6],
        "radius": 0.06,
        "moves": {"kind": "route", "waypoints": [[0.3, 0.6], [0.3, -0.6]], "speed": 0.1},
    }
    data = yaml.safe_load(_robotarium())
    data["obstacles"].append(person)
    data["duration"] = 40.0
    s = parse_scenario(yaml.safe_dump(data))
    assert s.mover_ids == (2,)
    traj = simulate(s)
    summary = summarize(s, traj)
    assert summary.agent_at_fault == 0 and summary.collisions == 0
    assert summary.min_mover_clearance is not None and summary.guard_margin is not None
    assert summary.min_mover_clearance < 2 * s.control.safety_margin  # the person came close
    assert summary.guard_margin >= -1e-9


# -- mixed formations ---------------------------------------------------------------------------


def _mixed() -> str:
    """The robotarium formation with followers 2 and 5 holonomic (single integrators)."""
    data = yaml.safe_load(_robotarium())
    data["agents"][1]["kinematics"] = "single"
    data["agents"][4]["kinematics"] = "single"
    return yaml.safe_dump(data)


@pytest.mark.parametrize(
    ("agents", "kinematics", "field", "says"),
    [
        ([{"offset": [0, 0]}, {"offset": [-0.4, 0.4], "kinematics": "tank"}], True,
         "agents[1].kinematics", "single or unicycle"),
        ([{"offset": [0, 0]}, {"offset": [-0.4, 0.4], "kinematics": "unicycle"}], False,
         "agents[1].kinematics", "gives no unicycle"),
    ],
)  # fmt: skip
def test_a_wrong_agent_model_names_its_field(
    agents: list[dict[str, object]], kinematics: bool, field: str, says: str
) -> None:
    data = yaml.safe_load(_robotarium(agents=agents, obstacles=[]))
    data["graph"]["edges"] = [[1, 2]]
    if not kinematics:
        del data["kinematics"]
        data["control"] = {"sensing_radius": 1.5, "trigger_radius": 1.2}
        data["agent_radius"] = 0.05
    with pytest.raises(ScenarioError) as caught:
        parse_scenario(yaml.safe_dump(data))
    assert caught.value.field == field and says in str(caught.value)


def test_a_mixed_formation_moves_its_singles_straight_and_its_unicycles_along_arcs() -> None:
    """Followers 2 and 5 are single integrators among GRITSbots: every tick they move by
    exactly their velocity·dt (the bits of positions + dt·velocities) and keep their heading;
    the unicycles turn, their points land on their steps up to rounding; the run arrives and
    every body (a unicycle's about its axle, a single's about its point) stays clear along the
    true arcs; all-unicycle and every other scenario unchanged."""
    s = parse_scenario(_mixed())
    assert s.lookaheads is not None and s.lookaheads.tolist() == [0.05, 0.0, 0.05, 0.05, 0.0]
    traj = simulate(s)
    assert traj.headings is not None and summarize(s, traj).arrived
    singles, wheeled = [1, 4], [0, 2, 3]
    dt = s.dt
    steps = traj.positions[:-1] + dt * traj.velocities
    assert np.array_equal(traj.positions[1:, singles], steps[:, singles])
    assert (traj.headings[:, singles] == traj.headings[0, singles]).all()
    assert np.abs(traj.positions[1:, wheeled] - steps[:, wheeled]).max() < 1e-12
    assert np.ptp(traj.headings[:, [2, 3]], axis=0).min() > 0.1  # the wheeled followers turned
    ells = s.lookaheads
    least_obstacle = least_pair = math.inf
    for k in range(0, traj.ticks, 3):
        v, w = wheel_command(traj.velocities[k], traj.headings[k], ells, dt)
        for tau in np.linspace(0.0, 1.0, 8, endpoint=False):
            p = traj.positions[k] + tau * dt * traj.velocities[k]  # the singles
            h = traj.headings[k].copy()
            start = traj.positions[k, wheeled], traj.headings[k, wheeled]
            p[wheeled], h[wheeled] = drive(*start, v[wheeled], w[wheeled], ells[wheeled], tau * dt)
            c = body_centres(p, h, ells)
            gaps = np.linalg.norm(c[:, None] - s.obstacle_centres[None], axis=-1)
            least_obstacle = min(least_obstacle, float((gaps - s.obstacle_radii).min()))
            d = np.linalg.norm(c[:, None] - c[None], axis=-1) + np.eye(s.n) * 1e9
            least_pair = min(least_pair, float(d.min()))
        assert np.isnan(v[singles]).all() and np.isfinite(v[wheeled]).all()
    assert least_obstacle > s.agent_radius and least_pair > 2 * s.agent_radius
    whole = load_scenario("robotarium")
    assert whole.lookaheads is not None and set(whole.lookaheads.tolist()) == {0.05}
    assert load_scenario("default").lookaheads is None
