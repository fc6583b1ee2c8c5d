"""Law (1)-(2), scaling (8), rotation (9) and the evasive term of (12): agent/formation.py."""

from __future__ import annotations

import math

import numpy as np
import pytest

from shoal.agent.collision import evasive_offset
from shoal.agent.formation import consensus_error, evasive_error, rotation, shaped, velocity


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("theta", [0.0, 0.3, math.pi / 2, 2.0, -1.1, math.pi])
def test_rotation_is_orthonormal_with_unit_determinant(theta: float, dim: int) -> None:
    r = rotation(theta, dim)
    assert r.shape == (dim, dim)
    np.testing.assert_allclose(r @ r.T, np.eye(dim), atol=1e-12)
    assert np.linalg.det(r) == pytest.approx(1.0)


@pytest.mark.parametrize("theta", [0.0, 0.3, math.pi / 2, 2.0, -1.1])
def test_rotation_takes_x_axis_to_cos_sin_without_printed_minus(theta: float) -> None:
    # The printed (9) carries a leading minus, which would give (-cos, -sin): rotation by θ + π.
    np.testing.assert_allclose(
        rotation(theta, 2) @ np.array([1.0, 0.0]), [math.cos(theta), math.sin(theta)], atol=1e-12
    )


def test_rotation_by_zero_is_identity_and_quarter_turn_is_counter_clockwise() -> None:
    np.testing.assert_allclose(rotation(0.0, 2), np.eye(2))
    np.testing.assert_allclose(rotation(math.pi / 2, 2) @ [0.0, 1.0], [-1.0, 0.0], atol=1e-12)


def test_rotation_in_3d_is_about_z_and_keeps_z() -> None:
    r = rotation(0.7, 3)
    v = np.array([1.0, 2.0, 5.0])
    out = r @ v
    assert out[2] == pytest.approx(5.0)
    np.testing.assert_allclose(out[:2], rotation(0.7, 2) @ v[:2], atol=1e-12)
    np.testing.assert_allclose(r[2], [0.0, 0.0, 1.0])
    np.testing.assert_allclose(r[:, 2], [0.0, 0.0, 1.0])


@pytest.mark.parametrize("dim", [2, 3])
def test_shaped_equals_rotated_offsets_divided_by_sigma(dim: int) -> None:
    rng = np.random.default_rng(1)
    offsets = rng.normal(size=(6, dim))
    sigma, theta = 1.7, 0.9
    expected = np.array([rotation(theta, dim) @ d / sigma for d in offsets])
    np.testing.assert_allclose(shaped(offsets, sigma=sigma, theta=theta), expected, atol=1e-12)


def test_shaped_single_offset_hand_computed() -> None:
    # R(90°)(2, 0) = (0, 2); divided by σ = 2 -> (0, 1).
    out = shaped(np.array([2.0, 0.0]), sigma=2.0, theta=math.pi / 2)
    assert out.shape == (2,)
    np.testing.assert_allclose(out, [0.0, 1.0], atol=1e-12)


def test_shaped_identity_at_sigma_one_theta_zero_and_preserves_norm_ratio() -> None:
    offsets = np.array([[3.0, -1.0], [0.5, 2.0]])
    np.testing.assert_allclose(shaped(offsets, sigma=1.0, theta=0.0), offsets)
    out = shaped(offsets, sigma=4.0, theta=1.3)
    np.testing.assert_allclose(
        np.linalg.norm(out, axis=1), np.linalg.norm(offsets, axis=1) / 4.0, atol=1e-12
    )


def test_consensus_error_matches_sum_over_neighbours() -> None:
    rng = np.random.default_rng(2)
    x, d = rng.normal(size=3), rng.normal(size=3)
    xs, ds = rng.normal(size=(4, 3)), rng.normal(size=(4, 3))
    expected = sum((x - d) - (xs[j] - ds[j]) for j in range(4))
    np.testing.assert_allclose(consensus_error(x, d, xs, ds), expected, atol=1e-12)


def test_consensus_error_hand_computed() -> None:
    # (x_i - δ_i) = (1, 1); neighbours: (0,0)-(0,0) and (4,2)-(1,1) = (3,1).
    # e = (1,1)-(0,0) + (1,1)-(3,1) = (1,1) + (-2,0) = (-1, 1).
    e = consensus_error(
        np.array([2.0, 1.0]),
        np.array([1.0, 0.0]),
        np.array([[0.0, 0.0], [4.0, 2.0]]),
        np.array([[0.0, 0.0], [1.0, 1.0]]),
    )
    np.testing.assert_allclose(e, [-1.0, 1.0])


def test_consensus_error_zero_at_desired_formation() -> None:
    rng = np.random.default_rng(3)
    leader = rng.normal(size=2)
    offsets = rng.normal(size=(5, 2))
    offsets[0] = 0.0
    positions = leader + offsets
    for i in range(1, 5):
        others = [j for j in range(5) if j != i]
        e = consensus_error(positions[i], offsets[i], positions[others], offsets[others])
        np.testing.assert_allclose(e, 0.0, atol=1e-12)


def test_consensus_error_without_neighbours_is_zero() -> None:
    e = consensus_error(
        np.array([5.0, -3.0]), np.array([1.0, 1.0]), np.zeros((0, 2)), np.zeros((0, 2))
    )
    np.testing.assert_array_equal(e, [0.0, 0.0])


def test_evasive_error_subtracts_degree_times_offset() -> None:
    out = evasive_error(np.array([1.0, 2.0]), 3, np.array([0.5, -1.0]))
    np.testing.assert_allclose(out, [1.0 - 1.5, 2.0 + 3.0])


def test_velocity_sign_law_without_boundary_layer() -> None:
    arg = np.array([0.3, -2.0, 0.0])
    v = velocity(arg, alpha=1.5, beta=0.7, boundary_layer=0.0)
    np.testing.assert_allclose(v, [-1.5 * 0.3 - 0.7, 1.5 * 2.0 + 0.7, 0.0])


def test_velocity_inside_boundary_layer_is_linear() -> None:
    alpha, beta, phi = 2.0, 0.5, 0.1
    arg = np.array([0.05, -0.02, 0.1])
    v = velocity(arg, alpha=alpha, beta=beta, boundary_layer=phi)
    np.testing.assert_allclose(v, -alpha * arg - beta * arg / phi)
    outside = velocity(np.array([0.4, -3.0]), alpha=alpha, beta=beta, boundary_layer=phi)
    np.testing.assert_allclose(outside, [-alpha * 0.4 - beta, alpha * 3.0 + beta])


def test_velocity_with_boundary_layer_is_continuous_and_sign_law_jumps() -> None:
    e = np.linspace(-0.3, 0.3, 60001)
    smooth = velocity(e, alpha=1.0, beta=2.0, boundary_layer=0.05)
    # Lipschitz with constant α + β/φ = 41: neighbouring samples differ by at most that · step.
    assert np.abs(np.diff(smooth)).max() <= 41.0 * (e[1] - e[0]) * (1 + 1e-9)
    jump = velocity(np.array([-1e-9, 1e-9]), alpha=1.0, beta=2.0, boundary_layer=0.0)
    assert jump[0] - jump[1] == pytest.approx(4.0, abs=1e-6)


def _settle(
    positions: np.ndarray, offsets: np.ndarray, u_o: np.ndarray, *, phi: float, steps: int
) -> np.ndarray:
    """Euler-integrate follower 1 (index 1) with every other agent stationary."""
    dt = 1e-3
    x = np.array([3.0, -4.0])
    others = [j for j in range(len(positions)) if j != 1]
    for _ in range(steps):
        e = consensus_error(x, offsets[1], positions[others], offsets[others])
        arg = evasive_error(e, len(others), u_o)
        x = x + dt * np.asarray(velocity(arg, alpha=1.0, beta=0.5, boundary_layer=phi))
    return x


@pytest.mark.parametrize("phi", [0.0, 0.01])
def test_evasive_setpoint_moves_follower_away_from_obstacle(phi: float) -> None:
    leader = np.array([0.0, 0.0])
    delta = np.array([2.0, 0.0])
    slot = leader + delta
    # Heading +x, obstacle just above the ray from the slot: u^o points down, away from it.
    centre, radius = slot + np.array([4.0, 0.3]), 1.0
    u_o = evasive_offset(
        slot, np.array([1.0, 0.0]), centre, radius, safety_margin=0.2, epsilon=0.05
    )
    np.testing.assert_allclose(u_o, [0.0, -(1.0 + 0.2 + 0.05 - 0.3)])
    x = _settle(
        np.array([leader, [9.0, 9.0]]), np.array([[0.0, 0.0], delta]), u_o, phi=phi, steps=20000
    )
    tol = 1e-6 if phi > 0 else 2 * 0.5 * 1e-3  # sign law chatters within a few β·dt
    np.testing.assert_allclose(x, slot + u_o, atol=tol)
    # Lateral clearance from the obstacle's centre is now r + ρ + ε, clear of the guard circle;
    # the paper's printed "+" would settle at slot - u^o, only 0.65 m across: inside r = 1.
    assert abs(x[1] - centre[1]) == pytest.approx(1.25, abs=tol)
    assert abs((slot - u_o)[1] - centre[1]) == pytest.approx(0.65)


def test_evasive_setpoint_with_two_neighbours_is_still_plus_offset() -> None:
    offsets = np.array([[0.0, 0.0], [1.0, 1.0], [-1.0, 2.0]])
    leader = np.array([0.5, -0.5])
    positions = np.array([leader, [0.0, 0.0], leader + offsets[2]])
    u_o = np.array([0.4, -0.3])
    x = _settle(positions, offsets, u_o, phi=0.01, steps=20000)
    np.testing.assert_allclose(x, leader + offsets[1] + u_o, atol=1e-6)
