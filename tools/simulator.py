"""The reference simulator: every agent and the world in one process, in lockstep.

It calls exactly what the distributed run calls: the world's ``sensing_for`` and ``integrate``
and each agent's ``Controller.announce`` / ``Controller.act``, in the same order and on the same
float64 values, so a lockstep run over Zenoh must reproduce its trajectory bit for bit.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from agent.controller import Controller
from bus.types import AgentState
from world.kinematics import integrate, sensing_for
from world.scenario import Scenario
from world.trajectory import Trajectory

Progress = Callable[[int], None]


def simulate(scenario: Scenario, *, progress: Progress | None = None) -> Trajectory:
    """Run ``scenario`` for all its ticks; ``progress(k)`` is called after each tick."""
    n, dim, steps = scenario.n, scenario.dim, scenario.steps
    controllers = [Controller(scenario.agent_config(i + 1)) for i in range(n)]
    memories = [c.start() for c in controllers]
    centres, radii = scenario.obstacle_centres, scenario.obstacle_radii
    d = scenario.control.sensing_radius

    positions = np.empty((steps + 1, n, dim))
    velocities = np.empty((steps, n, dim))
    omega = np.zeros((steps, n), dtype=bool)
    bid, sigma, theta = (np.empty((steps, n)) for _ in range(3))
    positions[0] = scenario.initial_positions

    for k in range(steps):
        sensings = [sensing_for(k, positions[k, i], centres, radii, d) for i in range(n)]
        states: dict[int, AgentState] = {}
        for i, c in enumerate(controllers):
            memories[i], states[i + 1] = c.announce(memories[i], sensings[i])
        for i, c in enumerate(controllers):
            heard = {j: states[j] for j in c.listens_to}
            memories[i], command = c.act(memories[i], sensings[i], heard)
            velocities[k, i] = command.velocity
        for i in range(n):
            s = states[i + 1]
            omega[k, i], bid[k, i], sigma[k, i], theta[k, i] = s.omega, s.bid, s.sigma, s.theta
        positions[k + 1] = integrate(positions[k], velocities[k], scenario.dt)
        if progress is not None:
            progress(k)
    return Trajectory(
        dt=scenario.dt,
        positions=positions,
        velocities=velocities,
        omega=omega,
        bid=bid,
        sigma=sigma,
        theta=theta,
    )
