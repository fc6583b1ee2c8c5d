"""One agent's controller: Algorithm 2 around law (1)/(12), with Algorithm 1 running alongside.

A tick has two halves, because neighbours must hear each other before anyone moves:

1. ``announce(memory, sensing)``: from the world's sensing, decide Ω_i and the σ bid and produce
   the state this agent tells its neighbours.
2. ``act(memory, sensing, neighbour_states)``: with the neighbours' states of the same tick, drop
   the edges to evading neighbours, compute the nominal v̂_i, pass it through the safety filter
   (geometry/safety.py; unless ``safety: paper``), take one consensus round, produce the command.

Both are pure: memory in, memory out. The agent process and the reference simulator call exactly
these two methods, which is why a lockstep distributed run can equal the simulator bit for bit.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Final

from shoal.agent.collision import Evasion, collision_course, evasive_offset, ray_distance
from shoal.agent.consensus import consensus_round, epoch_of, epoch_start, passage_bid
from shoal.agent.formation import consensus_error, evasive_error, velocity
from shoal.agent.leader import Known, lead, remember, steer
from shoal.bus.messages import AgentState, Command, Sensing, picklable
from shoal.bus.types import AgentConfig, Waypoints
from shoal.geometry.path import leader_velocity
from shoal.geometry.safety import SafetyFilter, cap_to_limits
from shoal.geometry.vectors import Vector, VectorLike, norm, segment_distance, shaped_vector, sub


@dataclass(init=False, slots=True, unsafe_hash=True)
class Memory:
    """What an agent carries from one tick to the next.

    smoothed : (dim,) m/s, low-pass filtered own velocity; the ray of (11) runs along it.
    evasion : the evasive episode in force (Ω_i = 1), or None.
    bid : this agent's current value in Algorithm 1.
    sigma_consensus : the factor agreed in the last finished epoch, applied now.
    busy : ticks in a row this follower has been busy (evading, filtered or far from its slot).
    calm : ticks in a row it has not been busy, counted up to CALM_TAUS heading time constants.
    route : a leader's waypoints still to go (with the safety filter), else None.
    planned : how many of ``route``'s first points are a detour's vertices (agent/leader.py).
    known : the standing obstacles a leader with a route has sensed so far (agent/leader.py).
    """

    smoothed: Final[Vector]
    evasion: Final[Evasion | None]
    bid: Final[float]
    sigma_consensus: Final[float]
    busy: Final[int]
    route: Final[tuple[Vector, ...] | None]
    calm: Final[int]
    planned: Final[int]
    known: Final[Known]

    def __init__(
        self,
        smoothed: Vector,
        evasion: Evasion | None,
        bid: float,
        sigma_consensus: float,
        busy: int = 0,
        route: tuple[Vector, ...] | None = None,
        calm: int = 0,
        planned: int = 0,
        known: Known = (),
    ) -> None:
        self.smoothed = smoothed
        self.evasion = evasion
        self.bid = bid
        self.sigma_consensus = sigma_consensus
        self.busy = busy
        self.route = route
        self.calm = calm
        self.planned = planned
        self.known = known


picklable(Memory)

# With the safety filter u^o grows to at most this many times r_j + ρ + ε (agent/collision.py):
# twice what a ray through the centre needs.
RATCHET_CAP = 2.0
# s: the longest a busy follower abstains from bidding for a contraction (see Memory.busy).
BUSY_TIME = 5.0
# A follower is far from its slot (busy) while ‖e_i‖∞ / deg_i exceeds this many β·dt: the
# sign term's chattering band (the default convergence tolerance).
BUSY_BAND = 10.0
# Heading time constants: after being busy a follower bids again only once it has been calm this
# long, when what is left of its manoeuvre in its heading (e^-3 of it) no longer steers its bid.
CALM_TAUS = 3.0


class Controller:
    """The control laws of one agent, parameterised once by its :class:`AgentConfig`."""

    def __init__(self, config: AgentConfig) -> None:
        self.config = config
        self.params = config.params
        self.filtered = self.params.filtered
        self.safety = SafetyFilter.of(self.params, config.agent_id, config.dt, config.limits)
        self.offset = tuple(float(x) for x in config.offset)
        self.neighbour_offsets = tuple(tuple(float(x) for x in d) for d in config.neighbour_offsets)
        tau = self.params.heading_tau
        self.smoothing = 1.0 if tau <= 0 else 1.0 - math.exp(-config.dt / tau)
        self.listens_to = tuple(sorted(set(config.senses) | set(config.talks_to)))
        self._shapes: dict[tuple[float, float], tuple[Vector, tuple[Vector, ...]]] = {}
        self.busy_ticks = round(BUSY_TIME / config.dt)
        self.busy_error = BUSY_BAND * self.params.beta * config.dt
        self.calm_ticks = math.ceil(CALM_TAUS * tau / config.dt)
        # m/s: with the safety filter, a heading slower than this has no direction (announce).
        k = self.smoothing
        self.still_below = 0.0
        if self.filtered and k < 1.0:
            self.still_below = self.params.beta * math.sqrt(config.dim * k / (2.0 - k))

    def _shaped(self, sigma: float, theta: float) -> tuple[Vector, tuple[Vector, ...]]:
        """R(θ)δ/σ of this agent and of its sensed neighbours, computed once per (σ, θ)."""
        key = (sigma, theta)
        found = self._shapes.get(key)
        if found is None:
            if len(self._shapes) > 32:
                self._shapes.clear()
            found = (
                shaped_vector(self.offset, sigma=sigma, theta=theta),
                tuple(shaped_vector(d, sigma=sigma, theta=theta) for d in self.neighbour_offsets),
            )
            self._shapes[key] = found
        return found

    def start(self) -> Memory:
        """The memory before tick 0: at rest, not evading, bidding 1, unscaled; a leader with
        the safety filter and waypoints has all of them but the first (where it starts) to go."""
        path = self.config.path
        route = None
        if self.filtered and isinstance(path, Waypoints):
            route = tuple([tuple([float(x) for x in p]) for p in path.points[1:]])
        return Memory(
            smoothed=(0.0,) * self.config.dim,
            evasion=None,
            bid=1.0,
            sigma_consensus=1.0,
            route=route,
            calm=self.calm_ticks,
        )

    def shape(self, tick: int, sigma_consensus: float) -> tuple[float, float]:
        """(σ, θ) applied at ``tick``: the demanded reshape times the agreed contraction."""
        scale, rotate = 1.0, 0.0
        for r in self.config.reshapes:
            if r.tick <= tick:
                scale, rotate = r.scale, r.rotate
        return scale * sigma_consensus, rotate

    def announce(self, memory: Memory, sensing: Sensing) -> tuple[Memory, AgentState]:
        """First half of a tick: Ω_i (11) and the σ bid; returns the state for the neighbours."""
        p = self.params
        tick = sensing.tick
        position, centres, radii = (
            sensing.position,
            sensing.obstacle_centres,
            sensing.obstacle_radii,
        )
        bid, agreed = memory.bid, memory.sigma_consensus
        ray = self._direction(memory.smoothed)
        if epoch_start(tick, p.rounds):
            if tick > 0:
                agreed = memory.bid
            demanded, theta = self.shape(tick, 1.0)
            slot_shift = sub(
                self._shaped(demanded, theta)[0],
                self._shaped(demanded * memory.sigma_consensus, theta)[0],
            )
            manoeuvring = self.filtered and (
                0 < memory.busy <= self.busy_ticks
                or (memory.busy == 0 and memory.calm < self.calm_ticks)
            )
            bid = (
                1.0
                if manoeuvring
                else passage_bid(
                    position,
                    ray,
                    centres,
                    radii,
                    formation_radius=self.config.formation_radius / demanded,
                    slot_shift=slot_shift,
                    safety_margin=p.safety_margin,
                    epsilon=p.epsilon,
                    sigma_max=p.sigma_max,
                    strict=self.filtered,
                )
            )
        evasion = None
        if not self.config.is_leader:
            evasion = collision_course(
                position,
                ray,
                sensing.obstacle_ids,
                centres,
                radii,
                memory.evasion,
                trigger_radius=p.trigger_radius,
                sensing_radius=p.sensing_radius,
                safety_margin=p.safety_margin,
                epsilon=p.epsilon,
                ratchet_cap=RATCHET_CAP if self.filtered else math.inf,
            )
        memory = Memory(
            memory.smoothed,
            evasion,
            bid,
            agreed,
            busy=memory.busy,
            route=memory.route,
            calm=memory.calm,
            planned=memory.planned,
            known=memory.known,
        )
        sigma, theta = self.shape(tick, agreed)
        state = AgentState(
            agent_id=self.config.agent_id,
            tick=tick,
            position=sensing.position,
            omega=evasion is not None,
            bid=bid,
            sigma=sigma,
            theta=theta,
        )
        return memory, state

    def _direction(self, smoothed: Vector) -> Vector:
        """The direction along which (11)'s ray and Algorithm 1's look-ahead run: none (zero)
        while it is slower than the sign term's chatter leaves in it at rest.

        ``smoothed`` is the agent's own velocity low-pass filtered with k = 1 − e^(−dt/τ). At
        rest in its slot a follower's velocity is the sign term's chatter, ±β per coordinate,
        whose filtered sum keeps a standard deviation of β·√(dim·k/(2 − k)) for independent
        signs: a heading that points anywhere. Rays along it found obstacles beside the goal
        slots and Algorithm 1 passages there: formations that had arrived evaded and contracted
        again and again (on the hard fields, tools/campaign/hard.py, most of the 14 % that never
        arrived: Ω set hundreds of times and σ at σ_max in the last 10 s, the filter idle).
        Below that speed the agent is taken to have no direction of motion, as
        :func:`~shoal.agent.collision.ray_distance` already takes one below 1e-9 m/s: no ray, no
        collision course, no passage ahead. A formation on the move is faster than its chatter
        floor once β·dt is small against its speed; with ``heading_tau`` 0 (no filtering) or
        ``safety: paper`` nothing is gated (the paper's (11), bit for bit)."""
        if self.still_below > 0.0 and norm(smoothed) < self.still_below:
            return (0.0,) * len(smoothed)
        return smoothed

    def _reaimed(self, held: Evasion, position: Vector, target: Vector) -> Evasion:
        """An episode whose follower has come to rest off its slot, re-aimed at where it wants
        to go: u^o taken across the way from the follower to its set-point, not across a
        heading that is gone.

        u^o is perpendicular to the heading at τ_i. A follower the evasion brought to rest
        below an obstacle that stands between it and its slot has no heading (below the
        chatter floor) and the obstacle still in the way: the episode lasted, the set-point
        stayed shifted by the same u^o, and the follower stood there for good, its
        neighbours held with it (hard fields: 2 of the 12 that still did not arrive)."""
        p = self.params
        offset = evasive_offset(
            position,
            sub(target, position),
            held.centre,
            held.radius,
            safety_margin=p.safety_margin,
            epsilon=p.epsilon,
        )
        return Evasion(held.obstacle_id, held.centre, held.radius, offset)

    def _in_band(self, lag: float) -> bool:
        """Whether a follower is within the sign term's chattering band of its set-point
        (‖e_i‖∞/deg_i ≤ BUSY_BAND·β·dt), where its nominal is the chatter and says nothing of a
        way round an obstacle: the filter's :func:`~shoal.geometry.safety.keep_going` is not for it.

        Keep-going turns a follower pressed against a guard circle on the way it was going, for
        a slot that lies behind the obstacle, where the projection's tangential part flips with
        the chatter. A slot on or just outside the guard circle is reached along the circle
        itself, and there the tangential part flips because the follower passed its slot: kept
        going, it ran on round the circle and back for good (measured on the hard fields: 19
        of 44 that never arrived, followers 1–2.7 m off slots 0.007–0.08 m outside r + ρ,
        moving at 4–9 m/s). A leader has no slot and is never in the band."""
        return self.config.path is None and lag <= self.busy_error

    def act(
        self, memory: Memory, sensing: Sensing, neighbours: Mapping[int, AgentState]
    ) -> tuple[Memory, Command]:
        """Second half of a tick: v_i from (1) or (12) with Algorithm 2's edge dropping.

        ``neighbours`` maps id to the state announced this tick; a neighbour that is missing
        (gone) or evading (Ω_j = 1) is not followed this tick.
        """
        cfg, p = self.config, self.params
        evasion, lag, route, planned = memory.evasion, 0.0, memory.route, memory.planned
        known = memory.known
        v: VectorLike
        if route is not None and isinstance(cfg.path, Waypoints):
            known = remember(
                known, sensing.obstacle_ids, sensing.obstacle_centres, sensing.obstacle_radii
            )
            v, route, planned = self._lead(
                route, planned, known, sensing, cfg.path.speed, cfg.path.reach
            )
        elif cfg.path is not None:
            v = leader_velocity(cfg.path, sensing.tick, cfg.dt)
        else:
            v, evasion, lag = self._follow(memory, sensing, neighbours)
        out = tuple([float(c) for c in v])
        filtered = False
        if self.filtered:
            previous = None if self._in_band(lag) else memory.smoothed
            result = self.safety(out, sensing, previous=previous)
            if result.active:
                out, filtered = result.velocity, True
        elif cfg.limits:  # safety: paper on a unicycle: no filter, but its wheels' own limits
            out = cap_to_limits(out, cfg.limits, sensing.heading)  # (docs/safety.md, paper)
        epoch = epoch_of(sensing.tick, p.rounds)
        bids = [
            neighbours[j].bid
            for j in cfg.talks_to
            if j in neighbours and epoch_of(neighbours[j].tick, p.rounds) == epoch
        ]  # realtime: a state from the last epoch carries a value Algorithm 1 has reset
        busy = 0
        if self.filtered and (evasion is not None or filtered or lag > self.busy_error):
            busy = memory.busy + 1
        k = self.smoothing
        memory = Memory(
            smoothed=tuple([h + k * (x - h) for h, x in zip(memory.smoothed, out)]),
            evasion=evasion,
            bid=consensus_round(memory.bid, bids),
            sigma_consensus=memory.sigma_consensus,
            busy=busy,
            route=route,
            calm=0 if busy else min(memory.calm + 1, self.calm_ticks),
            planned=planned,
            known=known,
        )
        command = Command(agent_id=cfg.agent_id, tick=sensing.tick, velocity=out, filtered=filtered)
        return memory, command

    def _lead(
        self,
        route: tuple[Vector, ...],
        planned: int,
        known: Known,
        sensing: Sensing,
        speed: float,
        reach: float,
    ) -> tuple[Vector, tuple[Vector, ...], int]:
        """The leader's nominal with the safety filter: round any obstacle it has seen that its
        next leg would cross (keeping r_j + 2ρ + ε from the centre), re-planned when an obstacle
        comes into view across the detour ahead, then on to the next waypoint; the route left
        and how many of its first points are the detour's."""
        p = self.params
        route, planned = steer(
            sensing.position,
            route,
            planned,
            [c for _, c, _ in known],
            [r for _, _, r in known],
            guard=p.safety_margin,
            clearance=p.safety_margin + p.epsilon,
            reach=reach,
        )
        v, route = lead(sensing.position, route, speed, self.config.dt, reach=reach)  # steer
        return v, route, planned  # dropped what is reached here: lead drops nothing more

    def _follow(
        self, memory: Memory, sensing: Sensing, neighbours: Mapping[int, AgentState]
    ) -> tuple[Vector, Evasion | None, float]:
        """The nominal v̂_i of a follower, the evasion to carry into the next tick, and (with
        the safety filter) how far the plain law's set-point s_i − e_i/deg_i, where (1) without
        u^o pulls the agent, is per coordinate: ‖e_i‖∞/deg_i (m; 0 without neighbours).

        With the safety filter an episode also ends once the straight way to that set-point no
        longer comes within the obstacle's guard r_j + ρ, the circle the filter keeps: the obstacle
        is no longer in the way. (Tested against r_j + ρ + ε, a final slot less than ε outside r_j +
        ρ kept its follower evading, off the slot by u^o, for good: 6 of the hard fields that never
        arrived.) (11)'s hold-on lasts until the obstacle is passed along the heading: an agent of a
        formation that has stopped has no heading, and one that the filter slides round a guard
        circle has its heading along the circle, so such episodes never ended, kept the agent off
        its slot and its neighbours' edges to it dropped, for good, and the shifted set-point could
        lie inside the obstacle, the agent going round and round it (both measured, docs/safety.md).
        If the heading still points at the obstacle, (11) fires again at the next tick, with a fresh
        u^o measured from where the agent is now. An agent in its slot (‖e_i‖∞/deg_i within the
        chattering band) keeps (11)'s rule: there the heading is the formation's, and a heading
        below the chatter floor has no ray (:meth:`_direction`, as (11) itself is evaluated). The
        set-point, not the direction of (1), is tested: near the slot the sign term turns that
        direction every tick. The paper mode keeps episodes as (11) has them.

        With the safety filter a follower whose neighbours all evade follows them all the same,
        where Algorithm 2 would leave it with no neighbour and so standing still (Assumption 2
        broken in the run). Measured: such a follower stood still behind the formation for good,
        and pulled its evading neighbours' set-points back into their obstacles, so their
        episodes never ended either. Following evading neighbours costs shape, never safety: the
        filter keeps that.
        """
        cfg, p = self.config, self.params
        keep = [k for k, j in enumerate(cfg.senses) if j in neighbours and not neighbours[j].omega]
        if self.filtered and not keep:  # every neighbour evades: follow them all the same
            keep = [k for k, j in enumerate(cfg.senses) if j in neighbours]
        sigma, theta = self.shape(sensing.tick, memory.sigma_consensus)
        positions = [neighbours[cfg.senses[k]].position for k in keep]
        own, theirs = self._shaped(sigma, theta)
        position = sensing.position
        error = consensus_error(position, own, positions, [theirs[k] for k in keep])
        target, lag = None, 0.0
        if self.filtered and keep:
            degree = len(keep)
            target = tuple([x - e / degree for x, e in zip(position, error)])
            lag = max([abs(e) for e in error]) / degree
        held = memory.evasion
        if held is not None and target is not None:
            guard = held.radius + p.safety_margin
            ray = self._direction(memory.smoothed)
            away = not self._in_band(lag)
            if segment_distance(held.centre, position, target) > guard and (
                away or ray_distance(position, ray, held.centre) > guard + p.epsilon
            ):
                held = None
            elif away and not any(ray):
                held = self._reaimed(held, position, target)
        if held is not None:
            error = evasive_error(error, len(keep), held.offset)
        v = velocity(error, alpha=p.alpha, beta=p.beta, boundary_layer=p.boundary_layer)
        return v, held, lag
