"""Ray distance d_ij with Remark 4, the evasive offset u^o and the flag Ω of (11)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.typing import ArrayLike

from shoal.agent.collision import Evasion, collision_course, evasive_offset, ray_distance
from shoal.geometry.vectors import FloatArray

# Dyadic values so r + ρ + ε is exact in floating point: 1 + 0.25 + 0.125 = 1.375.
R, RHO, EPS = 1.0, 0.25, 0.125
CLEAR = R + RHO + EPS
KW = {"trigger_radius": 6.0, "sensing_radius": 10.0, "safety_margin": RHO, "epsilon": EPS}
EAST = np.array([1.0, 0.0])


def _course(
    position: ArrayLike,
    heading: ArrayLike,
    centres: ArrayLike,
    held: Evasion | None = None,
    ids: tuple[int, ...] | None = None,
    radii: ArrayLike | None = None,
) -> Evasion | None:
    centres = np.asarray(centres, dtype=float)
    ids = tuple(range(len(centres))) if ids is None else ids
    radii = np.full(len(centres), R) if radii is None else np.asarray(radii, dtype=float)
    pos, head = np.asarray(position, dtype=float), np.asarray(heading, dtype=float)
    return collision_course(pos, head, ids, centres, radii, held, **KW)


def test_ray_distance_known_geometry() -> None:
    assert ray_distance(np.zeros(2), EAST, np.array([5.0, 2.0])) == pytest.approx(2.0)
    assert ray_distance(np.zeros(2), 3.0 * EAST, np.array([5.0, -2.0])) == pytest.approx(2.0)
    assert ray_distance(
        np.array([1.0, 1.0]), np.array([1.0, 1.0]), np.array([3.0, 3.0])
    ) == pytest.approx(0.0, abs=1e-12)


def test_ray_distance_3d() -> None:
    d = ray_distance(
        np.array([1.0, 1.0, 1.0]), np.array([0.0, 0.0, 2.0]), np.array([4.0, 5.0, 10.0])
    )
    assert d == pytest.approx(5.0)


def test_ray_distance_matches_cross_product_formula_for_obstacles_ahead() -> None:
    rng = np.random.default_rng(10)
    for _ in range(200):
        o, h, c = rng.normal(size=2), rng.normal(size=2), rng.normal(size=2) * 5
        if (c - o) @ h <= 0:
            assert ray_distance(o, h, c) == math.inf
            continue
        expected = abs(h[0] * (c - o)[1] - h[1] * (c - o)[0]) / np.linalg.norm(h)
        assert ray_distance(o, h, c) == pytest.approx(expected, rel=1e-9, abs=1e-12)


@pytest.mark.parametrize(
    ("heading", "centre"),
    [
        (EAST, np.array([-5.0, 0.5])),  # behind
        (EAST, np.array([0.0, 3.0])),  # perpendicular: not an acute angle (Remark 4)
        (np.zeros(2), np.array([5.0, 0.0])),  # an agent that does not move has no ray
        (np.array([1e-12, 0.0]), np.array([5.0, 0.0])),
    ],
)
def test_ray_distance_is_inf_when_not_ahead_or_still(
    heading: FloatArray, centre: FloatArray
) -> None:
    assert ray_distance(np.zeros(2), heading, centre) == math.inf


@pytest.mark.parametrize("dim", [2, 3])
def test_evasive_offset_properties_random(dim: int) -> None:
    rng = np.random.default_rng(11 + dim)
    for _ in range(200):
        o, h = rng.normal(size=dim), rng.normal(size=dim)
        unit = h / np.linalg.norm(h)
        lateral = rng.normal(size=dim)
        lateral -= (lateral @ unit) * unit
        lateral *= rng.uniform(0.01, 1.3) / np.linalg.norm(lateral)
        c = o + rng.uniform(2.0, 8.0) * unit + lateral
        d = ray_distance(o, h, c)
        u = evasive_offset(o, h, c, R, safety_margin=RHO, epsilon=EPS)
        assert abs(u @ unit) < 1e-9  # perpendicular to the heading
        assert np.linalg.norm(u) == pytest.approx(CLEAR - d, abs=1e-9)
        assert u @ (-lateral) > 0  # from the centre towards the ray (foot - centre = -lateral)
        assert ray_distance(o + u, h, c) == pytest.approx(CLEAR, abs=1e-9)


def test_evasive_offset_hand_computed_2d() -> None:
    u = evasive_offset(np.zeros(2), EAST, np.array([5.0, 0.5]), R, safety_margin=RHO, epsilon=EPS)
    np.testing.assert_allclose(u, [0.0, -(CLEAR - 0.5)])


def test_evasive_offset_hand_computed_3d() -> None:
    # d = ‖(0.3, 0.4)‖ = 0.5; direction (foot - centre)/d = (-0.6, -0.8, 0); magnitude 0.875.
    u = evasive_offset(
        np.zeros(3),
        np.array([0.0, 0.0, 2.0]),
        np.array([0.3, 0.4, 5.0]),
        R,
        safety_margin=RHO,
        epsilon=EPS,
    )
    np.testing.assert_allclose(u, [-0.6 * 0.875, -0.8 * 0.875, 0.0], atol=1e-12)


def test_evasive_offset_zero_when_ray_already_clear() -> None:
    u = evasive_offset(np.zeros(2), EAST, np.array([5.0, 2.0]), R, safety_margin=RHO, epsilon=EPS)
    np.testing.assert_array_equal(u, [0.0, 0.0])


@pytest.mark.parametrize(
    ("heading", "left"),
    [((1.0, 0.0), (0.0, 1.0)), ((0.0, 1.0), (-1.0, 0.0)), ((0.0, -2.0), (1.0, 0.0))],
)
def test_evasive_offset_through_centre_goes_left(
    heading: tuple[float, float], left: tuple[float, float]
) -> None:
    h = np.array(heading)
    centre = 5.0 * h / np.linalg.norm(h)
    u = evasive_offset(np.zeros(2), h, centre, R, safety_margin=RHO, epsilon=EPS)
    np.testing.assert_allclose(u, CLEAR * np.array(left), atol=1e-12)


def test_evasive_offset_through_centre_3d_is_perpendicular_and_deterministic() -> None:
    h = np.array([1.0, 2.0, 2.0])
    c = 3.0 * h
    u = evasive_offset(np.zeros(3), h, c, R, safety_margin=RHO, epsilon=EPS)
    assert abs(u @ h) < 1e-12
    assert np.linalg.norm(u) == pytest.approx(CLEAR)
    np.testing.assert_array_equal(
        u, evasive_offset(np.zeros(3), h, c, R, safety_margin=RHO, epsilon=EPS)
    )
    assert ray_distance(u, h, c) == pytest.approx(CLEAR)


def test_collision_course_fires_with_obstacle_and_offset() -> None:
    ev = _course([0.0, 0.0], [2.0, 0.0], [[5.0, 0.5]], ids=(7,))
    assert isinstance(ev, Evasion)
    assert ev.obstacle_id == 7
    assert ev.radius == R
    np.testing.assert_allclose(ev.centre, [5.0, 0.5])
    np.testing.assert_allclose(ev.offset, [0.0, -(CLEAR - 0.5)])


def test_collision_course_fires_exactly_at_clearance_but_not_beyond() -> None:
    assert _course([0.0, 0.0], EAST, [[5.0, CLEAR]]) is not None
    assert _course([0.0, 0.0], EAST, [[5.0, CLEAR + 1e-6]]) is None


def test_collision_course_needs_obstacle_within_trigger_radius() -> None:
    assert _course([0.0, 0.0], EAST, [[5.9, 0.0]]) is not None
    assert _course([0.0, 0.0], EAST, [[6.1, 0.0]]) is None


def test_collision_course_ignores_obstacle_behind_or_still_agent() -> None:
    assert _course([0.0, 0.0], EAST, [[-3.0, 0.0]]) is None
    assert _course([0.0, 0.0], [0.0, 0.0], [[3.0, 0.0]]) is None


def test_collision_course_picks_nearest_firing_obstacle() -> None:
    ev = _course([0.0, 0.0], EAST, [[5.0, 0.0], [2.5, 0.5], [4.0, 3.0]], ids=(10, 11, 12))
    assert ev is not None
    assert ev.obstacle_id == 11


def _held() -> Evasion:
    ev = _course([0.0, 0.0], EAST, [[5.0, 0.5]], ids=(7,))
    assert ev is not None
    return ev


def test_collision_course_holds_episode_while_beside_obstacle() -> None:
    held = _held()
    # Beside the obstacle: the ray passes 2 m from the centre (clear), yet the episode holds.
    for x in (3.0, 5.0, 6.0, 6.2):
        ev = _course([x, -1.5], EAST, [[5.0, 0.5]], held=held, ids=(7,))
        assert ev is held
        np.testing.assert_array_equal(ev.offset, [0.0, -(CLEAR - 0.5)])


def test_collision_course_releases_once_past_guard_circle() -> None:
    held = _held()
    # (s - c)·ĥ ≥ r + ρ = 1.25 along the current heading  <=>  s_x ≥ 6.25
    assert _course([6.25, -1.5], EAST, [[5.0, 0.5]], held=held, ids=(7,)) is None
    assert _course([6.24, -1.5], EAST, [[5.0, 0.5]], held=held, ids=(7,)) is held


def test_collision_course_release_is_measured_along_current_heading() -> None:
    held = _held()
    # At (6, -1.5): along east 1.0 < 1.25 holds; along (1, -1)/√2 it is 3/√2 ≈ 2.12: passed.
    assert _course([6.0, -1.5], EAST, [[5.0, 0.5]], held=held, ids=(7,)) is held
    assert _course([6.0, -1.5], [1.0, -1.0], [[5.0, 0.5]], held=held, ids=(7,)) is None
    # A still agent has no heading to pass along: the episode holds.
    assert _course([6.0, -1.5], [0.0, 0.0], [[5.0, 0.5]], held=held, ids=(7,)) is held


def test_collision_course_releases_beyond_sensing_radius() -> None:
    held = _held()
    # Heading north, so never past along the heading; only the distance (d = 10 m) releases.
    north = [0.0, 1.0]
    assert _course([-4.0, 0.5], north, [[5.0, 0.5]], held=held, ids=(7,)) is held  # 9 m
    assert _course([-5.5, 0.5], north, [[5.0, 0.5]], held=held, ids=(7,)) is None  # 10.5 m


def test_collision_course_switches_to_nearer_newly_firing_obstacle() -> None:
    held = _held()
    ev = _course([3.0, -1.0], EAST, [[5.0, 0.5], [4.5, -1.2]], held=held, ids=(7, 8))
    assert ev is not None
    assert ev.obstacle_id == 8
    np.testing.assert_allclose(ev.offset, [0.0, CLEAR - 0.2], atol=1e-12)


def test_collision_course_keeps_held_when_farther_obstacle_fires() -> None:
    held = _held()
    ev = _course([2.0, -1.0], EAST, [[5.0, 0.5], [7.0, -1.0]], held=held, ids=(7, 8))
    assert ev is held  # ray at 1.5 from the held obstacle: clear, so u^o unchanged


def test_held_offset_grows_by_shortfall_while_ray_still_too_close() -> None:
    held = _held()  # u^o = (0, -0.875) fixed at τ
    # Still on the old ray (d = 0.5): short by 1.375 - 0.5 = 0.875 -> |u^o| = 1.75, same direction.
    ev = _course([2.0, 0.0], EAST, [[5.0, 0.5], [7.0, 0.0]], held=held, ids=(7, 8))
    assert ev is not None
    assert ev.obstacle_id == 7
    np.testing.assert_allclose(ev.offset, [0.0, -1.75])
    np.testing.assert_array_equal(ev.centre, held.centre)
    # Ray at d = 1.0 from the obstacle: short by 0.375 on top of the grown 1.75.
    again = _course([2.0, -0.5], EAST, [[5.0, 0.5]], held=ev, ids=(7,))
    assert again is not None
    np.testing.assert_allclose(again.offset, [0.0, -2.125])


def test_held_offset_never_shrinks() -> None:
    held = _held()
    # Ray clear of the obstacle (d = 3.5 > 1.375) or no ray at all: u^o stays as it was.
    assert _course([2.0, -3.0], EAST, [[5.0, 0.5]], held=held, ids=(7,)) is held
    assert _course([2.0, 0.0], [0.0, 0.0], [[5.0, 0.5]], held=held, ids=(7,)) is held


@pytest.mark.parametrize(("cap", "bounded"), [(2.0, True), (math.inf, False)])
def test_the_ratchet_on_u_o_stops_at_its_cap(cap: float, bounded: bool) -> None:
    """An agent whose heading keeps pointing at the obstacle (held back, not steering) grows
    u^o every tick; with the filter's cap it stops at cap × (r + ρ + ε), without it it runs on."""
    centre, radius, rho, eps = np.array([3.0, 0.0]), 1.0, 0.2, 0.05
    position, heading = np.array([0.0, 0.0]), np.array([1.0, 0.0])
    held = None
    for _ in range(200):
        held = collision_course(
            position, heading, (0,), centre[None], np.array([radius]), held,
            trigger_radius=4.0, sensing_radius=5.0, safety_margin=rho, epsilon=eps,
            ratchet_cap=cap,
        )  # fmt: skip
        assert held is not None
    size = float(np.linalg.norm(held.offset))
    guard = radius + rho + eps
    if bounded:
        assert size == pytest.approx(cap * guard)
    else:
        assert size > 10 * guard
