"""The types that cross process boundaries: the configuration an agent runs with (this module)
and the messages of every tick (bus/messages.py).

`agent` and `world` never import each other; everything they share lives here. All vectors are
tuples of floats in metres (positions, offsets) or metres per second (velocities) in the world
frame, of length ``dim`` (2 or 3). Ticks are integers; simulated time is ``tick * dt`` seconds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields
from enum import StrEnum
from typing import Any

from shoal.bus.errors import ConfigError

Vector = tuple[float, ...]
# One side of a unicycle's limits as a polygon of its point's velocities in its body frame
# (world/limits.py): (n_x, n_y, c, nearest), the polygon n·w ≤ c with n a unit vector; nearest,
# m/s: how close the side's edge comes to standing still.
LimitSide = tuple[float, float, float, float]


class Safety(StrEnum):
    """How an agent's command is made safe (docs/safety.md)."""

    FILTER = (
        "filter"  # the nominal law, capped and projected by the safety filter (geometry/safety.py)
    )
    PAPER = "paper"  # the paper's Algorithm 2 alone, unfiltered


STALE_AFTER = 5
"""Realtime: ticks after which the world's watchdog applies no command of an agent (a command
of tick t is held at tick k > t + STALE_AFTER: world/process.py). The same figure bounds how far
a neighbour's state may run ahead of an agent's own last sensing (agent/process.py): an agent
whose sensing is that late, or lost that many ticks in a row, still has its commands applied, so
a neighbour that far ahead is news, not a bad message."""


class Clock(StrEnum):
    """How a run's ticks advance (docs/wire.md)."""

    LOCKSTEP = "lockstep"  # the world waits for every agent's command: exact, as the reference
    REALTIME = "realtime"  # ticks on the wall clock; a late command is held


class SafetyLayer(StrEnum):
    """What stands between each agent's command and its robot's motion (docs/safety.md,
    Realtime and Without a referee). In lockstep every command is already safe for the tick it
    is applied at, and the referee changes nothing."""

    REFEREE = "referee"  # filters it again with every agent's true position at that tick
    ONBOARD = "onboard"  # each robot's own layer, knowing what it knows (world/onboard.py)
    NONE = "none"  # applied as sent; the world counts what a referee would have changed
    # The referee for robots with mass: each step from what the robot can reach, given its pose's
    # age, the commands it was sent and its body's bounds (world/reach_layer.py)
    REACH = "reach"

    @classmethod
    def of(cls, layer: SafetyLayer | None, clock: Clock) -> SafetyLayer:
        """``layer``, or by default onboard in realtime and the referee in lockstep (where
        every command is already safe for its tick and the referee changes nothing)."""
        if layer is not None:
            return layer
        return cls.ONBOARD if clock == Clock.REALTIME else cls.REFEREE


@dataclass(frozen=True, slots=True, kw_only=True)
class Gains:
    """Gains and thresholds of the paper's control laws, as a scenario gives them and as every
    agent of a run uses them (the two views below add what each side needs).

    alpha, beta : gains of law (1), 1/s and m/s; finite-time convergence needs |f| < beta.
    sensing_radius : d, m; an obstacle whose centre is within d of an agent is sensed.
    trigger_radius : d̄ < d, m; the collision-course flag (11) only fires within d̄.
    epsilon : ε, m; tolerance of the ray test in (11).
    safety_margin : ρ, m; clearance that the evasive offset and the passage bid keep.
    heading_tau : s; time constant of the heading filter that defines "the ray along v_i".
    sigma_max : largest contraction factor an agent will bid (an impassable gap bids this).
    boundary_layer : m; 0 gives the paper's sign(e); φ > 0 uses sat(e/φ) instead.
    safety : :class:`Safety`.
    """

    alpha: float
    beta: float
    sensing_radius: float
    trigger_radius: float
    epsilon: float
    safety_margin: float
    heading_tau: float
    sigma_max: float
    boundary_layer: float = 0.0
    safety: Safety = Safety.FILTER

    @property
    def filtered(self) -> bool:
        return self.safety == Safety.FILTER


def gains_of(g: Gains) -> dict[str, Any]:
    """The :class:`Gains` fields of ``g`` (of either view), to build the other view from."""
    return {f.name: getattr(g, f.name) for f in fields(Gains)}


@dataclass(frozen=True, slots=True, kw_only=True)
class ControlParams(Gains):
    """The gains every agent of a run uses, with what the scenario derives resolved.

    rounds : ticks per epoch of Algorithm 1: L_G, the diameter of the communication graph (in
        realtime a multiple of it).
    speed_limit : v_max, m/s; the nominal velocity is capped at it before filtering.
    separation : 2R, m; the distance the safety filter keeps between any two agents.
    """

    rounds: int
    speed_limit: float = 1e9
    separation: float = 0.4


REACHED = 1e-9  # m: the reach of a simulated leader (Waypoints.reach)


@dataclass(frozen=True, slots=True)
class Waypoints:
    """The leader visits ``points`` in order along straight legs at ``speed`` m/s, then stops.

    A point counts as visited once the leader is within ``reach`` m of it. Simulated, the
    leader's last step lands on the point, so 1 nm does; a real robot, seen through late poses
    and moved by commands held for a tick, overshoots and is sent back without end (measured
    with ROS 2 robots, docs/ros2.md), so the world serves a tick's travel when it drives robots
    (world/process.py)."""

    points: tuple[Vector, ...]
    speed: float
    reach: float = REACHED


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
    limits : a unicycle's speed, turn-rate and wheel limits as a polygon of its point's
        velocities in its body frame (world/limits.py); empty for a single integrator.
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
    limits: tuple[LimitSide, ...] = ()

    def __post_init__(self) -> None:
        problem = config_problem(self)
        if problem is not None:
            raise ConfigError(*problem)

    @property
    def is_leader(self) -> bool:
        return self.path is not None


def config_problem(c: AgentConfig) -> tuple[str, str] | None:
    """What is wrong with an agent's configuration, as (field, message), or None.

    The one check of an :class:`AgentConfig`, run once, when one is made (from a scenario, from
    the wire, by hand): an invalid configuration cannot exist, so nothing that takes one checks
    it again."""
    if c.dim not in (2, 3):
        return "dim", f"must be 2 or 3, got {c.dim}"
    if not c.dt > 0:
        return "dt", f"must be > 0 s, got {c.dt}"
    if len(c.offset) != c.dim:
        return "offset", f"has {len(c.offset)} coordinates, dim is {c.dim}"
    if len(c.neighbour_offsets) != len(c.senses):
        return "neighbour_offsets", "not one per agent in senses"
    if any(len(o) != c.dim for o in c.neighbour_offsets):
        return "neighbour_offsets", f"every offset needs {c.dim} coordinates"
    path = c.path
    points = () if path is None else (
        path.points if isinstance(path, Waypoints) else (path.start, path.direction, path.normal)
    )  # fmt: skip
    if any(len(v) != c.dim for v in points):
        return "path", f"every point and direction needs {c.dim} coordinates"
    if isinstance(path, Waypoints) and not 0 < path.reach < math.inf:
        return "path.reach", f"must be > 0 m and finite, got {path.reach}"
    if c.limits and c.dim != 2:
        return "limits", "a unicycle's limits are for the plane (dim 2)"
    for k, (nx, ny, bound, nearest) in enumerate(c.limits):
        unit = abs(math.hypot(nx, ny) - 1.0) < 1e-9
        if not (unit and 0 < bound <= nearest * (1 + 1e-9) < math.inf):
            return f"limits[{k}]", "needs a unit normal and 0 < c ≤ nearest, finite"
    p = c.params
    positive = ("alpha", "beta", "sensing_radius", "trigger_radius", "sigma_max", "speed_limit",
                "separation")  # fmt: skip
    for name in positive:
        if not getattr(p, name) > 0:
            return f"params.{name}", f"must be > 0, got {getattr(p, name)}"
    if p.safety not in tuple(Safety):
        return "params.safety", f"must be filter or paper, got {p.safety!r}"
    if p.rounds < 1:
        return "params.rounds", f"must be ≥ 1 (the graph diameter), got {p.rounds}"
    return None
