"""The scenario model: a frozen, validated description of one run.

Loaded from YAML by :mod:`shoal.world.loader`; checked against the paper's assumptions by
:mod:`shoal.world.assumptions`. Lengths in metres, times in seconds, angles in radians. Agent
ids are 1..n; agent 1 is the leader and its offset is zero.
"""

from __future__ import annotations

import functools
import math
import zlib
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from shoal.bus.types import (
    AgentConfig,
    Clock,
    ControlParams,
    Gains,
    LimitSide,
    PathSpec,
    Reshape,
    Vector,
    gains_of,
)
from shoal.geometry.vectors import FloatArray
from shoal.world.dynamics import Dynamics, DynamicsSetup, of_agents
from shoal.world.graph import adjacency, communication_graph, diameter
from shoal.world.limits import limit_sides, outer
from shoal.world.movers import Motion
from shoal.world.unicycle import arc_departure, speed_cap


@dataclass(frozen=True, slots=True)
class Obstacle:
    """A circular (spherical in 3-D) obstacle: standing, or moving by ``motion``
    (world/movers.py), in which case ``centre`` is where it starts."""

    centre: Vector
    radius: float
    motion: Motion | None = None

    @property
    def speed_cap(self) -> float:
        """u_max, m/s: the fastest it can move (0 standing)."""
        return 0.0 if self.motion is None else self.motion.speed_cap


@dataclass(frozen=True, slots=True)
class AgentSetup:
    """One agent: where it starts and its desired offset δ_i from the leader;
    ``given_initial``: its start is the file's ``initial`` (else path start + δ_i + noise)."""

    agent_id: int
    initial: Vector
    offset: Vector
    given_initial: bool = False
    heading: float = 0.0  # rad: a unicycle's initial heading (ignored for single integrators)
    single: bool = True  # a single integrator; False: a unicycle (the scenario's ``unicycle``)


# Realtime: ticks one round of Algorithm 1 may take. An agent acts on the freshest state it has
# of each neighbour, often a tick or more old (more on a loaded machine), so an epoch of L_G
# ticks ended before the maximum had spread and agents applied different σ.
REALTIME_TICKS_PER_ROUND = 4


@dataclass(frozen=True, slots=True, kw_only=True)
class Control(Gains):
    """The control section of a scenario: the :class:`~shoal.bus.types.Gains` and two values
    the scenario may leave to be derived (:meth:`Scenario.params` resolves them).

    speed_limit : m/s; None: the largest the safety theorem admits (:attr:`Scenario.speed_limit`).
    separation : m; None: 2ρ (each agent keeps ρ from the bisector).
    """

    speed_limit: float | None = None
    separation: float | None = None


@dataclass(frozen=True, slots=True)
class Unicycle:
    """Every agent a unicycle (world/unicycle.py): the point ``lookahead`` l m ahead of the axle
    follows the laws. ``max_speed`` |v| ≤ m/s and ``max_turn_rate`` |ω| ≤ rad/s; optionally
    differential-drive wheels of ``wheel_radius`` m on an ``axle`` m long, each turning at most
    ``max_wheel_speed`` rad/s."""

    lookahead: float
    max_speed: float
    max_turn_rate: float
    wheel_radius: float | None = None
    axle: float | None = None
    max_wheel_speed: float | None = None

    def limit(self) -> float:
        """m/s: the most |(v, l·ω)| may be so that every limit holds whatever the heading:
        |v| and l·|ω| are its parts, and a wheel's rim speed |v ± ω·axle/2| = |(v, l·ω)·(1, ±k)|,
        k = axle/(2l), is at most |(v, l·ω)|·√(1 + k²) (Cauchy–Schwarz; reached when
        (v, l·ω) ∥ (1, ±k))."""
        cap = min(self.max_speed, self.lookahead * self.max_turn_rate)
        if self.wheel_radius is not None and self.axle is not None and self.max_wheel_speed:
            rim = self.wheel_radius * self.max_wheel_speed
            cap = min(cap, rim / math.hypot(1.0, self.axle / (2.0 * self.lookahead)))
        return cap

    def point_speed_cap(self, dt: float) -> float:
        """m/s: the fastest the point may move in ticks of ``dt`` s so that every limit holds
        whatever the heading (world/unicycle.py, speed_cap)."""
        return speed_cap(self.limit(), self.lookahead, dt)

    def sides(self, dt: float) -> tuple[LimitSide, ...]:
        """Its limits as a polygon of the point's velocities in its body frame, for ticks of
        ``dt`` s (world/limits.py): what the safety filter meets as rows at each heading."""
        return _sides_of(self, dt)

    def any_direction(self, dt: float) -> float:
        """m/s: the fastest the point may move in every direction at once under its limits, in
        ticks of ``dt`` s: the polygon's nearest side (a little under :meth:`point_speed_cap`,
        the disc the exact limits hold, which the polygon does not quite reach)."""
        return min(side[2] for side in self.sides(dt))

    def fastest_point(self, dt: float) -> float:
        """m/s: the fastest the point may move in some direction under its limits, in ticks of
        ``dt`` s: the polygon's farthest vertex (straight ahead or back, for most robots), and
        never above l/dt (the exact arc map's range, docs/safety.md)."""
        return min(outer(self.sides(dt)), self.lookahead / dt)


@functools.lru_cache(maxsize=64)
def _sides_of(u: Unicycle, dt: float) -> tuple[LimitSide, ...]:
    wheels = u.wheel_radius is not None and u.axle is not None and u.max_wheel_speed
    return limit_sides(
        u.lookahead, u.max_speed, u.max_turn_rate, dt,
        rim=u.wheel_radius * u.max_wheel_speed if wheels else None,  # type: ignore[operator]
        half_axle=u.axle / 2.0 if wheels else None,  # type: ignore[operator]
    )  # fmt: skip


@dataclass(frozen=True, slots=True)
class RobotSetup:
    """The scenario's ``robots:`` section (docs/ros2.md): which ROS 2 robots its agents are
    when a run drives robots (``--robots ros2``), and how to reach them. A field the file leaves
    out is None (``connect``: empty); the command line's options win over the file's."""

    namespaces: tuple[str, ...] | None = None  # agent i's robot is namespaces[i - 1]
    domain: int | None = None  # ROS_DOMAIN_ID, 0–232
    connect: tuple[str, ...] = ()  # the robots' router, e.g. tcp/192.168.1.2:7447
    distro: str | None = None  # humble, jazzy, kilted or rolling
    pose: str | None = None  # odom (nav_msgs/Odometry) or pose (geometry_msgs/PoseStamped)
    pose_timeout: float | None = None  # s: an older pose holds its robot still


@dataclass(frozen=True)
class Scenario:
    """Everything needed to run and to judge one run."""

    name: str
    description: str
    dim: int
    dt: float
    duration: float
    seed: int
    agents: tuple[AgentSetup, ...]
    directed: bool
    edges: tuple[tuple[int, int], ...]
    path: PathSpec
    obstacles: tuple[Obstacle, ...]
    reshapes: tuple[Reshape, ...]
    control: Control
    agent_radius: (
        float  # m: two agents closer than 2× this, or an agent this close to an obstacle, collide
    )
    tolerance_factor: float  # formation converged when every error ≤ this × β·dt
    source: str = ""  # the YAML text it was loaded from
    unicycle: Unicycle | None = None  # None: single integrators (the paper's model)
    position_error: float = 0.0  # m: e, the bound of every robot's own position estimate's error
    robots: RobotSetup | None = None  # the ROS 2 robots its agents are (docs/ros2.md)
    dynamics: DynamicsSetup | None = None  # its robots' mass and drive, for a physics plant

    def robot_dynamics(self, preset: str | None = None) -> tuple[Dynamics, ...]:
        """Each agent's robot with mass (world/dynamics.py): the file's ``dynamics:`` section,
        its preset replaced by ``preset`` (``--dynamics``) if given."""
        chosen = (
            None
            if self.dynamics is None and preset is None
            else ((self.dynamics or DynamicsSetup()).resolve(preset))
        )
        where = "dynamics.preset" if preset is None else "--dynamics"
        return of_agents(chosen, tuple(not a.single for a in self.agents), self.dim, where)

    @cached_property
    def position_biases(self) -> FloatArray | None:
        """(n, dim) each robot's estimate's error b_i, m: constant over the run (a drift-free
        odometry from a bounded fix, docs/safety.md, Position error), uniform in the ball of
        radius ``position_error``, drawn from the scenario's seed; None when it is 0."""
        e = self.position_error
        if e == 0.0:
            return None
        rng = np.random.default_rng([self.seed, zlib.crc32(b"position-error")])
        way = rng.normal(size=(self.n, self.dim))
        way /= np.linalg.norm(way, axis=1, keepdims=True)
        return way * (e * rng.random((self.n, 1)) ** (1.0 / self.dim))

    @property
    def cell_separation(self) -> float:
        """m: what the safety filter keeps between the robots' *estimates*, 2R + 2e, so that
        the robots themselves keep 2R (docs/safety.md, Position error)."""
        return self.separation + 2.0 * self.position_error

    @property
    def n(self) -> int:
        return len(self.agents)

    @property
    def steps(self) -> int:
        """Number of ticks simulated."""
        return round(self.duration / self.dt)

    @property
    def tolerance(self) -> float:
        """Convergence tolerance, m: tolerance_factor · β · dt (the sign term's chattering band)."""
        return self.tolerance_factor * self.control.beta * self.dt

    @cached_property
    def adjacency(self) -> FloatArray:
        return adjacency(self.n, self.edges, directed=self.directed)

    @cached_property
    def rounds(self) -> int:
        """L_G, the diameter of the communication graph: rounds of Algorithm 1 per epoch."""
        return max(1, diameter(communication_graph(self.adjacency)))

    @property
    def offsets(self) -> FloatArray:
        """(n, dim) desired offsets δ, m."""
        return np.asarray([a.offset for a in self.agents], dtype=np.float64)

    @property
    def initial_positions(self) -> FloatArray:
        """(n, dim) initial positions, m (of a unicycle: its point, l ahead of the axle)."""
        return np.asarray([a.initial for a in self.agents], dtype=np.float64)

    @property
    def initial_headings(self) -> FloatArray:
        """(n,) initial headings, rad (unicycles)."""
        return np.asarray([a.heading for a in self.agents], dtype=np.float64)

    @property
    def lookahead(self) -> float | None:
        """l, m, for unicycles (their point ahead of the axle); None for single integrators."""
        return None if self.unicycle is None else self.unicycle.lookahead

    @property
    def lookaheads(self) -> FloatArray | None:
        """(n,) l per agent, m: the unicycles' lookahead, 0 for the single integrators of a
        mixed formation (world/unicycle.py moves those straight); None when every agent is a
        single integrator."""
        if self.unicycle is None:
            return None
        lookahead = self.unicycle.lookahead
        return np.asarray([0.0 if a.single else lookahead for a in self.agents], dtype=np.float64)

    @property
    def arc_departure(self) -> float:
        """m: how far a unicycle's point may be from where the straight step the safety filter
        certified would have it at the same instant, at v_max (world/unicycle.py); 0 for single
        integrators."""
        u = self.unicycle
        return 0.0 if u is None else arc_departure(self.speed_limit, u.lookahead, self.dt)

    @property
    def body_reach(self) -> float:
        """m: the radius about an agent's point that holds its body over any whole tick, which
        the safety filter's guards and cells must cover: ``agent_radius``, and for a unicycle
        also l (the body's centre is behind the point) and the point's departure from its
        straight step (world/unicycle.py)."""
        u = self.unicycle
        if u is None:
            return self.agent_radius
        return self.agent_radius + u.lookahead + self.arc_departure

    @cached_property
    def standing_ids(self) -> tuple[int, ...]:
        """Indices (in ``obstacles``) of the obstacles that do not move."""
        return tuple(k for k, o in enumerate(self.obstacles) if o.motion is None)

    @cached_property
    def mover_ids(self) -> tuple[int, ...]:
        """Indices (in ``obstacles``) of the moving obstacles (docs/people.md)."""
        return tuple(k for k, o in enumerate(self.obstacles) if o.motion is not None)

    @property
    def standing(self) -> tuple[Obstacle, ...]:
        return tuple(self.obstacles[k] for k in self.standing_ids)

    @property
    def obstacle_centres(self) -> FloatArray:
        """(m, dim) centres of the standing obstacles, m: what the nominal law and the paper's
        assumptions are about (moving ones: ``mover_ids``)."""
        return np.asarray([o.centre for o in self.standing], dtype=np.float64).reshape(
            len(self.standing_ids), self.dim
        )

    @property
    def obstacle_radii(self) -> FloatArray:
        """(m,) radii of the standing obstacles, m."""
        return np.asarray([o.radius for o in self.standing], dtype=np.float64)

    @property
    def u_max(self) -> float:
        """m/s: the fastest any obstacle moves (0 when every one stands)."""
        return max((o.speed_cap for o in self.obstacles), default=0.0)

    @property
    def formation_radius(self) -> float:
        """max_i ‖δ_i‖, m: radius of the leader-centred circle enclosing the formation."""
        return float(np.linalg.norm(self.offsets, axis=1).max())

    @property
    def separation(self) -> float:
        """2R, m: the distance the safety filter keeps between agents (default 2ρ)."""
        c = self.control
        return 2.0 * c.safety_margin if c.separation is None else c.separation

    @property
    def largest_step(self) -> float:
        """m: the longest step the safety theorem admits, min(d − r_max − ρ − u_max·dt,
        (d − 2R)/2), so that no obstacle or agent beyond the sensing radius can be reached in
        one tick, even one that walks towards the agent at u_max (docs/people.md)."""
        c = self.control
        r_max = max((o.radius for o in self.obstacles), default=0.0)
        reach = c.sensing_radius - r_max - c.safety_margin
        if self.u_max > 0.0:
            reach -= self.u_max * self.dt
        return min(reach, (c.sensing_radius - self.cell_separation) / 2)

    @property
    def speed_limit(self) -> float:
        """v_max, m/s: the control's, or by default the largest the theorem admits."""
        c = self.control
        if c.speed_limit is not None:
            return c.speed_limit
        largest = self.largest_step / self.dt
        if self.unicycle is None:
            return largest
        return min(largest, self.unicycle.fastest_point(self.dt))

    @cached_property
    def limits(self) -> tuple[tuple[LimitSide, ...], ...]:
        """Each agent's unicycle limits as the safety filter meets them (world/limits.py):
        empty for a single integrator; () when every agent is one."""
        u = self.unicycle
        if u is None:
            return ()
        sides = u.sides(self.dt)
        return tuple(() if a.single else sides for a in self.agents)

    def epoch_ticks(self, clock: Clock = Clock.LOCKSTEP) -> int:
        """Ticks per epoch of Algorithm 1 under ``clock``: L_G in lockstep; in realtime
        :data:`REALTIME_TICKS_PER_ROUND` times that, because an agent acts on neighbours'
        states that are often a tick or more old, so a round can take that many ticks."""
        return self.rounds * (REALTIME_TICKS_PER_ROUND if clock == Clock.REALTIME else 1)

    def params(self, clock: Clock = Clock.LOCKSTEP) -> ControlParams:
        return ControlParams(
            **gains_of(self.control),
            rounds=self.epoch_ticks(clock),
            speed_limit=self.speed_limit,
            separation=self.cell_separation,
        )

    def agent_config(self, agent_id: int, clock: Clock = Clock.LOCKSTEP) -> AgentConfig:
        """The configuration agent ``agent_id`` runs with under ``clock`` (what the world
        serves it)."""
        a = self.adjacency
        comm = communication_graph(a)
        i = agent_id - 1
        senses = tuple(int(j) + 1 for j in np.flatnonzero(a[i]))
        talks_to = tuple(int(j) + 1 for j in np.flatnonzero(comm[i]))
        return AgentConfig(
            agent_id=agent_id,
            dim=self.dim,
            dt=self.dt,
            params=self.params(clock),
            senses=senses if i > 0 else (),
            talks_to=talks_to,
            offset=self.agents[i].offset,
            neighbour_offsets=tuple(self.agents[j - 1].offset for j in senses) if i > 0 else (),
            formation_radius=self.formation_radius,
            path=self.path if i == 0 else None,
            reshapes=self.reshapes,
            limits=self.limits[i] if self.limits else (),
        )
