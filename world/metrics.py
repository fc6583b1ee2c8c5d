"""Ground-truth metrics of a run, computed from its trajectory alone.

The formation error of follower i at tick k is ‖s_i - s_1 - R(θ)δ_i/σ‖_∞ (m), with the σ, θ that
agent applied at tick k: the laws and the bounds of Theorem 1 / Remark 3 work per coordinate.

Distances to standing obstacles and between agents are the least over each whole step
(world/sweep.py), not samples at ticks: an agent that passes through an obstacle between two
ticks collides. A body contact is an overlap deeper than :func:`contact_slack`; the margins
against the safety theorem's own bounds (ρ, the separation) are reported beside the count.
Arrival, its cause when it fails, and livelocks are world/arrival.py's.
"""

from __future__ import annotations

import itertools
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from shoal.bus.types import Clock
from shoal.geometry.path import path_position, peak_speed
from shoal.geometry.safety import TOLERANCE
from shoal.geometry.vectors import FloatArray, norm, shaped
from shoal.world.arrival import STALL_SPEED, arrival
from shoal.world.contacts import contacts
from shoal.world.obstacles import centres_at
from shoal.world.scenario import Scenario
from shoal.world.slots import slot_errors
from shoal.world.sweep import step_clearances, step_separations
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
    min_interagent_distance: float  # m: least over whole steps, as min_clearance
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
    # Fraction of agent-ticks moving at the speed limit (for unicycles, the point's cap: there
    # the limits cut in and the point does not follow the law exactly; Theorem 1 assumes not).
    at_speed_limit: float = 0.0
    stalls: int = 0  # times an agent was held by the filter for more than STALL_TIME
    longest_stall: float = 0.0  # s
    leader_shortfall: float = 0.0  # m: the leader's final distance from where its path ends
    sigma_disagreement: int = 0  # ticks in which the agents applied different σ
    # Contacts with moving obstacles by fault (world/contacts.py): the agent moved towards the
    # obstacle during the contact, or stood / moved away while it was walked into.
    agent_at_fault: int = 0
    obstacle_at_fault: int = 0
    min_mover_clearance: float | None = None  # m: least agent-to-edge distance to a moving one
    # The safety theorem's own bounds (docs/safety.md): both ≥ 0 with the filter, up to
    # contact_slack. guard_margin: min_clearance − ρ (None without standing obstacles);
    # separation_margin: min_interagent_distance − the separation; for unicycles the same
    # bounds hold for their points' chords, the steps the filter certified. m.
    guard_margin: float | None = None
    separation_margin: float = 0.0
    contact_slack: float = 0.0  # m: an overlap this shallow is rounding, not a collision
    # Arrival (world/arrival.py): the leader home and every follower, averaged over a trailing
    # window, within arrival_tolerance (m) of its slot from arrival_time (s) to the end; else
    # not_arrived names why: "leader trapped", "deadlock", "livelock" or "out of time".
    arrived: bool = False
    arrival_time: float | None = None
    arrival_tolerance: float = 0.0
    not_arrived: str | None = None
    leader_trapped: bool = False  # not_arrived is "leader trapped" (the world logs it live)
    slot_distance: float = 0.0  # m: the farthest follower from its slot at the end (averaged)
    livelocks: int = 0  # episodes of an agent moving without getting closer to its slot
    longest_livelock: float = 0.0  # s

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


# An agent is held by the filter while the filter is active and it moves slower than
# STALL_SPEED, m/s (world/arrival.py); a hold longer than STALL_TIME, s, is a stall (docs/safety.md,
# liveness). A still agent off its slot with the filter idle is not a stall: arrival names it.
STALL_TIME = 0.5

# m per tick: how much deeper a pair of bodies may overlap each tick without a collision. The
# filter accepts a row met within geometry/safety.py's TOLERANCE (1e-12 m), so an agent pressed
# against a row may sink that much further every tick, and a pair of agents twice that (each
# agent's row); the other 2e-12 m cover the rounding of positions (an ulp of a 100 m coordinate
# is 1.4e-14 m). Over a run of T ticks the overlap is at most T times this.
CONTACT_SLACK_PER_TICK = 4 * TOLERANCE


def contact_slack(ticks: int) -> float:
    """m: the deepest overlap that is floating-point slack rather than a collision in a run of
    ``ticks`` ticks (:data:`CONTACT_SLACK_PER_TICK` per tick)."""
    return max(1, ticks) * CONTACT_SLACK_PER_TICK


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
    """(T, n-1) formation error of every follower at the start of every tick, m: the ∞-norm of
    :func:`~shoal.world.slots.slot_errors`."""
    return np.asarray(np.abs(slot_errors(scenario, traj)).max(axis=2), dtype=np.float64)


def clearances(scenario: Scenario, traj: Trajectory) -> FloatArray:
    """(T+1, n, m) distance from every agent to every obstacle's edge at every tick, m
    (obstacles in scenario order, moving ones where they were): samples for the figures; the
    reported minima are :class:`Sweep`'s."""
    radii = np.asarray([o.radius for o in scenario.obstacles], dtype=np.float64)
    centres = centres_at(scenario, traj.movers, traj.positions.shape[0])
    diff = traj.positions[:, :, None, :] - centres[:, None, :, :]
    return np.asarray(np.linalg.norm(diff, axis=-1) - radii, dtype=np.float64)


def pair_distances(traj: Trajectory) -> FloatArray:
    """(T+1, n(n-1)/2) distance between every pair of agents at every tick, m, pairs in (i<j)
    order (what the figures draw; the reported minima are :class:`Sweep`'s)."""
    n = traj.positions.shape[1]
    pairs = list(itertools.combinations(range(n), 2))
    return np.stack(
        [np.linalg.norm(traj.positions[:, i] - traj.positions[:, j], axis=1) for i, j in pairs],
        axis=1,
    )


@dataclass(frozen=True)
class Sweep:
    """The least distances of a run over whole steps (world/sweep.py), m.

    clearance : (T, n, m) to every standing obstacle's edge, in ``standing_ids`` order;
    separation : (T, n(n-1)/2) between every pair of agents, pairs in (i<j) order;
    slack : m, :func:`contact_slack` of the run."""

    clearance: FloatArray
    separation: FloatArray
    slack: float

    @classmethod
    def of(cls, scenario: Scenario, traj: Trajectory) -> Sweep:
        return cls(
            clearance=step_clearances(
                traj.positions, scenario.obstacle_centres, scenario.obstacle_radii
            ),
            separation=step_separations(traj.positions),
            slack=contact_slack(traj.ticks),
        )

    def obstacle_contacts(self, agent_radius: float) -> int:
        """Body contacts with standing obstacles: onsets of an overlap deeper than the slack."""
        return onsets(self.clearance < agent_radius - self.slack)

    def agent_contacts(self, agent_radius: float) -> int:
        """Body contacts between agents: onsets of an overlap deeper than the slack."""
        return onsets(self.separation < 2 * agent_radius - self.slack)


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


def at_speed_limit(scenario: Scenario, traj: Trajectory) -> float:
    """Fraction of agent-ticks whose velocity is at the speed limit (within 1e-9 of it), or,
    for a unicycle, on its limits' polygon at its heading (world/limits.py): where the limits
    cut the law."""
    if not traj.velocities.size:
        return 0.0
    speeds = np.linalg.norm(traj.velocities, axis=-1)
    at = speeds >= scenario.speed_limit * (1.0 - 1e-9)
    if scenario.limits and traj.headings is not None:
        turned = traj.headings[: len(traj.velocities)]
        cos, sin = np.cos(turned), np.sin(turned)
        u = traj.velocities
        w = np.stack([cos * u[..., 0] + sin * u[..., 1], -sin * u[..., 0] + cos * u[..., 1]], -1)
        for i, sides in enumerate(scenario.limits):
            if sides:
                n = np.asarray([side[:2] for side in sides])
                c = np.asarray([side[2] for side in sides])
                worst = (w[:, i] @ n.T - c * (1.0 - 1e-9)).max(axis=1)
                at[:, i] |= worst >= 0.0
    return float(np.mean(at))


def _bound_from_start(scenario: Scenario, traj: Trajectory) -> float:
    """s: Theorem 1's (Remark 3's, directed) convergence bound from the run's first tick, its
    offsets shaped as the agents held them then."""
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
    return scenario_bound(scenario, z0)


def scenario_bound(scenario: Scenario, z0: FloatArray) -> float:
    """s: Theorem 1's (Remark 3's, directed) bound for ``scenario``'s graph, gains and path
    from the followers' formation errors ``z0`` ((n − 1, dim), m)."""
    return convergence_bound(
        scenario.adjacency,
        z0,
        directed=scenario.directed,
        beta=scenario.control.beta,
        f_max=peak_speed(scenario.path),
    )


def summarize(
    scenario: Scenario,
    traj: Trajectory,
    *,
    clock: Clock = Clock.LOCKSTEP,
    swept: Sweep | None = None,
) -> Summary:
    """The figures reported after a run under ``clock`` (which sets Algorithm 1's epochs);
    ``swept``: the run's :class:`Sweep` if the caller has it already."""
    swept = Sweep.of(scenario, traj) if swept is None else swept
    errors = formation_errors(scenario, traj)
    worst = errors.max(axis=1)
    below = np.flatnonzero(worst <= scenario.tolerance)
    bound = _bound_from_start(scenario, traj)
    rho = scenario.control.safety_margin
    # A unicycle's body is judged by the disc about its point's chord that holds it over the
    # tick (body_reach, world/unicycle.py): never a contact missed, possibly one that was not.
    collisions = swept.obstacle_contacts(scenario.body_reach)
    collisions += swept.agent_contacts(scenario.body_reach)
    min_clearance = float(swept.clearance.min()) if swept.clearance.size else None
    min_mover_clearance = None
    if scenario.mover_ids:
        clear = clearances(scenario, traj)
        min_mover_clearance = float(clear[:, :, list(scenario.mover_ids)].min())
    min_distance = float(swept.separation.min())
    came = arrival(scenario, traj)
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
        min_interagent_distance=min_distance,
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
        at_speed_limit=at_speed_limit(scenario, traj),
        stalls=sum(h > STALL_TIME for h in held),
        longest_stall=max(held, default=0.0),
        leader_shortfall=norm(traj.positions[-1, 0] - goal),
        min_mover_clearance=min_mover_clearance,
        agent_at_fault=at_fault,
        obstacle_at_fault=len(touches) - at_fault,
        guard_margin=None if min_clearance is None else min_clearance - rho,
        separation_margin=min_distance - scenario.separation,
        contact_slack=swept.slack,
        arrived=came.arrived,
        arrival_time=came.time,
        arrival_tolerance=came.tolerance,
        not_arrived=came.cause,
        leader_trapped=came.cause == "leader trapped",
        slot_distance=came.slot_distance,
        livelocks=came.livelocks,
        longest_livelock=came.longest_livelock,
    )
