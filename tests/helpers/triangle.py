"""The small scenario several tests build on: three agents in a triangle, every pair an edge,
behind a leader at 1 m/s, with one obstacle (as the data a scenario file holds)."""

from __future__ import annotations


def triangle(
    waypoints: list[list[float]],
    *,
    duration: float,
    obstacle: tuple[list[float], float],
    **control: object,
) -> dict[str, object]:
    """The scenario's data: ticks of 0.01 s for ``duration`` s, the leader along ``waypoints``,
    the obstacle's ``(centre, radius)``; ``control`` added to the sensing and trigger radii."""
    centre, radius = obstacle
    return {
        "dt": 0.01,
        "duration": duration,
        "control": {"sensing_radius": 5.0, "trigger_radius": 4.0, **control},
        "graph": {"edges": [[1, 2], [2, 3], [1, 3]]},
        "agents": [{"offset": [0, 0]}, {"offset": [-3, 3]}, {"offset": [-3, -3]}],
        "leader": {"waypoints": waypoints, "speed": 1.0},
        "obstacles": [{"centre": centre, "radius": radius}],
    }
