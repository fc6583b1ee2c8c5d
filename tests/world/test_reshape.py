"""Remark 2: the settled formation is R(θ)δ/σ, in 2-D and 3-D (rotation about z)."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from shoal.geometry.vectors import rotation
from shoal.tools.simulator import simulate
from shoal.world.loader import scenario_from_dict


def formation(dim: int, reshape: list[dict[str, float]]) -> dict[str, Any]:
    offsets = [[0, 0, 0], [-3, 3, 1], [-3, -3, -1], [-6, 0, 2]]
    return {
        "dim": dim,
        "dt": 0.01,
        "duration": 12.0,
        "seed": 5,
        "graph": {"edges": [[1, 2], [1, 3], [2, 3], [2, 4], [3, 4]]},
        "agents": [{"offset": o[:dim]} for o in offsets],
        "initial_noise": 1.0,
        "leader": {"waypoints": [[0] * dim, [10] + [2] * (dim - 1)], "speed": 1.0},
        "reshape": reshape,
    }


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize(("scale", "rotate"), [(2.0, 0.7), (0.5, -1.2), (1.0, np.pi)])
def test_settled_offsets_equal_rotated_and_scaled_offsets(
    dim: int, scale: float, rotate: float
) -> None:
    scenario = scenario_from_dict(formation(dim, [{"at": 2.0, "scale": scale, "rotate": rotate}]))
    traj = simulate(scenario)
    rel = traj.positions[-1, 1:] - traj.positions[-1, 0]
    expected = scenario.offsets[1:] @ rotation(rotate, dim).T / scale
    assert np.abs(rel - expected).max() <= scenario.tolerance
    # Before the reshape the formation held the nominal offsets.
    before = traj.positions[199, 1:] - traj.positions[199, 0]
    assert np.abs(before - scenario.offsets[1:]).max() <= scenario.tolerance


def test_rotation_keeps_the_z_offsets_in_3d() -> None:
    scenario = scenario_from_dict(formation(3, [{"at": 0.0, "rotate": 1.0}]))
    traj = simulate(scenario)
    rel = traj.positions[-1, 1:] - traj.positions[-1, 0]
    assert np.abs(rel[:, 2] - scenario.offsets[1:, 2]).max() <= scenario.tolerance
