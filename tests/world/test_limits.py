"""A unicycle's limits as rows of its safety filter (world/limits.py, geometry/safety.py): every
point velocity inside the polygon is a (v, ω) within every limit, whatever the robot; the filter
keeps them from any safe state, the bodies clear along the true arcs as before; and the polygon
gives back what the old disc withheld. Mutants (the chords' bow dropped, a limit forgotten, the
filter told no limits) fail."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from shoal.bus.messages import Mover, Sensing
from shoal.bus.types import LimitSide
from shoal.geometry.safety import cap_to_limits, limit_rows, safe_velocity
from shoal.world import limits as limits_module
from shoal.world.limits import LimitError, limit_sides, outer
from shoal.world.loader import load_scenario
from shoal.world.scenario import Unicycle
from shoal.world.unicycle import arc_departure, body_centres, drive, wheel_command

GRITSBOT = Unicycle(0.05, 0.2, 3.6363636363636362, 0.016, 0.11, 12.5)
DT = 0.033
ANGLES = st.floats(-math.pi, math.pi)


def _worst(
    w: np.ndarray, ell: float, dt: float, speed: float, turn: float, rim: float | None, half: float
) -> float:
    """The largest of |v|/v_max, |ω|/ω_max and the wheels' rim speed over theirs, for the
    (v, ω) that moves the point by w·dt in a robot facing along x."""
    v, omega = wheel_command(w[None], np.array([0.0]), ell, dt)
    ratio = max(abs(v[0]) / speed, abs(omega[0]) / turn)
    if rim is not None:
        ratio = max(ratio, (abs(v[0]) + half * abs(omega[0])) / rim)
    return float(ratio)


def _extent(sides: tuple[LimitSide, ...], angle: float) -> float:
    """How far the polygon reaches from 0 along ``angle`` (m/s)."""
    e = (math.cos(angle), math.sin(angle))
    return min(c / (nx * e[0] + ny * e[1]) for nx, ny, c, _ in sides if nx * e[0] + ny * e[1] > 0)


ROBOTS = st.tuples(
    st.floats(0.02, 0.3),  # l, m
    st.floats(0.05, 5.0),  # v_max, m/s
    st.floats(0.2, 60.0),  # ω_max, rad/s
    st.floats(0.005, 0.1),  # dt, s
    st.one_of(st.none(), st.tuples(st.floats(0.05, 5.0), st.floats(0.02, 0.3))),  # rim, half axle
)


@settings(max_examples=300, deadline=None)
@given(ROBOTS, ANGLES, st.floats(0.0, 1.0))
def test_every_velocity_in_the_polygon_keeps_every_limit(
    robot: tuple[float, float, float, float, tuple[float, float] | None],
    angle: float,
    fraction: float,
) -> None:
    """Any robot, any direction, anywhere from standing to the polygon's edge (no faster than
    l/dt, the filter's most): the (v, ω) held keeps |v|, |ω| and both wheels within their
    limits (to rounding)."""
    ell, speed, turn, dt, wheels = robot
    rim, half = wheels if wheels is not None else (None, 0.0)
    sides = limit_sides(ell, speed, turn, dt, rim=rim, half_axle=half if wheels else None)
    reach = min(_extent(sides, angle), ell / dt)
    w = fraction * reach * np.array([math.cos(angle), math.sin(angle)])
    assert _worst(w, ell, dt, speed, turn, rim, half) <= 1.0 + 1e-9


def test_the_polygon_gives_the_gritsbot_what_the_disc_withheld() -> None:
    """Straight ahead and back the point may move at nearly |v|'s 0.2 m/s (the disc allowed
    0.1345 whatever the heading); in every direction the polygon still holds the disc's speed
    to 0.2 % (it cannot hold the disc and the corners at once: the exact set is not convex at
    the back)."""
    sides = GRITSBOT.sides(DT)
    disc = GRITSBOT.point_speed_cap(DT)
    assert outer(sides) == pytest.approx(0.2, rel=1e-3)
    assert _extent(sides, 0.0) == pytest.approx(0.2, rel=1e-3)
    assert _extent(sides, math.pi) > 1.1 * disc
    assert GRITSBOT.any_direction(DT) >= 0.998 * disc
    assert len(sides) <= 40


def _violation(sides: tuple[LimitSide, ...], robot: Unicycle, dt: float) -> float:
    """The worst limit ratio over the polygon's edge, on a fine fan of directions."""
    rim = robot.wheel_radius * robot.max_wheel_speed if robot.wheel_radius else None
    half = robot.axle / 2.0 if robot.axle else 0.0
    worst = 0.0
    for a in np.linspace(-math.pi, math.pi, 2001):
        edge = _extent(sides, a) * np.array([math.cos(a), math.sin(a)])
        worst = max(worst, _worst(edge, robot.lookahead, dt, robot.max_speed,
                                  robot.max_turn_rate, rim, half))  # fmt: skip
    return worst


def test_the_polygon_reaches_its_limits_and_a_mutant_without_the_bow_breaks_them(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The edge of the polygon comes within 0.5 % of the limits; the same polygon with its
    chords not moved for their bow lets a limit break."""
    sides = GRITSBOT.sides(DT)
    assert 0.995 <= _violation(sides, GRITSBOT, DT) <= 1.0 + 1e-9
    monkeypatch.setattr(limits_module, "bow", lambda bound, span: 0.0)
    broken = limit_sides(0.05, 0.2, 3.6363636363636362, DT, rim=0.2, half_axle=0.055)
    assert _violation(broken, GRITSBOT, DT) > 1.0 + 1e-6


@pytest.mark.parametrize(
    ("robot", "forgotten"),
    [
        (GRITSBOT, {"rim": None, "half_axle": None}),  # the wheels
        (Unicycle(0.05, 0.2, 1.0), {"max_turn_rate": 10.0}),  # the turn rate
        (Unicycle(0.05, 0.2, 10.0), {"max_speed": 0.4}),  # |v|
    ],
)
def test_a_polygon_that_forgets_a_limit_breaks_it(
    robot: Unicycle, forgotten: dict[str, float | None]
) -> None:
    wheels = robot.wheel_radius is not None and robot.axle is not None
    given_ = {
        "rim": robot.wheel_radius * robot.max_wheel_speed if wheels else None,  # type: ignore[operator]
        "half_axle": robot.axle / 2.0 if wheels else None,  # type: ignore[operator]
        "max_speed": robot.max_speed,
        "max_turn_rate": robot.max_turn_rate,
    }
    assert _violation(robot.sides(DT), robot, DT) <= 1.0 + 1e-9
    given_.update(forgotten)
    sides = limit_sides(robot.lookahead, given_.pop("max_speed"), given_.pop("max_turn_rate"), DT,
                        **given_)  # type: ignore[arg-type]  # fmt: skip
    assert _violation(sides, robot, DT) > 1.0 + 1e-3


def test_limits_that_leave_no_motion_are_refused() -> None:
    with pytest.raises(LimitError):
        limit_sides(0.05, 0.0, 3.0, DT)
    with pytest.raises(LimitError):
        limit_sides(0.05, 0.2, 3.0, DT, rim=0.0, half_axle=0.05)


def test_the_rows_at_a_heading_are_the_polygon_turned_and_the_far_sides_left_out() -> None:
    sides = GRITSBOT.sides(DT)
    theta = 0.7
    rows = limit_rows(sides, theta, 10.0, DT)
    assert len(rows) == len(sides)
    for row, (nx, ny, c, _) in zip(rows, sides, strict=True):
        w = (c * nx, c * ny)  # on the side's line, in the body frame
        u = (math.cos(theta) * w[0] - math.sin(theta) * w[1],
             math.sin(theta) * w[0] + math.cos(theta) * w[1])  # fmt: skip
        assert (row.normal[0] * u[0] + row.normal[1] * u[1]) * DT == pytest.approx(row.bound)
    assert limit_rows(sides, theta, 0.5 * min(s[3] for s in sides), DT) == []
    fast = (0.5, 0.0)  # straight ahead at 0.5 m/s: scaled onto the polygon, direction kept
    capped = cap_to_limits(fast, sides, 0.0)
    assert capped[1] == 0.0 and capped[0] == pytest.approx(0.2, rel=1e-3)
    assert cap_to_limits((0.05, 0.05), sides, 1.0) == (0.05, 0.05)


# -- the filter with the limits: any safe state, any nominal -----------------------------------

ROBOTARIUM = load_scenario("robotarium")
BODY = ROBOTARIUM.agent_radius
L = GRITSBOT.lookahead
SPEED = ROBOTARIUM.speed_limit  # the polygon's farthest vertex, straight ahead
REACH = BODY + L + arc_departure(SPEED, L, DT)
SIDES = GRITSBOT.sides(DT)


def _filtered(
    nominal: tuple[float, float], sensing: Sensing, agent: int, heading: float, sides: tuple
) -> tuple[float, ...]:
    return safe_velocity(
        nominal, sensing, agent, dt=DT, margin=REACH, half_separation=REACH, speed_limit=SPEED,
        previous=None, limits=sides, heading=heading,
    ).velocity  # fmt: skip


@settings(max_examples=300, deadline=None)
@given(
    st.lists(ANGLES, min_size=7, max_size=7),
    st.lists(st.floats(0.0, 0.1), min_size=2, max_size=2),
    st.floats(0.0, 2.5),
)
def test_from_any_safe_state_the_filter_keeps_the_limits_and_the_bodies_clear(
    angles: list[float], gaps: list[float], push: float
) -> None:
    """Two GRITSbots, one with an obstacle on its guard, the other at the separation, any
    headings, any nominal up to 2.5 times the fastest the point may go: every (v, ω) keeps every
    limit, and the bodies keep off the obstacle and each other along the tick's true arcs."""
    a_obstacle, a_neighbour, h1, h2, n1, n2, _ = angles
    unit = lambda a: (math.cos(a), math.sin(a))  # noqa: E731
    radius = 0.05
    centre = tuple((radius + REACH + gaps[0]) * x for x in unit(a_obstacle))
    other = tuple((2 * REACH + gaps[1]) * x for x in unit(a_neighbour))
    assume(math.dist(other, centre) >= radius + REACH)
    points, headings = [(0.0, 0.0), other], [h1, h2]
    velocities = []
    for i in (0, 1):
        sensing = Sensing(0, points[i], (0,), (centre,), (radius,), (2 - i,), (points[1 - i],),
                          heading=headings[i])  # fmt: skip
        nominal = tuple(push * SPEED * x for x in unit((n1, n2)[i]))
        velocities.append(_filtered(nominal, sensing, i + 1, headings[i], SIDES))
    p0, h0 = np.array(points), np.array(headings)
    v, omega = wheel_command(np.array(velocities), h0, L, DT)
    assert np.abs(v).max() <= 0.2 * (1 + 1e-9)
    assert np.abs(omega).max() <= GRITSBOT.max_turn_rate * (1 + 1e-9)
    assert (np.abs(v) + 0.055 * np.abs(omega)).max() <= 0.2 * (1 + 1e-9)
    for tau in np.linspace(0.0, 1.0, 21):
        p, h = drive(p0, h0, v, omega, L, tau * DT)
        c = body_centres(p, h, L)
        assert float(np.linalg.norm(c - np.array(centre), axis=-1).min()) >= radius + BODY - 1e-12
        assert float(np.linalg.norm(c[0] - c[1])) >= 2 * BODY - 1e-12


@settings(max_examples=200, deadline=None)
@given(ANGLES, ANGLES, ANGLES, st.floats(0.0, 0.1), st.floats(0.0, 2.5))
def test_evading_a_person_keeps_the_limits_too(
    where: float, heading: float, aim: float, gap: float, push: float
) -> None:
    """A person near the guard (some row's bound > 0: the filter evades or flees) — the (v, ω)
    still keeps every limit."""
    centre = tuple((0.1 + REACH + gap) * x for x in (math.cos(where), math.sin(where)))
    person = Mover(3, centre, 0.1, (0.0, 0.0), 0.15)
    sensing = Sensing(0, (0.0, 0.0), (), (), (), movers=(person,), heading=heading)
    nominal = (push * SPEED * math.cos(aim), push * SPEED * math.sin(aim))
    u = _filtered(nominal, sensing, 1, heading, SIDES)
    v, omega = wheel_command(np.array([u]), np.array([heading]), L, DT)
    assert abs(v[0]) + 0.055 * abs(omega[0]) <= 0.2 * (1 + 1e-9)
    assert abs(omega[0]) <= GRITSBOT.max_turn_rate * (1 + 1e-9)


def test_a_filter_told_no_limits_breaks_them_and_a_feasible_command_comes_back_unchanged() -> None:
    """Sideways at the fastest straight-ahead speed: without the limits the wheels would need
    more than they have; with them the command is cut onto the polygon. A command inside
    everything comes back as the same tuple."""
    sensing = Sensing(0, (0.0, 0.0), (), (), ())
    sideways = (0.0, SPEED)
    free = _filtered(sideways, sensing, 1, 0.0, ())
    v, omega = wheel_command(np.array([free]), np.array([0.0]), L, DT)
    assert abs(v[0]) + 0.055 * abs(omega[0]) > 0.2 * 1.05
    kept = _filtered(sideways, sensing, 1, 0.0, SIDES)
    v, omega = wheel_command(np.array([kept]), np.array([0.0]), L, DT)
    assert abs(v[0]) + 0.055 * abs(omega[0]) <= 0.2 * (1 + 1e-9)
    inside = (0.05, -0.03)
    out = safe_velocity(inside, sensing, 1, dt=DT, margin=REACH, half_separation=REACH,
                        speed_limit=SPEED, limits=SIDES, heading=2.0)  # fmt: skip
    assert out.velocity is inside and not out.active
