"""The messages of a tick: what the world tells an agent (:class:`Sensing`, with the
:class:`Mover` s it senses), what agents tell each other (:class:`AgentState`), what an agent tells
the world (:class:`Command`), and what the world tells everyone (:class:`TickRecord`,
:class:`Event`). Vectors and units as in bus/types.py; docs/wire.md has their encoding.

They are made every tick, so they (and ``Memory``, ``Filtered``, ``Row`` and ``Evasion`` in
the compiled modules) are dataclasses with their own ``__init__`` and ``Final`` fields instead of
``frozen=True``: a frozen dataclass sets each field through ``object.__setattr__``, 2.4 µs for
a 7-field record made from compiled code, against 0.1 µs for a compiled ``__init__`` (0.6
interpreted). They are as immutable to mypy, and in the compiled build at run time too (a
``Final`` attribute of a compiled class is read-only); dataclasses still give them ``==``,
``hash``, ``repr``, ``fields`` and ``replace``, and :func:`picklable` pickling and copying (a
compiled class with its own ``__init__`` has no other way back).
"""

from __future__ import annotations

import copyreg
from dataclasses import dataclass, fields
from typing import Any, Final

from shoal.bus.types import Vector


@dataclass(init=False, slots=True, unsafe_hash=True)
class Mover:
    """A moving obstacle (a person, a cart) as an agent senses it at the start of a tick.

    obstacle_id : its index in the scenario's obstacles; centre (m) and velocity (m/s) at the
    start of the tick, the velocity it holds over the tick (the world reports the truth; a real
    sensor's estimate would carry its error, docs/people.md); radius, m; speed_cap u_max, m/s:
    the fastest it can move, which the safety filter's row assumes, whatever its velocity.
    """

    obstacle_id: Final[int]
    centre: Final[Vector]
    radius: Final[float]
    velocity: Final[Vector]
    speed_cap: Final[float]

    def __init__(
        self, obstacle_id: int, centre: Vector, radius: float, velocity: Vector, speed_cap: float
    ) -> None:
        self.obstacle_id = obstacle_id
        self.centre = centre
        self.radius = radius
        self.velocity = velocity
        self.speed_cap = speed_cap


@dataclass(init=False, slots=True, unsafe_hash=True)
class Sensing:
    """World → agent at the start of tick ``tick``: where the agent is and what it senses.

    obstacle_centres : (m, dim) metres; obstacle_radii : (m,) metres, in obstacle-id order: the
        standing obstacles, which the nominal law (Algorithm 2, the leader's detour) plans round.
    agent_ids, agent_positions : the other agents within the sensing radius and where they are
        at the start of this same tick, (q, dim) metres, in id order (the safety filter's rows).
    movers : the moving obstacles within the sensing radius, in obstacle-id order; only the
        safety filter acts on them (docs/people.md).
    heading : rad, a unicycle's heading at the start of the tick (0 for a single integrator):
        the safety filter meets its limits as rows for it (docs/safety.md, Unicycles).
    """

    tick: Final[int]
    position: Final[Vector]
    obstacle_ids: Final[tuple[int, ...]]
    obstacle_centres: Final[tuple[Vector, ...]]
    obstacle_radii: Final[tuple[float, ...]]
    agent_ids: Final[tuple[int, ...]]
    agent_positions: Final[tuple[Vector, ...]]
    movers: Final[tuple[Mover, ...]]
    heading: Final[float]

    def __init__(
        self,
        tick: int,
        position: Vector,
        obstacle_ids: tuple[int, ...],
        obstacle_centres: tuple[Vector, ...],
        obstacle_radii: tuple[float, ...],
        agent_ids: tuple[int, ...] = (),
        agent_positions: tuple[Vector, ...] = (),
        movers: tuple[Mover, ...] = (),
        heading: float = 0.0,
    ) -> None:
        self.tick = tick
        self.position = position
        self.obstacle_ids = obstacle_ids
        self.obstacle_centres = obstacle_centres
        self.obstacle_radii = obstacle_radii
        self.agent_ids = agent_ids
        self.agent_positions = agent_positions
        self.movers = movers
        self.heading = heading


@dataclass(init=False, slots=True, unsafe_hash=True)
class AgentState:
    """Agent → its neighbours at tick ``tick``: position (m), collision-course flag Ω_i, the
    current value of its σ bid in Algorithm 1, and the scale σ and rotation θ (rad) it applies.
    """

    agent_id: Final[int]
    tick: Final[int]
    position: Final[Vector]
    omega: Final[bool]
    bid: Final[float]
    sigma: Final[float]
    theta: Final[float]

    def __init__(
        self,
        agent_id: int,
        tick: int,
        position: Vector,
        omega: bool,
        bid: float,
        sigma: float,
        theta: float,
    ) -> None:
        self.agent_id = agent_id
        self.tick = tick
        self.position = position
        self.omega = omega
        self.bid = bid
        self.sigma = sigma
        self.theta = theta


@dataclass(init=False, slots=True, unsafe_hash=True)
class Command:
    """Agent → world: the velocity v_i (m/s) to hold during tick ``tick``; ``filtered``: the
    agent's safety filter changed its nominal velocity to get it."""

    agent_id: Final[int]
    tick: Final[int]
    velocity: Final[Vector]
    filtered: Final[bool]

    def __init__(self, agent_id: int, tick: int, velocity: Vector, filtered: bool = False) -> None:
        self.agent_id = agent_id
        self.tick = tick
        self.velocity = velocity
        self.filtered = filtered


@dataclass(init=False, slots=True, unsafe_hash=True)
class TickRecord:
    """World → all, once per tick: the ground truth of tick ``tick``.

    positions (n, dim) m at the start of the tick and velocities (n, dim) m/s held during it, as
    nested tuples in agent-id order; omega, bid, sigma, theta as each agent announced them; alive
    False for an agent the world holds still because its process is gone; filtered True where
    the agent's safety filter changed its nominal velocity that tick. mover_centres (m) and
    mover_velocities (m/s): every moving obstacle at the start of the tick and over it, in
    obstacle order (empty when none moves). headings (rad): every unicycle's heading at the
    start of the tick, agent-id order (empty for single integrators).
    """

    tick: Final[int]
    positions: Final[tuple[Vector, ...]]
    velocities: Final[tuple[Vector, ...]]
    omega: Final[tuple[bool, ...]]
    bid: Final[tuple[float, ...]]
    sigma: Final[tuple[float, ...]]
    theta: Final[tuple[float, ...]]
    alive: Final[tuple[bool, ...]]
    filtered: Final[tuple[bool, ...]]
    mover_centres: Final[tuple[Vector, ...]]
    mover_velocities: Final[tuple[Vector, ...]]
    headings: Final[tuple[float, ...]]

    def __init__(
        self,
        tick: int,
        positions: tuple[Vector, ...],
        velocities: tuple[Vector, ...],
        omega: tuple[bool, ...],
        bid: tuple[float, ...],
        sigma: tuple[float, ...],
        theta: tuple[float, ...],
        alive: tuple[bool, ...],
        filtered: tuple[bool, ...],
        mover_centres: tuple[Vector, ...] = (),
        mover_velocities: tuple[Vector, ...] = (),
        headings: tuple[float, ...] = (),
    ) -> None:
        self.tick = tick
        self.positions = positions
        self.velocities = velocities
        self.omega = omega
        self.bid = bid
        self.sigma = sigma
        self.theta = theta
        self.alive = alive
        self.filtered = filtered
        self.mover_centres = mover_centres
        self.mover_velocities = mover_velocities
        self.headings = headings


@dataclass(init=False, slots=True, unsafe_hash=True)
class Event:
    """World → all: a line for the log. level: 1 debug, 2 info, 3 warning, 4 error (as
    foxglove.Log); agent: the agent it is about, 0 if none."""

    tick: Final[int]
    level: Final[int]
    agent: Final[int]
    text: Final[str]

    def __init__(self, tick: int, level: int, agent: int, text: str) -> None:
        self.tick = tick
        self.level = level
        self.agent = agent
        self.text = text


@dataclass(init=False, slots=True, unsafe_hash=True)
class RobotsRecord:
    """World → all, each tick of a run that drives robots (issue 33): what the robots were sent
    and what they reported. twists: the command each robot was sent for the tick, (linear x,
    linear y, angular z) in m/s and rad/s in its own frame (a unicycle's linear y is 0); ages
    (s): how old each robot's pose was when the world read it at the tick's start (empty when
    the robots cannot tell). Agent-id order."""

    tick: Final[int]
    twists: Final[tuple[Vector, ...]]
    ages: Final[tuple[float, ...]]

    def __init__(self, tick: int, twists: tuple[Vector, ...], ages: tuple[float, ...] = ()) -> None:
        self.tick = tick
        self.twists = twists
        self.ages = ages


def _rebuilt(record: Any) -> tuple[type[Any], tuple[Any, ...]]:
    return type(record), tuple([getattr(record, f.name) for f in fields(record)])


def picklable(*classes: type[Any]) -> None:
    """Pickle and copy instances of these dataclasses as their class called on their fields'
    values, in either build (a compiled class with its own ``__init__`` cannot be rebuilt the
    default way: pickle calls it with no arguments)."""
    for cls in classes:
        copyreg.pickle(cls, _rebuilt)


picklable(Mover, Sensing, AgentState, Command, TickRecord, Event, RobotsRecord)
