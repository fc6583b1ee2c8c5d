"""Unicycles (world/unicycle.py): the exact arc the world integrates, the bounds the safety
theorem for unicycles rests on (the point's departure from its straight step, the limits), and
the guarantee itself along the true arc — with the mutant that forgets the departure caught."""

from __future__ import annotations

import math
from importlib import resources

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from shoal.bus.messages import Sensing
from shoal.bus.safety import safe_velocity
from shoal.tools.simulator import simulate
from shoal.world.errors import ScenarioError
from shoal.world.loader import load_scenario, parse_scenario
from shoal.world.metrics import summarize
from shoal.world.scenario import Unicycle
from shoal.world.unicycle import arc_departure, body_centres, step, wheel_command

ANGLES = st.floats(-math.pi, math.pi)


def _euler(point: np.ndarray, theta: float, u: np.ndarray, ell: float, dt: float, n: int) -> tuple:
    """The same (v, ω) held, integrated in n tiny Euler steps of the body: the reference."""
    v, w = (float(x[0]) for x in wheel_command(u[None], np.array([theta]), ell))
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
    theta: float, direction: float, speed: float, ell: float, dt: float
) -> None:
    u = speed * np.array([math.cos(direction), math.sin(direction)])
    p0 = np.array([0.3, -0.7])
    moved, turned = step(p0[None], np.array([theta]), u[None], ell, dt)
    ref, ref_theta = _euler(p0, theta, u, ell, dt, 4000)
    euler = speed * dt * (speed / ell * dt) / 4000  # the reference's own error, first order
    assert float(np.linalg.norm(moved[0] - ref)) <= 2 * euler + 1e-12
    assert turned[0] == pytest.approx(ref_theta, abs=1e-9)


@settings(max_examples=200, deadline=None)
@given(ANGLES, ANGLES, st.floats(0.0, 2.0), st.floats(0.01, 0.5), st.floats(0.001, 0.2))
def test_the_point_never_leaves_its_straight_step_by_more_than_the_departure(
    theta: float, direction: float, speed: float, ell: float, dt: float
) -> None:
    """Along the whole tick (sampled), not only at its end: |p(t) − (p0 + u·t)| ≤ |u|²dt²/(2l)
    and |p(t) − p0| ≤ |u|·t."""
    u = speed * np.array([math.cos(direction), math.sin(direction)])
    p0 = np.array([[2.0, 1.0]])
    bound = arc_departure(speed, ell, dt)
    for tau in np.linspace(0.0, 1.0, 21):
        p, _ = step(p0, np.array([theta]), u[None], ell, tau * dt)
        assert float(np.linalg.norm(p[0] - p0[0] - u * tau * dt)) <= bound + 1e-12
        assert float(np.linalg.norm(p[0] - p0[0])) <= speed * tau * dt + 1e-12


@settings(max_examples=200, deadline=None)
@given(ANGLES, ANGLES, st.floats(0.0, 1.0))
def test_a_point_under_its_cap_keeps_every_limit_whatever_the_heading(
    theta: float, direction: float, fraction: float
) -> None:
    robot = Unicycle(0.05, 0.2, 3.6363636363636362, 0.016, 0.11, 12.5)  # a GRITSbot
    speed = fraction * robot.point_speed_cap
    u = speed * np.array([[math.cos(direction), math.sin(direction)]])
    v, w = (float(x[0]) for x in wheel_command(u, np.array([theta]), robot.lookahead))
    assert abs(v) <= robot.max_speed + 1e-12 and abs(w) <= robot.max_turn_rate + 1e-12
    for rim in (v + w * 0.11 / 2, v - w * 0.11 / 2):  # each wheel's rim speed
        assert abs(rim) <= 0.016 * 12.5 + 1e-12


def test_the_gritsbots_point_cap_is_set_by_its_wheels() -> None:
    robot = Unicycle(0.05, 0.2, 3.6363636363636362, 0.016, 0.11, 12.5)
    assert robot.point_speed_cap == pytest.approx(0.2 / (1 + 0.11 / 0.1))
    assert Unicycle(0.05, 0.2, 3.0).point_speed_cap == pytest.approx(0.15)  # l·ω_max


# -- the guarantee along the true arc ------------------------------------------------------------

R_OBSTACLE, BODY, L, DT, V = 0.5, 0.05, 0.05, 0.1, 0.5


def _least_body_clearance(margin: float, theta: float, nominal: tuple[float, float]) -> float:
    """A point on its guard circle (margin m from the obstacle's edge), the filter run with that
    margin, then the least distance of the body (a disc of BODY about the axle) from the
    obstacle's edge along the true arc of the tick."""
    point = (0.0, R_OBSTACLE + margin)
    sensing = Sensing(0, point, (0,), ((0.0, 0.0),), (R_OBSTACLE,))
    u = safe_velocity(
        nominal, sensing, 1, dt=DT, margin=margin, half_separation=margin,
        speed_limit=V, previous=None,
    ).velocity  # fmt: skip
    least = math.inf
    for tau in np.linspace(0.0, 1.0, 201):
        p, h = step(np.array([point]), np.array([theta]), np.array([u]), L, tau * DT)
        c = body_centres(p, h, L)[0]
        least = min(least, float(np.linalg.norm(c)) - R_OBSTACLE - BODY)
    return least


def test_the_body_stays_off_the_obstacle_along_its_arc_with_the_unicycle_margin() -> None:
    """ρ = agent_radius + l + v²dt²/(2l) (Scenario.body_reach): a tangential command the
    filter passes, with the point turning towards the obstacle, keeps the body clear; the
    margin without the departure term (the mutant) lets the body into the obstacle."""
    reach = BODY + L + arc_departure(V, L, DT)
    worst = min(
        _least_body_clearance(reach, theta, (V * math.cos(a), V * math.sin(a)))
        for theta in np.linspace(-math.pi, math.pi, 25)
        for a in np.linspace(-math.pi, math.pi, 25)
    )
    assert worst >= -1e-12
    mutant = min(
        _least_body_clearance(BODY + L, theta, (V, 0.0))
        for theta in np.linspace(-math.pi, math.pi, 73)
    )
    assert mutant < -0.01  # the departure is 0.125 m here: the body goes in


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
        ({"control": {"safety_margin": 0.15, "speed_limit": 0.15, "sensing_radius": 0.8,
                      "trigger_radius": 0.6}}, "control.speed_limit", "whatever its heading"),
        ({"agents": [{"offset": [0, 0], "heading": 7.0}, {"offset": [-0.4, 0.4]}]},
         "agents[0].heading", "outside"),
        ({"obstacles": [{"centre": [0.0, 1.0], "radius": 0.05,
                         "moves": {"kind": "drift", "velocity": [0.01, 0.0]}}]},
         "obstacles[0].moves", "not yet"),
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
    assert s.unicycle is not None and s.speed_limit == pytest.approx(s.unicycle.point_speed_cap)
    assert s.body_reach == pytest.approx(0.0925 + 0.05 + s.speed_limit**2 * 0.033**2 / 0.1)
    assert s.control.safety_margin >= s.body_reach


def test_the_robotarium_run_keeps_its_bodies_apart_and_off_the_obstacles() -> None:
    """The built-in's bodies, each a disc of agent_radius about its axle, measured along the
    exact arcs (sampled 20 times a tick): never closer than the bodies' radii."""
    s = load_scenario("robotarium")
    traj = simulate(s)
    assert traj.headings is not None and summarize(s, traj).arrived
    ell, dt = s.unicycle.lookahead if s.unicycle else 0.0, s.dt
    centres, radii = s.obstacle_centres, s.obstacle_radii
    least_obstacle = least_pair = math.inf
    for k in range(traj.ticks):
        for tau in np.linspace(0.0, 1.0, 20, endpoint=False):
            p, h = step(traj.positions[k], traj.headings[k], traj.velocities[k], ell, tau * dt)
            c = body_centres(p, h, ell)
            gaps = np.linalg.norm(c[:, None] - centres[None], axis=-1) - radii - s.agent_radius
            least_obstacle = min(least_obstacle, float(gaps.min()))
            d = np.linalg.norm(c[:, None] - c[None], axis=-1) + np.eye(s.n) * 1e9
            least_pair = min(least_pair, float(d.min()) - 2 * s.agent_radius)
    assert least_obstacle > 0 and least_pair > 0
