"""Ground-truth metrics of a run, computed from its trajectory alone.

The formation error of follower i at tick k is ‖s_i - s_1 - R(θ)δ_i/σ‖_∞ (m), with the σ, θ that
agent applied at tick k: the laws and the bounds of Theorem 1 / Remark 3 work per coordinate.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from shoal.bus.geometry import FloatArray, norm, shaped
from shoal.bus.path import path_position, peak_speed
from shoal.bus.types import Clock
from shoal.world.contacts import contacts
from shoal.world.field import centres_at
from shoal.world.scenario import Scenario
from shoal.world.theory import convergence_bound
from shoal.world.trajectory import Trajectory


@dataclass(frozen=True)
class Summary:
    """What a run amounted to. Distances in m, times in s; None where it does not apply."""

    scenario: str
    agents: int
    steps: int
    dt: float
    collisions: int  # agent–agent, agent–standing obstacle, and agent-at-fault contacts
    min_clearance: float | None  # m: least agent-to-edge distance to a standing obstacle
    min_interagent_distance: float
    convergence_time: float | None
    convergence_bound: float
    tolerance: float
    final_formation_error: float
    sigma: float
    sigma_rounds: int | None
    omega_episodes: int
    assumption2_violations: int
    safety: str = "filter"
    filter_activity: float = 0.0  # fraction of agent-ticks the safety filter changed
    stalls: int = 0  # times an agent was held by the filter for more than STALL_TIME
    longest_stall: float = 0.0  # s
    leader_shortfall: float = 0.0  # m: the leader's final distance from where its path ends
    sigma_disagreement: int = 0  # ticks in which the agents applied different σ
    # Contacts with moving obstacles by fault (world/contacts.py): the agent moved towards the
    # obstacle during the contact, or stood / moved away while it was walked into.
    agent_at_fault: int = 0
    obstacle_at_fault: int = 0
    min_mover_clearance: float | None = None  # m: least agent-to-edge distance to a moving one

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


# An agent is held by the filter while the filter is active and it moves slower than this, m/s;
# a hold longer than STALL_TIME, s, is a stall (docs/safety.md, liveness).
STALL_SPEED = 0.05
STALL_TIME = 0.5


def holds(traj: Trajectory) -> list[float]:
    """The length, s, of every stretch of consecutive ticks in which some agent was held: its
    filter active and its speed below STALL_SPEED. Agent by agent, in time order."""
    speed = np.linalg.norm(traj.velocities, axis=-1)
    held = traj.filtered & (speed < STALL_SPEED)
    out: list[float] = []
    for i in range(held.shape[1]):
        flags = np.concatenate([[False], held[:, i], [False]]).astype(np.int8)
        edges = np.flatnonzero(np.diff(flags))
        out += [float((b - a) * traj.dt) for a, b in zip(edges[::2], edges[1::2], strict=True)]
    return out


def formation_errors(scenario: Scenario, traj: Trajectory) -> FloatArray:
    """(T, n-1) formation error of every follower at the start of every tick, m.

    The demanded offsets are :func:`~shoal.bus.geometry.shaped`'s, elementwise over all ticks
    at once: the same operations, so the same bits; cos and sin by ``math`` on each distinct θ
    (numpy's may be vectorised differently on another CPU)."""
    offsets = scenario.offsets[1:]
    ticks = traj.ticks
    rel = traj.positions[:-1, 1:] - traj.positions[:-1, :1]
    theta, sigma = traj.theta[:ticks, 1:], traj.sigma[:ticks, 1:]
    values, where = np.unique(theta, return_inverse=True)
    c = np.array([math.cos(t) for t in values.tolist()])[where].reshape(theta.shape)
    s = np.array([math.sin(t) for t in values.tolist()])[where].reshape(theta.shape)
    desired = np.broadcast_to(offsets, rel.shape).copy()
    x, y = offsets[:, 0], offsets[:, 1]
    desired[..., 0] = x * c + y * -s
    desired[..., 1] = x * s + y * c
    desired /= sigma[..., None]
    return np.asarray(np.abs(rel - desired).max(axis=2), dtype=np.float64)


def clearances(scenario: Scenario, traj: Trajectory) -> FloatArray:
    """(T+1, n, m) distance from every agent to every obstacle's edge at every tick, m
    (obstacles in scenario order, moving ones where they were)."""
    radii = np.asarray([o.radius for o in scenario.obstacles], dtype=np.float64)
    centres = centres_at(scenario, traj.movers, traj.positions.shape[0])
    diff = traj.positions[:, :, None, :] - centres[:, None, :, :]
    return np.asarray(np.linalg.norm(diff, axis=-1) - radii, dtype=np.float64)


def pair_distances(traj: Trajectory) -> FloatArray:
    """(T+1, n(n-1)/2) distance between every pair of agents, m, pairs in (i<j) order."""
    n = traj.positions.shape[1]
    pairs = list(itertools.combinations(range(n), 2))
    return np.stack(
        [np.linalg.norm(traj.positions[:, i] - traj.positions[:, j], axis=1) for i, j in pairs],
        axis=1,
    )


def onsets(flags: np.ndarray[Any, np.dtype[np.bool_]]) -> int:
    """Number of False→True switches along axis 0 (a flag already set at tick 0 counts)."""
    before = np.concatenate([np.zeros_like(flags[:1]), flags[:-1]])
    return int((flags & ~before).sum())


def sigma_rounds(bid: FloatArray, rounds: int) -> int | None:
    """Rounds Algorithm 1 took to spread the maximum bid in the first epoch that contracted.

    Values announced at tick eK + r have been through r rounds; after K = L_G rounds all agree
    (Proposition 1), which the next epoch applies. None if no agent ever bid above 1.
    """
    for start in range(0, bid.shape[0], rounds):
        epoch = bid[start : start + rounds]
        top = float(epoch.max())
        if top <= 1.0:
            continue
        for r in range(epoch.shape[0]):
            if np.all(epoch[r] == top):
                return r
        return rounds
    return None


def assumption2_violations(scenario: Scenario, omega: np.ndarray[Any, Any]) -> int:
    """Ticks at which some evading agent has every neighbour evading too."""
    a = scenario.adjacency
    count = 0
    for k in range(omega.shape[0]):
        for i in np.flatnonzero(omega[k]):
            row = np.flatnonzero(a[i])
            if row.size and omega[k, row].all():
                count += 1
                break
    return count


def summarize(scenario: Scenario, traj: Trajectory, *, clock: Clock = Clock.LOCKSTEP) -> Summary:
    """The figures reported after a run under ``clock`` (which sets Algorithm 1's epochs)."""
    errors = formation_errors(scenario, traj)
    worst = errors.max(axis=1)
    below = np.flatnonzero(worst <= scenario.tolerance)
    z0 = (
        traj.positions[0, 1:]
        - traj.positions[0, 0]
        - np.stack(
            [
                shaped(
                    scenario.offsets[i],
                    sigma=float(traj.sigma[0, i]),
                    theta=float(traj.theta[0, i]),
                )
                for i in range(1, scenario.n)
            ]
        )
    )
    bound = convergence_bound(
        scenario.adjacency,
        z0,
        directed=scenario.directed,
        beta=scenario.control.beta,
        f_max=peak_speed(scenario.path),
    )
    collisions = 0
    min_clearance = min_mover_clearance = None
    if scenario.obstacles:
        clear = clearances(scenario, traj)
        standing = clear[:, :, list(scenario.standing_ids)]
        if standing.size:
            min_clearance = float(standing.min())
            collisions += onsets(standing < scenario.agent_radius)
        if scenario.mover_ids:
            min_mover_clearance = float(clear[:, :, list(scenario.mover_ids)].min())
    pairs = pair_distances(traj)
    collisions += onsets(pairs < 2 * scenario.agent_radius)
    held = holds(traj)
    goal = path_position(scenario.path, traj.ticks * traj.dt)
    touches = contacts(scenario, traj)
    at_fault = sum(c.agent_at_fault for c in touches)
    collisions += at_fault  # a contact a moving obstacle made is counted beside, by fault
    return Summary(
        scenario=scenario.name,
        agents=scenario.n,
        steps=traj.ticks,
        dt=traj.dt,
        collisions=collisions,
        min_clearance=min_clearance,
        min_interagent_distance=float(pairs.min()),
        convergence_time=float(below[0] * traj.dt) if below.size else None,
        convergence_bound=bound,
        tolerance=scenario.tolerance,
        final_formation_error=float(worst[-1]),
        sigma=float(traj.sigma.max()),
        sigma_rounds=sigma_rounds(traj.bid, scenario.epoch_ticks(clock)),
        sigma_disagreement=int(np.any(traj.sigma != traj.sigma[:, :1], axis=1).sum()),
        omega_episodes=onsets(traj.omega),
        assumption2_violations=assumption2_violations(scenario, traj.omega),
        safety=str(scenario.control.safety),
        filter_activity=float(traj.filtered.mean()) if traj.filtered.size else 0.0,
        stalls=sum(h > STALL_TIME for h in held),
        longest_stall=max(held, default=0.0),
        leader_shortfall=norm(traj.positions[-1, 0] - goal),
        min_mover_clearance=min_mover_clearance,
        agent_at_fault=at_fault,
        obstacle_at_fault=len(touches) - at_fault,
    )
