"""World kinematics and sensing: Euler steps of ṡ = v, and which obstacles each agent senses."""

from __future__ import annotations

import numpy as np

from shoal.world.kinematics import integrate, sense_all


def test_integrate_is_one_euler_step() -> None:
    p = np.array([[0.0, 1.0], [2.0, -1.0]])
    v = np.array([[1.0, 0.5], [-2.0, 0.0]])
    assert np.array_equal(integrate(p, v, 0.1), p + 0.1 * v)


def test_sense_all_reports_obstacles_within_d_inclusive_in_id_order() -> None:
    positions = np.array([[0.0, 0.0], [10.0, 0.0]])
    centres = np.array([[3.0, 4.0], [0.0, 1.0], [10.0, 6.0], [100.0, 0.0]])
    radii = np.array([1.0, 0.5, 2.0, 3.0])
    first, second = sense_all(7, positions, centres, radii, 5.0)
    assert first.tick == second.tick == 7
    assert first.position == (0.0, 0.0)
    assert first.obstacle_ids == (0, 1)  # (3, 4) is exactly 5 m away: sensed
    assert first.obstacle_centres == ((3.0, 4.0), (0.0, 1.0))
    assert first.obstacle_radii == (1.0, 0.5)
    assert second.obstacle_ids == ()  # (10, 6) is 6 m away


def test_sense_all_without_obstacles_and_in_3d() -> None:
    positions = np.array([[1.0, 2.0, 3.0]])
    (only,) = sense_all(0, positions, np.zeros((0, 3)), np.zeros(0), 5.0)
    assert only.position == (1.0, 2.0, 3.0)
    assert only.obstacle_ids == only.obstacle_centres == only.obstacle_radii == ()
    (near,) = sense_all(0, positions, np.array([[1.0, 2.0, 7.0]]), np.array([1.0]), 4.0)
    assert near.obstacle_ids == (0,)
