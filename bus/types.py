"""The types that cross process boundaries: what the world tells an agent, what agents tell
each other, what an agent tells the world, and the configuration an agent runs with.

`agent` and `world` never import each other; everything they share lives here. All vectors are
tuples of floats in metres (positions, offsets) or metres per second (velocities) in the world
frame, of length ``dim`` (2 or 3). Ticks are integers; simulated time is ``tick * dt`` seconds.
"""

from __future__ import annotations

from dataclasses import dataclass, field

Vector = tuple[float, ...]


@dataclass(frozen=True, slots=True)
class ControlParams:
    """Gains and thresholds of the paper's control laws, shared by every agent of a run.

    alpha, beta : gains of law (1), 1/s and m/s; finite-time convergence needs |f| < beta.
    safety : "filter" (the nominal law, capped at ``speed_limit`` and projected by the safety
        filter, bus/safety.py) or "paper" (the paper's Algorithm 2 alone, unfiltered).
    speed_limit : v_max, m/s; the nominal velocity is capped at it before filtering.
    separation : 2R, m; the distance the safety filter keeps between any two agents.
    sensing_radius : d, m; an obstacle whose centre is within d of an agent is sensed.
    trigger_radius : d̄ < d, m; the collision-course flag (11) only fires within d̄.
    epsilon : ε, m; tolerance of the ray test in (11).
    safety_margin : ρ, m; clearance that the evasive offset and the passage bid keep.
    heading_tau : s; time constant of the heading filter that defines "the ray along v_i".
    sigma_max : largest contraction factor an agent will bid (an impassable gap bids this).
    rounds : L_G, the diameter of the communication graph: rounds of Algorithm 1 per epoch.
    boundary_layer : m; 0 gives the paper's sign(e); φ > 0 uses sat(e/φ) instead.
    """

    alpha: float
    beta: float
    sensing_radius: float
    trigger_radius: float
    epsilon: float
    safety_margin: float
    heading_tau: float
    sigma_max: float
    rounds: int
    boundary_layer: float = 0.0
    safety: str = "filter"
    speed_limit: float = 1e9
    separation: float = 0.4

    @property
    def filtered(self) -> bool:
        return self.safety == "filter"


@dataclass(frozen=True, slots=True)
class Waypoints:
    """The leader visits ``points`` in order along straight legs at ``speed`` m/s, then stops."""

    points: tuple[Vector, ...]
    speed: float


@dataclass(frozen=True, slots=True)
class Sinusoid:
    """p(t) = start + direction·speed·t + normal·amplitude·sin(2π t / period).

    ``direction`` and ``normal`` are unit vectors, perpendicular to each other.
    """

    start: Vector
    direction: Vector
    normal: Vector
    speed: float
    amplitude: float
    period: float


PathSpec = Waypoints | Sinusoid


@dataclass(frozen=True, slots=True)
class Reshape:
    """From ``tick`` on, the demanded formation is R(rotate)·δ / scale (Remark 2, (8)-(9))."""

    tick: int
    scale: float
    rotate: float  # rad, about the z axis in 3-D


@dataclass(frozen=True, slots=True)
class AgentConfig:
    """Everything one agent needs to run; built by the world from a scenario.

    senses : ids j with A_ij = 1 (row i of the sensing adjacency), ascending.
    talks_to : ids that exchange σ bids with this agent (the undirected communication graph).
    offset : δ_i, m. neighbour_offsets : δ_j for every j in ``senses``, same order.
    formation_radius : max_j ‖δ_j‖, m: radius of the leader-centred circle enclosing the
        nominal formation (the paper's "diameter of the circle that encloses the formation" / 2).
    path : the leader's path; None for followers.
    """

    agent_id: int
    dim: int
    dt: float
    params: ControlParams
    senses: tuple[int, ...]
    talks_to: tuple[int, ...]
    offset: Vector
    neighbour_offsets: tuple[Vector, ...]
    formation_radius: float
    path: PathSpec | None = None
    reshapes: tuple[Reshape, ...] = field(default_factory=tuple)

    @property
    def is_leader(self) -> bool:
        return self.path is not None


@dataclass(frozen=True, slots=True)
class Sensing:
    """World → agent at the start of tick ``tick``: where the agent is and what it senses.

    obstacle_centres : (m, dim) metres; obstacle_radii : (m,) metres, in obstacle-id order.
    agent_ids, agent_positions : the other agents within the sensing radius and where they are
        at the start of this same tick, (q, dim) metres, in id order (the safety filter's rows).
    """

    tick: int
    position: Vector
    obstacle_ids: tuple[int, ...]
    obstacle_centres: tuple[Vector, ...]
    obstacle_radii: tuple[float, ...]
    agent_ids: tuple[int, ...] = ()
    agent_positions: tuple[Vector, ...] = ()


@dataclass(frozen=True, slots=True)
class AgentState:
    """Agent → its neighbours at tick ``tick``: position (m), collision-course flag Ω_i, the
    current value of its σ bid in Algorithm 1, and the scale σ and rotation θ (rad) it applies.
    """

    agent_id: int
    tick: int
    position: Vector
    omega: bool
    bid: float
    sigma: float
    theta: float


@dataclass(frozen=True, slots=True)
class Command:
    """Agent → world: the velocity v_i (m/s) to hold during tick ``tick``; ``filtered``: the
    agent's safety filter changed its nominal velocity to get it."""

    agent_id: int
    tick: int
    velocity: Vector
    filtered: bool = False


@dataclass(frozen=True, slots=True)
class TickRecord:
    """World → all, once per tick: the ground truth of tick ``tick``.

    positions (n, dim) m at the start of the tick and velocities (n, dim) m/s held during it, as
    nested tuples in agent-id order; omega, bid, sigma, theta as each agent announced them; alive
    False for an agent the world holds still because its process is gone; filtered True where
    the agent's safety filter changed its nominal velocity that tick.
    """

    tick: int
    positions: tuple[Vector, ...]
    velocities: tuple[Vector, ...]
    omega: tuple[bool, ...]
    bid: tuple[float, ...]
    sigma: tuple[float, ...]
    theta: tuple[float, ...]
    alive: tuple[bool, ...]
    filtered: tuple[bool, ...]


@dataclass(frozen=True, slots=True)
class Event:
    """World → all: a line for the log. level: 1 debug, 2 info, 3 warning, 4 error (as
    foxglove.Log); agent: the agent it is about, 0 if none."""

    tick: int
    level: int
    agent: int
    text: str
