"""Scenarios the physics plant's tests share (tests/world/test_physics.py, tests/tools/)."""

from __future__ import annotations

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
