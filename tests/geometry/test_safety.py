"""The safety filter (geometry/safety.py, docs/safety.md): feasible, optimal, never longer than the
nominal, the identity on a feasible nominal, and safe over the whole step — for one agent in
any crowd, and for a whole swarm under any nominal law, in 2-D and 3-D."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from safety_cases import (
    CHECKS,
    Case,
    cases,
    failures,
    pair_gap_along_step,
    random_case,
    segment_gap,
    unit,
)

from shoal.bus.messages import Sensing
from shoal.geometry.safety import (
    Row,
    agent_row,
    obstacle_row,
    project,
    safe_velocity,
    satisfies,
)
from shoal.world.kinematics import sense_all


def _projection(*args: object, **kwargs: object) -> tuple[float, ...]:
    """The bare projection (the cap and the nearest feasible velocity)."""
    return safe_velocity(*args, right_hand=False, **kwargs).velocity  # type: ignore[arg-type]


def _filter(*args: object, **kwargs: object) -> tuple[float, ...]:
    """The filter as agents run it: the projection, turned right where it would deadlock."""
    return safe_velocity(*args, **kwargs).velocity  # type: ignore[arg-type]


SAFE = {name: check for name, check in CHECKS.items() if name != "nearest"}


@settings(max_examples=300, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_the_projection_is_feasible_optimal_short_and_safe(seed: int) -> None:
    case = random_case(np.random.default_rng(seed))
    v = case.run(_projection)
    for name, check in CHECKS.items():
        assert not check(case, v), f"{name}: {case} → {v}"


@settings(max_examples=300, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_the_right_hand_turn_stays_feasible_short_and_safe(seed: int) -> None:
    """The sidestep gives up optimality (on purpose), never safety."""
    case = random_case(np.random.default_rng(seed))
    v = case.run(_filter)
    for name, check in SAFE.items():
        assert not check(case, v), f"{name}: {case} → {v}"


def test_no_property_fails_on_two_thousand_crowded_cases() -> None:
    batch = cases(seed=1, count=2000)
    assert failures(_projection, batch) == dict.fromkeys(CHECKS, 0)
    found = failures(_filter, batch)
    assert {k: found[k] for k in SAFE} == dict.fromkeys(SAFE, 0)


def test_the_crowded_cases_do_reach_corners() -> None:
    """The batch above means something only if the filter is often active, and often with two
    or more rows active at once (where removing rows one at a time goes wrong)."""
    active = corners = 0
    for case in cases(seed=1, count=2000):
        v = case.run(_projection)
        if v != case.nominal:
            active += 1
        tight = [r for r in case.rows() if abs(np.dot(r.normal, v) * case.dt - r.bound) < 1e-9]
        corners += len(tight) >= 2 and v != case.nominal
    assert active > 600 and corners > 100, (active, corners)


@settings(max_examples=200, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_a_feasible_nominal_comes_back_bit_for_bit(seed: int) -> None:
    rng = np.random.default_rng(seed)
    case = random_case(rng)
    small = tuple(x * 1e-3 for x in case.nominal)  # short steps rarely reach a boundary
    rows = case.rows()
    if satisfies(small, rows, case.dt):
        out = project(small, rows, case.dt)
        assert out.velocity is small and not out.active
    again = project(project(case.nominal, rows, case.dt).velocity, rows, case.dt)
    assert not again.active  # the projection is idempotent: the world's no-op in lockstep


def test_every_row_holds_at_rest_for_a_safe_agent() -> None:
    for case in cases(seed=2, count=500):
        for r in case.rows():
            assert r.bound <= 0.0


def test_rows_have_the_geometry_of_the_theorem() -> None:
    row = obstacle_row((3.0, 4.0), (0.0, 0.0), 2.0, 0.5)
    assert row == Row((0.6, 0.8), 2.5 - 5.0, obstacle=True)
    inside = obstacle_row((1.0, 0.0), (0.0, 0.0), 2.0, 0.5)  # already inside: may not go deeper
    assert inside.bound == 0.0
    a = agent_row((0.0, 0.0), (4.0, 0.0), 0.5, lower=True)
    b = agent_row((4.0, 0.0), (0.0, 0.0), 0.5, lower=False)
    assert a.normal == tuple(-x for x in b.normal) and a.bound == b.bound == 0.5 - 2.0
    c = agent_row((1.0, 1.0), (1.0, 1.0), 0.5, lower=True)  # coincident: opposite x axes
    d = agent_row((1.0, 1.0), (1.0, 1.0), 0.5, lower=False)
    assert c.normal == (1.0, 0.0) and d.normal == (-1.0, 0.0)


def test_a_head_on_nominal_stops_at_the_guard_and_slides_along_it() -> None:
    from shoal.bus.messages import Sensing

    s = Sensing(0, (0.0, 0.0), (0,), ((2.0, 0.0),), (1.0,))
    dt, rho = 0.1, 0.5  # guard 1.5: 0.5 m of free way
    head_on = safe_velocity((10.0, 0.0), s, 1, dt=dt, margin=rho, half_separation=0.2,
                            speed_limit=100.0, right_hand=False)  # fmt: skip
    assert head_on.active and head_on.velocity == pytest.approx((5.0, 0.0), abs=1e-12)
    at_guard = Sensing(0, (0.5, 0.0), (0,), ((2.0, 0.0),), (1.0,))
    stuck = safe_velocity((10.0, 0.0), at_guard, 1, dt=dt, margin=rho, half_separation=0.2,
                          speed_limit=100.0, right_hand=False).velocity  # fmt: skip
    assert stuck == pytest.approx((0.0, 0.0), abs=1e-12)
    turned = safe_velocity((10.0, 0.0), at_guard, 1, dt=dt, margin=rho, half_separation=0.2,
                           speed_limit=100.0).velocity  # fmt: skip
    assert turned[1] < -1.0 and np.hypot(*turned) <= 10.0  # round it to the right, no faster
    slanted = safe_velocity((10.0, 10.0), s, 1, dt=dt, margin=rho, half_separation=0.2,
                            speed_limit=100.0)  # fmt: skip
    assert slanted.velocity == pytest.approx((5.0, 10.0), abs=1e-12)  # tangential part kept
    capped = safe_velocity((0.0, 10.0), s, 1, dt=dt, margin=rho, half_separation=0.2,
                           speed_limit=2.0)  # fmt: skip
    assert capped.active and capped.velocity == pytest.approx((0.0, 2.0), abs=1e-12)


def _behind_an_obstacle(previous: bool, dim: int) -> tuple[int | None, float]:
    """An agent whose goal lies straight behind an obstacle, driven by the sign-term law
    v = −β sign(p − goal) per coordinate (which turns from tick to tick) through the filter;
    returns the tick at which it is within 0.1 m of the goal (None: never, in 600 ticks) and
    the least clearance beyond the guard."""
    from shoal.bus.messages import Sensing

    centre, radius, rho, dt, beta = (0.0,) * dim, 1.0, 0.2, 0.02, 3.0
    goal = np.array([3.0] + [0.0] * (dim - 1))
    pos = np.array([-1.2 - 1e-3] + [1e-3] * (dim - 1))  # at the guard, a hair off the axis
    held = np.zeros(dim)
    worst = np.inf
    for k in range(600):
        if np.linalg.norm(pos - goal) < 0.1:
            return k, worst
        nominal = -beta * np.sign(pos - goal)
        s = Sensing(k, tuple(pos.tolist()), (0,), (centre,), (radius,))
        v = np.asarray(safe_velocity(tuple(nominal.tolist()), s, 1, dt=dt, margin=rho,
                                     half_separation=0.2, speed_limit=10.0,
                                     previous=tuple(held.tolist()) if previous else None,
                                     ).velocity)  # fmt: skip
        worst = min(worst, segment_gap(np.zeros(dim), pos, pos + v * dt) - (radius + rho))
        pos, held = pos + v * dt, v
    return None, worst


@pytest.mark.parametrize("dim", [2, 3])
def test_an_agent_goes_round_an_obstacle_whose_far_side_holds_its_goal(dim: int) -> None:
    """Liveness (docs/safety.md): the projection keeps the nominal's part along the guard
    circle, which the sign term flips from tick to tick; remembering which way it was going
    (``previous``), the agent goes round, where without it it shuffles on the spot."""
    arrived, clearance = _behind_an_obstacle(previous=True, dim=dim)
    assert arrived is not None and arrived < 300, arrived  # 2 m round a 1.2 m guard at 3 m/s
    assert clearance >= -1e-9
    stuck, clearance = _behind_an_obstacle(previous=False, dim=dim)
    assert stuck is None and clearance >= -1e-9


def _swarm_run(seed: int, dim: int, steps: int) -> tuple[float, float]:
    """A swarm under an adversarial nominal law (every agent aims at an obstacle or another
    agent, at up to the speed limit), filtered each tick from the world's sensing; returns the
    least clearance beyond each guard and the least pair gap beyond 2R over every whole step."""
    rng = np.random.default_rng(seed)
    n, m = int(rng.integers(3, 8)), int(rng.integers(1, 6))
    rho, half, dt, d = 0.2, 0.25, 0.05, 4.0
    radii = rng.uniform(0.2, 1.2, size=m)
    centres = rng.uniform(-4, 4, size=(m, dim))
    positions = []
    while len(positions) < n:
        p = rng.uniform(-6, 6, size=dim)
        clear = all(np.linalg.norm(p - c) >= r + rho for c, r in zip(centres, radii, strict=True))
        if clear and all(np.linalg.norm(p - q) >= 2 * half for q in positions):
            positions.append(p)
    pos = np.asarray(positions)
    v_max = min(d - radii.max() - rho, (d - 2 * half) / 2) / dt  # (D), exactly at its limit
    targets = rng.integers(0, n + m, size=n)
    worst_clear, worst_gap = np.inf, np.inf
    vel = np.zeros_like(pos)
    for k in range(steps):
        sensings = sense_all(k, pos, centres, radii, d)
        held, vel = vel, np.empty_like(pos)
        for i in range(n):
            t = targets[i]
            aim = centres[t - n] if t >= n else pos[t]
            nominal = (aim - pos[i]) * rng.uniform(0.5, 50.0) + unit(rng, dim) * rng.uniform(0, 2)
            vel[i] = safe_velocity(
                tuple(nominal.tolist()), sensings[i], i + 1, dt=dt, margin=rho,
                half_separation=half, speed_limit=v_max, previous=tuple(held[i].tolist()),
            ).velocity  # fmt: skip
        for i in range(n):
            for c, r in zip(centres, radii, strict=True):
                case_gap = segment_gap(c, pos[i], pos[i] + vel[i] * dt) - (r + rho)
                worst_clear = min(worst_clear, case_gap)
        for i, j in itertools.combinations(range(n), 2):
            gap = pair_gap_along_step(pos[i], vel[i], pos[j], vel[j], dt) - 2 * half
            worst_gap = min(worst_gap, gap)
        pos = pos + dt * vel
        if k % 25 == 0:
            targets = rng.integers(0, n + m, size=n)
    return worst_clear, worst_gap


@pytest.mark.parametrize("dim", [2, 3])
def test_a_swarm_under_any_nominal_law_never_enters_a_guard_nor_a_neighbours_cell(
    dim: int,
) -> None:
    for seed in range(6):
        clear, gap = _swarm_run(seed, dim, steps=150)
        assert clear >= -1e-9 and gap >= -1e-9, (seed, clear, gap)


def test_the_adversarial_swarm_does_press_against_the_boundaries() -> None:
    """Otherwise the test above proves nothing: the agents do get to (within 1 mm of) the
    guard circles and of each other's cells."""
    clear, gap = _swarm_run(0, 2, steps=150)
    assert clear < 1e-3 and gap < 1e-3


def _pair_step(
    tick: int,
    nominal: np.ndarray,
    me: np.ndarray,
    other: np.ndarray,
    i: int,
    *,
    half: float,
    dt: float,
    right_hand: bool,
) -> np.ndarray:
    """Agent i's filtered velocity with the one other agent (id 3 − i) in sight."""
    from shoal.bus.messages import Sensing

    seen = Sensing(tick, tuple(me.tolist()), (), (), (), (3 - i,), (tuple(other.tolist()),))
    out = safe_velocity(tuple(nominal.tolist()), seen, i, dt=dt, margin=0.2,
                        half_separation=half, speed_limit=5.0, right_hand=right_hand)  # fmt: skip
    return np.asarray(out.velocity)


def test_two_agents_head_on_pass_each_other_to_their_right() -> None:
    """The bare projection stops both for good (each nominal points straight at the other);
    with the right-hand rule they swap places, never closer than the separation."""

    dt, half = 0.05, 0.25
    for right_hand, expect_swap in ((False, False), (True, True)):
        a, b = np.array([-2.0, 0.0]), np.array([2.0, 0.0])
        goal_a, goal_b = b.copy(), a.copy()
        closest = np.inf
        for k in range(400):
            va = np.clip(goal_a - a, -1, 1) * 1.5
            vb = np.clip(goal_b - b, -1, 1) * 1.5

            na = _pair_step(k, va, a, b, 1, half=half, dt=dt, right_hand=right_hand)
            nb = _pair_step(k, vb, b, a, 2, half=half, dt=dt, right_hand=right_hand)
            closest = min(closest, pair_gap_along_step(a, na, b, nb, dt))
            a, b = a + dt * na, b + dt * nb
        swapped = np.linalg.norm(a - goal_a) < 0.05 and np.linalg.norm(b - goal_b) < 0.05
        assert swapped == expect_swap
        assert closest >= 2 * half - 1e-9


def test_an_unsafe_start_is_not_made_worse() -> None:
    """An agent already inside a guard (which the loader refuses) may not move deeper."""
    from shoal.bus.messages import Sensing

    s = Sensing(0, (0.0, 0.0), (0,), ((1.0, 0.0),), (0.8,))
    out = safe_velocity((5.0, 1.0), s, 1, dt=0.1, margin=0.2, half_separation=0.1,
                        speed_limit=10.0).velocity  # fmt: skip
    assert out[0] <= 1e-12


def test_case_generator_builds_safe_cases() -> None:
    c: Case = random_case(np.random.default_rng(5), dim=3)
    assert len(c.sensing.position) == 3
    assert all(r.bound <= 0 for r in c.rows())


def test_an_agent_whose_way_on_is_blocked_by_a_neighbour_turns_back_along_the_guard() -> None:
    """Liveness: going on the way it was going (``previous``) is right against a guard, but not
    into a neighbour's cell. Measured in campaign field 818: an agent on an obstacle's guard,
    its last heading pointing round the guard towards a neighbour at the separation, was turned
    that way every tick, projected to a standstill and held for 6.4 s until the run ended."""
    centre, guard, half = np.array([8.097, 2.725]), 1.276 + 0.2, 0.2
    out = np.array([-0.551, 0.834]) / np.hypot(-0.551, 0.834)
    me = centre + guard * out  # on the guard, up and left of the obstacle
    neighbour = me - 2 * half * np.array([0.747, 0.665]) / np.hypot(0.747, 0.665)
    sensing = Sensing(
        tick=0, position=tuple(me.tolist()), obstacle_ids=(0,),
        obstacle_centres=(tuple(centre.tolist()),), obstacle_radii=(1.276,),
        agent_ids=(4,), agent_positions=(tuple(neighbour.tolist()),),
    )  # fmt: skip
    nominal = (7.83, -3.92)  # its slot lies behind the obstacle, down and to the right
    kw = {"dt": 0.01, "margin": 0.2, "half_separation": half, "speed_limit": 10.0}
    bare = np.asarray(safe_velocity(nominal, sensing, 2, right_hand=False, **kw).velocity)
    got = np.asarray(safe_velocity(nominal, sensing, 2, previous=(-0.269, 0.07), **kw).velocity)
    tangent = np.array([out[1], -out[0]])  # round the guard, away from the neighbour
    assert bare @ tangent > 1.0  # the projection slides on round the guard
    assert got @ tangent >= 0.25 * np.linalg.norm(bare)  # and so does the filter
    assert np.linalg.norm(got - bare) < 1e-9 * np.linalg.norm(bare)


@pytest.mark.parametrize("chatter", [-1.0, 1.0])
def test_an_agent_going_nowhere_head_on_against_a_standing_one_turns_right_whatever_its_chatter(
    chatter: float,
) -> None:
    """A follower pressed head on against an agent that stands between it and its slot: the
    sign term's part across the row (±β) survives the projection whole, so the projection
    alone keeps 40 % of the speed, left at one tick and right at the next, and the follower
    stood there for good. Going nowhere (its heading near zero), it turns to its right either
    way; on the move (its heading is its velocity), the projection is left as it is."""
    half, beta = 0.2, 5.0
    sensing = Sensing(
        tick=0, position=(0.0, 0.0), obstacle_ids=(), obstacle_centres=(), obstacle_radii=(),
        agent_ids=(1,), agent_positions=((0.0, 2 * half),),
    )  # fmt: skip
    nominal = (chatter * beta, 11.0)  # its slot lies beyond the standing agent, straight up
    kw = {"dt": 0.01, "margin": 0.2, "half_separation": half, "speed_limit": 20.0}
    bare = safe_velocity(nominal, sensing, 2, right_hand=False, **kw).velocity
    assert bare == pytest.approx((chatter * beta, 0.0))  # the chatter is all that is kept
    going_nowhere = safe_velocity(nominal, sensing, 2, previous=(0.01, 0.02), **kw).velocity
    assert going_nowhere[0] > 0.5 * beta  # right of "towards it" (+y) is +x, both ticks
    assert going_nowhere[1] <= 1e-12  # and never into the other agent's half
    moving = (chatter * 5.0, 0.0)  # it slides along the row at speed: no turn
    assert safe_velocity(nominal, sensing, 2, previous=moving, **kw).velocity == bare
