"""Scenarios several tests share: the physics plant's crash, and a mixed formation."""

from __future__ import annotations

from shoal.world.loader import load_scenario


def mixed_robotarium(
    duration: float, singles: tuple[str, ...] = ("[-0.4, 0.4]}", "[-0.8, -0.8]}")
) -> str:
    """``robotarium``'s YAML cut to ``duration`` s, with the agents at ``singles`` (their offsets
    as the file writes them) made holonomic (``kinematics: single``): GRITSbots and bases."""
    text = load_scenario("robotarium").source.replace("duration: 75.0", f"duration: {duration}")
    for offset in singles:
        text = text.replace(offset, offset[:-1] + ", kinematics: single}")
    return text


# The paper's law alone (no safety filter) drives the follower through an obstacle at 0.4 m/s:
# a contact the engine must report.
CRASH = """
name: crash
description: The paper's law alone drives a follower through an obstacle.
dt: 0.01
duration: 6.0
agent_radius: 0.1
control: {alpha: 1.0, beta: 0.5, sensing_radius: 0.45, trigger_radius: 0.35, epsilon: 0.05,
          safety_margin: 0.05, safety: paper}
graph: {edges: [[1, 2]]}
agents: [{offset: [0, 0]}, {offset: [0, -1]}]
leader: {waypoints: [[0, 0], [4, 0]], speed: 0.4}
obstacles: [{centre: [2, -1], radius: 0.2}]
"""
