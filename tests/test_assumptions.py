"""world/assumptions.py beyond the paper's Assumptions (those are in test_loader.py): what makes
a field impossible to finish, refused at load with the field named."""

from __future__ import annotations

import copy
from typing import Any

import pytest

from shoal.world.errors import ScenarioError
from shoal.world.loader import scenario_from_dict


def base() -> dict[str, Any]:
    """Four agents on a 20 m leg; final slots (17, 3), (17, -3), (14, 0); no obstacle."""
    return {
        "dt": 0.01,
        "duration": 25.0,
        "graph": {"edges": [[1, 2], [1, 3], [2, 3], [2, 4], [3, 4]]},
        "agents": [{"offset": o} for o in ([0, 0], [-3, 3], [-3, -3], [-6, 0])],
        "leader": {"waypoints": [[0, 0], [20, 0]], "speed": 1.0},
    }


def with_(data: dict[str, Any], **fields: Any) -> dict[str, Any]:
    return {**copy.deepcopy(data), **fields}


def walker(centre: list[float], to: list[float], speed: float = 1.0) -> dict[str, Any]:
    return {"centre": centre, "radius": 0.3,
            "moves": {"kind": "route", "waypoints": [to], "speed": speed}}  # fmt: skip


# -- obstacles are named by their place in the list ---------------------------------------------


def test_a_standing_obstacle_after_a_moving_one_is_named_by_its_own_index() -> None:
    data = with_(base(), obstacles=[walker([5, 8], [5, 9]), {"centre": [-3, 3.3], "radius": 0.5}])
    message = r"^agents\[1\]\.initial: starts inside obstacles\[1\]$"
    with pytest.raises(ScenarioError, match=message):
        scenario_from_dict(data)
